#include "core/sim/reference_renderer.h"

#include <algorithm>
#include <cmath>

#include "core/sim/fast_math.h"
#include "core/util/parallel.h"

namespace spikems::sim {

namespace {

constexpr float kNear = 0.01f;
constexpr float kFar = 1e30f;
constexpr float kTwoPi = 6.2831853f;

struct V3 {
  float x, y, z;
};

// A shape ready for one frame: camera-frame ray directions map to local ones through M.
struct Prepared {
  const Shape* s;
  float M[9];
  V3 o;                // camera centre in the local frame
  V3 light;            // light direction in the local frame
  V3 h;                // half extents
  int x0, x1, y0, y1;  // screen-space box outside which the shape cannot be hit
};

inline V3 mul(const float* M, float x, float y, float z) {
  return {M[0] * x + M[1] * y + M[2] * z, M[3] * x + M[4] * y + M[5] * z,
          M[6] * x + M[7] * y + M[8] * z};
}

inline bool in_outline(Outline o, float px, float py, float hx, float hy) {
  switch (o) {
    case Outline::Rect:
      return std::fabs(px) <= hx && std::fabs(py) <= hy;
    case Outline::Disc:
      return (px * px) / (hx * hx) + (py * py) / (hy * hy) <= 1.f;
    case Outline::Star: {
      float r2 = px * px + py * py;
      if (r2 > hx * hx) return false;
      float th = std::atan2(py, px);
      float rmax = hx * (0.62f + 0.38f * std::cos(5.f * th));
      return r2 <= rmax * rmax;
    }
  }
  return false;
}

// Nearest hit parameter along o + t d (t is the camera z because d.z = 1), or kFar.
inline float intersect(const Prepared& p, const V3& d) {
  const V3& o = p.o;
  const V3& h = p.h;
  switch (p.s->kind) {
    case ShapeKind::Ellipsoid: {
      V3 os{o.x / h.x, o.y / h.y, o.z / h.z}, ds{d.x / h.x, d.y / h.y, d.z / h.z};
      float a = ds.x * ds.x + ds.y * ds.y + ds.z * ds.z;
      float b = os.x * ds.x + os.y * ds.y + os.z * ds.z;
      float c = os.x * os.x + os.y * os.y + os.z * os.z - 1.f;
      float disc = b * b - a * c;
      if (disc < 0) return kFar;
      float sq = std::sqrt(disc);
      float t = (-b - sq) / a;
      if (t > kNear) return t;
      t = (-b + sq) / a;
      return t > kNear ? t : kFar;
    }
    case ShapeKind::Box: {
      float tmin = -kFar, tmax = kFar;
      const float oo[3] = {o.x, o.y, o.z}, dd[3] = {d.x, d.y, d.z}, hh[3] = {h.x, h.y, h.z};
      for (int a = 0; a < 3; ++a) {
        if (std::fabs(dd[a]) < 1e-12f) {
          if (std::fabs(oo[a]) > hh[a]) return kFar;
          continue;
        }
        float inv = 1.f / dd[a];
        float t0 = (-hh[a] - oo[a]) * inv, t1 = (hh[a] - oo[a]) * inv;
        if (t0 > t1) std::swap(t0, t1);
        tmin = std::max(tmin, t0);
        tmax = std::min(tmax, t1);
      }
      if (tmax < tmin || tmax < kNear) return kFar;
      return tmin > kNear ? tmin : tmax;
    }
    case ShapeKind::Quad:
    case ShapeKind::Net: {
      if (std::fabs(d.z) < 1e-12f) return kFar;
      float t = -o.z / d.z;
      if (t <= kNear) return kFar;
      float px = o.x + t * d.x, py = o.y + t * d.y;
      if (p.s->kind == ShapeKind::Quad)
        return in_outline(p.s->outline, px, py, h.x, h.y) ? t : kFar;
      if (std::fabs(px) > h.x || std::fabs(py) > h.y) return kFar;
      if (p.s->net_pattern == NetPattern::Foliage) return p.s->leaf_at(px, py) ? t : kFar;
      const float sp = float(p.s->net_spacing), bar = float(p.s->net_bar);
      float mx = px / sp - fast_floor(px / sp);
      if (p.s->net_pattern == NetPattern::Bars) return mx * sp < bar ? t : kFar;
      float my = py / sp - fast_floor(py / sp);
      return (mx * sp < bar || my * sp < bar) ? t : kFar;
    }
    case ShapeKind::Room: {
      float t = kFar;
      if (d.x != 0) t = std::min(t, ((d.x > 0 ? h.x : -h.x) - o.x) / d.x);
      if (d.y != 0) t = std::min(t, ((d.y > 0 ? h.y : -h.y) - o.y) / d.y);
      if (d.z != 0) t = std::min(t, ((d.z > 0 ? h.z : -h.z) - o.z) / d.z);
      return t > kNear ? t : kFar;
    }
  }
  return kFar;
}

// Albedo x shading at the hit point of `p` at parameter t along camera direction dc.
inline float shade(const Scene& scene, const Prepared& p, const V3& dc, float t, float fx) {
  const Shape& s = *p.s;
  V3 d = mul(p.M, dc.x, dc.y, dc.z);
  V3 q{p.o.x + t * d.x, p.o.y + t * d.y, p.o.z + t * d.z};
  float dn = std::sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
  V3 n{0, 0, 1};
  float u = 0, v = 0;
  int tex = s.texture;
  bool two_sided = false;
  const float tile = float(s.tile_m);
  switch (s.kind) {
    case ShapeKind::Ellipsoid: {
      V3 g{q.x / (p.h.x * p.h.x), q.y / (p.h.y * p.h.y), q.z / (p.h.z * p.h.z)};
      float gn = std::sqrt(g.x * g.x + g.y * g.y + g.z * g.z);
      n = {g.x / gn, g.y / gn, g.z / gn};
      V3 e{q.x / p.h.x, q.y / p.h.y, q.z / p.h.z};
      float r = (p.h.x + p.h.y + p.h.z) / 3.f;
      float ku = std::max(1.f, std::round(kTwoPi * r / tile));
      float kv = std::max(1.f, std::round(3.14159265f * r / tile));
      u = (std::atan2(e.y, e.x) / kTwoPi + 0.5f) * ku;
      v = std::acos(std::clamp(e.z, -1.f, 1.f)) / 3.14159265f * kv;
      break;
    }
    case ShapeKind::Box: {
      float ax = std::fabs(q.x) / p.h.x, ay = std::fabs(q.y) / p.h.y, az = std::fabs(q.z) / p.h.z;
      if (ax >= ay && ax >= az) {
        n = {q.x > 0 ? 1.f : -1.f, 0, 0};
        u = q.y / tile;
        v = q.z / tile;
      } else if (ay >= az) {
        n = {0, q.y > 0 ? 1.f : -1.f, 0};
        u = q.x / tile;
        v = q.z / tile;
      } else {
        n = {0, 0, q.z > 0 ? 1.f : -1.f};
        u = q.x / tile;
        v = q.y / tile;
      }
      break;
    }
    case ShapeKind::Quad:
    case ShapeKind::Net:
      two_sided = true;
      u = q.x / tile;
      v = q.y / tile;
      break;
    case ShapeKind::Room: {
      // The wall hit is the one whose bound is reached (largest relative coordinate).
      float ax = std::fabs(q.x) / p.h.x, ay = std::fabs(q.y) / p.h.y, az = std::fabs(q.z) / p.h.z;
      if (ax >= ay && ax >= az) {
        n = {q.x > 0 ? -1.f : 1.f, 0, 0};
        u = q.z / tile;
        v = q.y / tile;
        tex = s.texture;
      } else if (ay >= az) {
        n = {0, q.y > 0 ? -1.f : 1.f, 0};
        u = q.x / tile;
        v = q.z / tile;
        tex = s.texture + 1;
      } else {
        n = {0, 0, q.z > 0 ? -1.f : 1.f};
        u = q.x / tile;
        v = q.y / tile;
        tex = s.texture + 2;
      }
      break;
    }
  }
  float cosi = std::fabs(n.x * d.x + n.y * d.y + n.z * d.z) / dn;
  float lam = n.x * p.light.x + n.y * p.light.y + n.z * p.light.z;
  lam = two_sided ? std::fabs(lam) : std::max(lam, 0.f);
  float albedo;
  if (s.kind == ShapeKind::Net) {
    albedo = float(s.albedo_scale);
  } else {
    // Footprint of the pixel on the surface, in texture tiles.
    float foot = t * dn / (fx * std::max(cosi, 0.15f)) / tile;
    albedo = scene.textures[size_t(tex)].sample(u, v, foot) * float(s.albedo_scale);
  }
  float amb = float(scene.ambient);
  return float(scene.illumination) * albedo * (amb + (1 - amb) * lam);
}

}  // namespace

ReferenceRenderer::ReferenceRenderer(const Scene& scene, const Camera& cam, double log_eps)
    : scene_(scene), cam_(cam), log_eps_(float(log_eps)) {
  rx_.resize(size_t(cam.width));
  ry_.resize(size_t(cam.height));
  for (int x = 0; x < cam.width; ++x) rx_[size_t(x)] = float((x - cam.cx) / cam.fx);
  for (int y = 0; y < cam.height; ++y) ry_[size_t(y)] = float((y - cam.cy) / cam.fy);
}

void ReferenceRenderer::render(double t_s, Frame& out, int threads) const {
  const int W = cam_.width, H = cam_.height;
  out.t_s = t_s;
  out.log_intensity.resize(size_t(W) * H);
  out.id.resize(size_t(W) * H);
  out.depth.resize(size_t(W) * H);
  out.surface.resize(size_t(W) * H);

  const Pose cp = scene_.camera.at(t_s);
  const Mat3 Rwc = cp.q.to_matrix();
  std::vector<Prepared> prep;
  std::vector<size_t> prep_index;  // shape index of each prepared entry
  prep.reserve(scene_.shapes.size());
  for (size_t si = 0; si < scene_.shapes.size(); ++si) {
    const Shape& s = scene_.shapes[si];
    Pose op = s.motion.at(t_s);
    Mat3 Rwo = op.q.to_matrix(), Row = Rwo.transposed();
    Mat3 M = Row * Rwc;
    Vec3 o = Row * (cp.t - op.t);
    Vec3 l = Row * scene_.light_dir;
    Prepared p;
    p.s = &s;
    for (int i = 0; i < 9; ++i) p.M[i] = float(M.m[size_t(i)]);
    p.o = {float(o.x), float(o.y), float(o.z)};
    p.light = {float(l.x), float(l.y), float(l.z)};
    p.h = {float(s.half.x), float(s.half.y), float(s.half.z)};
    p.x0 = 0, p.x1 = W - 1, p.y0 = 0, p.y1 = H - 1;
    if (s.kind == ShapeKind::Ellipsoid || s.kind == ShapeKind::Box ||
        (s.kind == ShapeKind::Quad && s.id != 0)) {
      // Conservative screen box of the bounding sphere (x/z over a box is extremal at corners).
      Vec3 c = Rwc.transposed() * (op.t - cp.t);
      double r = s.half.norm() * 1.01 + 1e-3;
      if (c.z - r > kNear) {
        double zs[2] = {c.z - r, c.z + r};
        double umin = 1e30, umax = -1e30, vmin = 1e30, vmax = -1e30;
        for (double z : zs)
          for (double sx : {-r, r})
            umin = std::min(umin, (c.x + sx) / z), umax = std::max(umax, (c.x + sx) / z);
        for (double z : zs)
          for (double sy : {-r, r})
            vmin = std::min(vmin, (c.y + sy) / z), vmax = std::max(vmax, (c.y + sy) / z);
        auto clampi = [](double v, int lo, int hi) {
          return int(std::clamp(v, double(lo), double(hi)));
        };
        p.x0 = clampi(std::floor(cam_.fx * umin + cam_.cx) - 1, -1, W);
        p.x1 = clampi(std::ceil(cam_.fx * umax + cam_.cx) + 1, -1, W);
        p.y0 = clampi(std::floor(cam_.fy * vmin + cam_.cy) - 1, -1, H);
        p.y1 = clampi(std::ceil(cam_.fy * vmax + cam_.cy) + 1, -1, H);
      } else if (c.z + r < kNear) {
        p.x0 = 1, p.x1 = 0;  // entirely behind the camera
      }
    }
    if (p.x0 <= p.x1 && p.y0 <= p.y1) {
      prep.push_back(p);
      prep_index.push_back(si);
    }
  }
  const float fx = float(cam_.fx);
  parallel_chunks(H, threads, [&](int, int y_begin, int y_end) {
    for (int y = y_begin; y < y_end; ++y) {
      const float ry = ry_[size_t(y)];
      for (int x = 0; x < W; ++x) {
        const V3 dc{rx_[size_t(x)], ry, 1.f};
        float best = kFar;
        int bi = -1;
        for (size_t k = 0; k < prep.size(); ++k) {
          const Prepared& p = prep[k];
          if (x < p.x0 || x > p.x1 || y < p.y0 || y > p.y1) continue;
          V3 d = mul(p.M, dc.x, dc.y, dc.z);
          float t = intersect(p, d);
          if (t < best) best = t, bi = int(k);
        }
        size_t i = size_t(y) * W + x;
        float I = 0;
        uint16_t id = 0;
        if (bi >= 0) {
          I = shade(scene_, prep[size_t(bi)], dc, best, fx);
          id = prep[size_t(bi)].s->id;
        }
        out.log_intensity[i] = fast_log(log_eps_ + I);
        out.id[i] = id;
        out.depth[i] = bi >= 0 ? best : 0.f;
        out.surface[i] = bi >= 0 ? uint8_t(std::min<size_t>(prep_index[size_t(bi)] + 1, 255)) : 0;
      }
    }
  });
}

}  // namespace spikems::sim
