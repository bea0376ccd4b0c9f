// Row-at-a-time ray casting. Every step is a loop over the pixels of one row with no branch per
// pixel, so the compiler vectorises it:
//   1. per shape whose screen box meets the row: intersect its span of pixels and keep the
//      nearest hit (per-kind intersection functions, written branch-free);
//   2. per shape: shading parameters (texture, u, v, footprint, shading factor) of the pixels it
//      won (the room, which covers most pixels, branch-free; other kinds per pixel);
//   3. texture sampling (sample_row: Texture::sample's mip level and taps for a row) and log.
// Each pixel evaluates the same expressions in the same order as ReferenceRenderer (this file
// is built without fused multiply-adds), so the output is bit-identical to it;
// tests/core/sim/test_renderer.cpp checks that on random scenes of several presets.
#include "core/sim/renderer.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "core/sim/fast_math.h"
#include "core/util/error.h"
#include "core/util/parallel.h"

// One clone per instruction set for the row loops (chosen at load time); IEEE operations
// without contraction round alike in every clone, so the output does not depend on the CPU.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && \
    !defined(SPIKEMS_NO_MULTIVERSION)
#define SIM_ROW_CLONES __attribute__((target_clones("avx2", "avx", "sse4.1", "default")))
#else
#define SIM_ROW_CLONES
#endif

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
  uint8_t surface;     // shape index + 1 (saturated)
};

// Direction of pixel (rx, ry, 1) in the shape's frame: the same expression (and rounding) as a
// 3x3 product with z = 1.
inline V3 local_dir(const Prepared& p, float rx, float ry) {
  return {p.M[0] * rx + p.M[1] * ry + p.M[2], p.M[3] * rx + p.M[4] * ry + p.M[5],
          p.M[6] * rx + p.M[7] * ry + p.M[8]};
}

inline float sel(bool c, float a, float b) {
  return c ? a : b;
}

// Per-kind nearest hit parameter along o + t d (t = camera z since d.z = 1 in the camera
// frame), or kFar. Branch-free forms of the reference's tests.
inline float hit_ellipsoid(const Prepared& p, const V3& d) {
  const V3& o = p.o;
  const V3& h = p.h;
  const float osx = o.x / h.x, osy = o.y / h.y, osz = o.z / h.z;
  const float dsx = d.x / h.x, dsy = d.y / h.y, dsz = d.z / h.z;
  const float a = dsx * dsx + dsy * dsy + dsz * dsz;
  const float b = osx * dsx + osy * dsy + osz * dsz;
  const float c = osx * osx + osy * osy + osz * osz - 1.f;
  const float disc = b * b - a * c;
  const float sq = std::sqrt(std::max(disc, 0.f));
  const float t0 = (-b - sq) / a, t1 = (-b + sq) / a;
  const float t = sel(t0 > kNear, t0, sel(t1 > kNear, t1, kFar));
  return sel(disc < 0, kFar, t);
}

inline float hit_box(const Prepared& p, const V3& d) {
  const float oo[3] = {p.o.x, p.o.y, p.o.z}, dd[3] = {d.x, d.y, d.z}, hh[3] = {p.h.x, p.h.y, p.h.z};
  float tmin = -kFar, tmax = kFar;
  bool miss = false;
  for (int a = 0; a < 3; ++a) {
    const bool flat = std::fabs(dd[a]) < 1e-12f;
    miss = miss | (flat & (std::fabs(oo[a]) > hh[a]));
    const float inv = 1.f / dd[a];
    const float t0 = (-hh[a] - oo[a]) * inv, t1 = (hh[a] - oo[a]) * inv;
    const float lo = sel(t0 > t1, t1, t0), hi = sel(t0 > t1, t0, t1);
    tmin = sel(flat, tmin, std::max(tmin, lo));
    tmax = sel(flat, tmax, std::min(tmax, hi));
  }
  const bool none = miss | (tmax < tmin) | (tmax < kNear);
  return sel(none, kFar, sel(tmin > kNear, tmin, tmax));
}

// Plane z = 0 of a quad or net: t, and the hit point (px, py); t = kFar when missed.
inline float hit_plane(const Prepared& p, const V3& d, float& px, float& py) {
  const float t = -p.o.z / d.z;
  px = p.o.x + t * d.x;
  py = p.o.y + t * d.y;
  return sel((std::fabs(d.z) < 1e-12f) | (t <= kNear), kFar, t);
}

inline float hit_quad_rect(const Prepared& p, const V3& d) {
  float px, py;
  const float t = hit_plane(p, d, px, py);
  return sel((std::fabs(px) <= p.h.x) & (std::fabs(py) <= p.h.y), t, kFar);
}

inline float hit_quad_disc(const Prepared& p, const V3& d) {
  float px, py;
  const float t = hit_plane(p, d, px, py);
  const float hx = p.h.x, hy = p.h.y;
  return sel((px * px) / (hx * hx) + (py * py) / (hy * hy) <= 1.f, t, kFar);
}

// Star: atan2 and cos do not vectorise; this one stays per pixel.
inline float hit_quad_star(const Prepared& p, const V3& d) {
  float px, py;
  const float t = hit_plane(p, d, px, py);
  if (t == kFar) return kFar;
  const float hx = p.h.x;
  const float r2 = px * px + py * py;
  if (r2 > hx * hx) return kFar;
  const float th = std::atan2(py, px);
  const float rmax = hx * (0.62f + 0.38f * std::cos(5.f * th));
  return r2 <= rmax * rmax ? t : kFar;
}

inline float hit_net(const Prepared& p, const V3& d) {
  float px, py;
  const float t = hit_plane(p, d, px, py);
  const bool inside = (std::fabs(px) <= p.h.x) & (std::fabs(py) <= p.h.y);
  if (p.s->net_pattern == NetPattern::Foliage)  // `inside` first: leaf_at reads a bounded field
    return (inside && p.s->leaf_at(px, py)) ? t : kFar;
  const float sp = float(p.s->net_spacing), bar = float(p.s->net_bar);
  const float mx = px / sp - fast_floor(px / sp), my = py / sp - fast_floor(py / sp);
  if (p.s->net_pattern == NetPattern::Bars) return sel(inside & (mx * sp < bar), t, kFar);
  return sel(inside & ((mx * sp < bar) | (my * sp < bar)), t, kFar);
}

// The room seen from inside: the exit wall, i.e. the nearest of the three bounds the ray
// moves towards.
inline float hit_room(const Prepared& p, const V3& d) {
  const V3& o = p.o;
  const V3& h = p.h;
  float t = kFar;
  const float tx = (sel(d.x > 0, h.x, -h.x) - o.x) / d.x;
  const float ty = (sel(d.y > 0, h.y, -h.y) - o.y) / d.y;
  const float tz = (sel(d.z > 0, h.z, -h.z) - o.z) / d.z;
  t = sel(d.x != 0, std::min(t, tx), t);
  t = sel(d.y != 0, std::min(t, ty), t);
  t = sel(d.z != 0, std::min(t, tz), t);
  return sel(t > kNear, t, kFar);
}

// Keeps the nearest hit of shape k over pixels [xa, xb] of a row (strictly nearer wins, shapes
// in order: the reference's tie rule).
template <float (*Hit)(const Prepared&, const V3&)>
__attribute__((always_inline)) inline void hit_span(const Prepared& p, const float* rx, float ry,
                                                    int xa, int xb, int32_t k, float* best,
                                                    int32_t* bk) {
  for (int x = xa; x <= xb; ++x) {
    const float t = Hit(p, local_dir(p, rx[x], ry));
    const float b = best[x];
    const int32_t kb = bk[x];
    const bool nearer = t < b;
    best[x] = sel(nearer, t, b);
    bk[x] = nearer ? k : kb;
  }
}

// Shading inputs of one pixel; the intensity is illum * (albedo * scale) * light_term with
// albedo = texture sample (tex >= 0) or 1 (tex < 0: the net's plain bars).
struct ShadeOut {
  int32_t* tex;
  float *u, *v, *foot, *scale, *light;
};

// The room: wall choice, normal, texture coordinates and footprint without branches.
__attribute__((always_inline)) inline void shade_room_span(const Prepared& p, const float* rx,
                                                           float ry, int xa, int xb, int32_t k,
                                                           const float* best, const int32_t* bk,
                                                           float fx, ShadeOut o) {
  const Shape& s = *p.s;
  const float tile = float(s.tile_m), scale = float(s.albedo_scale);
  const int32_t tex0 = s.texture;
  for (int x = xa; x <= xb; ++x) {
    const float t = best[x];
    const V3 d = local_dir(p, rx[x], ry);
    const V3 q{p.o.x + t * d.x, p.o.y + t * d.y, p.o.z + t * d.z};
    const float dn = std::sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
    const float ax = std::fabs(q.x) / p.h.x, ay = std::fabs(q.y) / p.h.y,
                az = std::fabs(q.z) / p.h.z;
    const bool wx = (ax >= ay) & (ax >= az);
    const bool wy = !wx & (ay >= az);
    const bool wz = !wx & !wy;
    const float nx = sel(wx, sel(q.x > 0, -1.f, 1.f), 0.f);
    const float ny = sel(wy, sel(q.y > 0, -1.f, 1.f), 0.f);
    const float nz = sel(wz, sel(q.z > 0, -1.f, 1.f), 0.f);
    const float u = sel(wx, q.z, q.x) / tile;
    const float v = sel(wy, q.z, q.y) / tile;
    const float cosi = std::fabs(nx * d.x + ny * d.y + nz * d.z) / dn;
    const float lam = std::max(nx * p.light.x + ny * p.light.y + nz * p.light.z, 0.f);
    const float foot = t * dn / (fx * std::max(cosi, 0.15f)) / tile;
    const bool mine = bk[x] == k;
    const int32_t tex_old = o.tex[x];
    const float u_old = o.u[x], v_old = o.v[x], foot_old = o.foot[x], scale_old = o.scale[x],
                light_old = o.light[x];
    o.tex[x] = mine ? tex0 + int32_t(!wx) + int32_t(wz) : tex_old;
    o.u[x] = sel(mine, u, u_old);
    o.v[x] = sel(mine, v, v_old);
    o.foot[x] = sel(mine, foot, foot_old);
    o.scale[x] = sel(mine, scale, scale_old);
    o.light[x] = sel(mine, lam, light_old);
  }
}

// Any other kind, one pixel at a time (objects cover few pixels).
inline void shade_pixel(const Prepared& p, const V3& dc, float t, float fx, ShadeOut o, int x) {
  const Shape& s = *p.s;
  V3 d = local_dir(p, dc.x, dc.y);
  V3 q{p.o.x + t * d.x, p.o.y + t * d.y, p.o.z + t * d.z};
  float dn = std::sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
  V3 n{0, 0, 1};
  float u = 0, v = 0;
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
    case ShapeKind::Room:  // shaded by shade_room_span
      two_sided = true;
      u = q.x / tile;
      v = q.y / tile;
      break;
  }
  float cosi = std::fabs(n.x * d.x + n.y * d.y + n.z * d.z) / dn;
  float lam = n.x * p.light.x + n.y * p.light.y + n.z * p.light.z;
  o.light[x] = two_sided ? std::fabs(lam) : std::max(lam, 0.f);
  o.scale[x] = float(s.albedo_scale);
  if (s.kind == ShapeKind::Net) {
    o.tex[x] = -1;
  } else {
    o.tex[x] = s.texture;
    o.u[x] = u;
    o.v[x] = v;
    // Footprint of the pixel on the surface, in texture tiles.
    o.foot[x] = t * dn / (fx * std::max(cosi, 0.15f)) / tile;
  }
}

struct RowScratch {
  std::vector<float> best, u, v, foot, scale, light, albedo, a, ax[2], ay[2], tap[9];
  std::vector<int32_t> bk, tex, l0, mode, idx[2][4];
  explicit RowScratch(int W) {
    for (auto* f :
         {&best, &u, &v, &foot, &scale, &light, &albedo, &a, &ax[0], &ax[1], &ay[0], &ay[1]})
      f->resize(size_t(W));
    for (auto& f : tap) f.resize(size_t(W));
    for (auto* f : {&bk, &tex, &l0, &mode}) f->resize(size_t(W));
    for (auto& l : idx)
      for (auto& f : l) f.resize(size_t(W));
  }
};

// Texture::sample for a row of pixels: the same expressions, split into a vectorised pass
// (wrap, mip level, tap indices and weights), a scalar pass (the loads) and a vectorised blend.
// levels[tex * n_levels + l] is level l of texture tex; coarsest[tex] its 1x1 level.
__attribute__((always_inline)) inline void sample_row(int W, const int32_t* tex, const float* U,
                                                      const float* V, const float* foot,
                                                      const float* const* levels, int n_levels,
                                                      RowScratch& r, float* out) {
  constexpr int kLog2Tile = 8;
  static_assert(Texture::kTile == 1 << kLog2Tile);
  const int last = n_levels - 1;
  int32_t* l0v = r.l0.data();
  int32_t* mode = r.mode.data();  // 0 trilinear, 1 level 0 only, 2 the coarsest texel
  float* av = r.a.data();
  for (int x = 0; x < W; ++x) {
    float u = U[x], v = V[x];
    const bool ok = (std::fabs(u) < 1e6f) & (std::fabs(v) < 1e6f);  // also NaN
    u = sel(ok, u, 0.f);
    v = sel(ok, v, 0.f);
    u -= fast_floor(u);
    v -= fast_floor(v);
    const float lod = fast_log2(std::max(foot[x] * Texture::kTile, 1e-6f));
    const bool fine = lod <= 0, flat = (!ok) | ((!fine) & (lod >= float(last)));
    const int32_t l = int32_t(sel(fine | flat, 0.f, lod));
    l0v[x] = l;
    av[x] = lod - float(l);
    mode[x] = int32_t(flat) * 2 + int32_t(fine & !flat);
    for (int k = 0; k < 2; ++k) {
      // s = kTile >> (l + k) as a float, from its exponent bits (no variable shifts in SSE).
      const int32_t eb = (127 + kLog2Tile - l - k) << 23;
      float s;
      std::memcpy(&s, &eb, 4);
      const int32_t si = int32_t(s), m = si - 1;
      const float xs = u * s - 0.5f, ys = v * s - 0.5f;
      const float fx0 = fast_floor(xs), fy0 = fast_floor(ys);
      r.ax[k][size_t(x)] = xs - fx0;
      r.ay[k][size_t(x)] = ys - fy0;
      const int32_t x0 = int32_t(fx0) & m, y0 = int32_t(fy0) & m;
      const int32_t x1 = (x0 + 1) & m, y1 = (y0 + 1) & m;
      r.idx[k][0][size_t(x)] = y0 * si + x0;
      r.idx[k][1][size_t(x)] = y0 * si + x1;
      r.idx[k][2][size_t(x)] = y1 * si + x0;
      r.idx[k][3][size_t(x)] = y1 * si + x1;
    }
  }
  for (int x = 0; x < W; ++x) {
    if (tex[x] < 0) continue;
    const float* const* lv = levels + size_t(tex[x]) * size_t(n_levels);
    const float* b0 = lv[l0v[x]];
    const float* b1 = lv[l0v[x] + 1];
    for (int j = 0; j < 4; ++j) {
      r.tap[j][size_t(x)] = b0[r.idx[0][j][size_t(x)]];
      r.tap[4 + j][size_t(x)] = b1[r.idx[1][j][size_t(x)]];
    }
    r.tap[8][size_t(x)] = lv[last][0];
  }
  for (int x = 0; x < W; ++x) {
    float b[2];
    for (int k = 0; k < 2; ++k) {
      const float ax = r.ax[k][size_t(x)], ay = r.ay[k][size_t(x)];
      const float t00 = r.tap[4 * k][size_t(x)], t01 = r.tap[4 * k + 1][size_t(x)],
                  t10 = r.tap[4 * k + 2][size_t(x)], t11 = r.tap[4 * k + 3][size_t(x)];
      b[k] = (t00 * (1 - ax) + t01 * ax) * (1 - ay) + (t10 * (1 - ax) + t11 * ax) * ay;
    }
    const float a = av[x];
    const float tri = b[0] * (1 - a) + b[1] * a;
    const float coarsest = r.tap[8][size_t(x)];
    const int32_t m = mode[x];
    out[x] = sel(m == 2, coarsest, sel(m == 1, b[0], tri));
  }
}

struct FrameConst {
  const Scene* scene;
  const Prepared* prep;
  int n_prep;
  const float* rx;
  int W;
  float fx, log_eps, illum, amb;
  const float* const* levels;  // texture t, mip level l: levels[t * n_levels + l]
  int n_levels;
};

SIM_ROW_CLONES
void render_row(const FrameConst& c, int y, float ry, RowScratch& r, float* L, uint16_t* id,
                float* depth, uint8_t* surface) {
  const int W = c.W;
  float* best = r.best.data();
  int32_t* bk = r.bk.data();
  for (int x = 0; x < W; ++x) best[x] = kFar, bk[x] = -1;
  // 1. nearest hit
  for (int k = 0; k < c.n_prep; ++k) {
    const Prepared& p = c.prep[k];
    if (y < p.y0 || y > p.y1) continue;
    const int xa = std::max(p.x0, 0), xb = std::min(p.x1, W - 1);
    if (xa > xb) continue;
    switch (p.s->kind) {
      case ShapeKind::Ellipsoid:
        hit_span<hit_ellipsoid>(p, c.rx, ry, xa, xb, k, best, bk);
        break;
      case ShapeKind::Box:
        hit_span<hit_box>(p, c.rx, ry, xa, xb, k, best, bk);
        break;
      case ShapeKind::Quad:
        if (p.s->outline == Outline::Rect)
          hit_span<hit_quad_rect>(p, c.rx, ry, xa, xb, k, best, bk);
        else if (p.s->outline == Outline::Disc)
          hit_span<hit_quad_disc>(p, c.rx, ry, xa, xb, k, best, bk);
        else
          hit_span<hit_quad_star>(p, c.rx, ry, xa, xb, k, best, bk);
        break;
      case ShapeKind::Net:
        hit_span<hit_net>(p, c.rx, ry, xa, xb, k, best, bk);
        break;
      case ShapeKind::Room:
        hit_span<hit_room>(p, c.rx, ry, xa, xb, k, best, bk);
        break;
    }
  }
  // 2. shading inputs of the pixels each shape won
  ShadeOut so{r.tex.data(), r.u.data(), r.v.data(), r.foot.data(), r.scale.data(), r.light.data()};
  for (int k = 0; k < c.n_prep; ++k) {
    const Prepared& p = c.prep[k];
    if (y < p.y0 || y > p.y1) continue;
    const int xa = std::max(p.x0, 0), xb = std::min(p.x1, W - 1);
    if (p.s->kind == ShapeKind::Room) {
      shade_room_span(p, c.rx, ry, xa, xb, k, best, bk, c.fx, so);
    } else {
      for (int x = xa; x <= xb; ++x)
        if (bk[x] == k) shade_pixel(p, V3{c.rx[x], ry, 1.f}, best[x], c.fx, so, x);
    }
  }
  // 3. albedo, intensity and log
  float* albedo = r.albedo.data();
  int32_t* tex = r.tex.data();
  for (int x = 0; x < W; ++x) {
    const int32_t tx = tex[x];
    tex[x] = bk[x] >= 0 ? tx : -1;
  }
  sample_row(W, tex, r.u.data(), r.v.data(), r.foot.data(), c.levels, c.n_levels, r, albedo);
  for (int x = 0; x < W; ++x) {
    const float al = albedo[x];
    albedo[x] = sel(tex[x] >= 0, al, 1.f);
  }
  const float* scale = r.scale.data();
  const float* light = r.light.data();
  const float amb = c.amb, illum = c.illum, eps = c.log_eps;
  for (int x = 0; x < W; ++x) {
    const bool hit = bk[x] >= 0;
    const float I = illum * (albedo[x] * scale[x]) * (amb + (1 - amb) * light[x]);
    const float t = best[x];
    L[x] = fast_log(eps + sel(hit, I, 0.f));
    depth[x] = sel(hit, t, 0.f);
  }
  for (int x = 0; x < W; ++x) {
    const int k = bk[x];
    id[x] = k >= 0 ? c.prep[k].s->id : 0;
    surface[x] = k >= 0 ? c.prep[k].surface : 0;
  }
}

}  // namespace

Renderer::Renderer(const Scene& scene, const Camera& cam, double log_eps)
    : scene_(scene), cam_(cam), log_eps_(float(log_eps)) {
  rx_.resize(size_t(cam.width));
  ry_.resize(size_t(cam.height));
  for (int x = 0; x < cam.width; ++x) rx_[size_t(x)] = float((x - cam.cx) / cam.fx);
  for (int y = 0; y < cam.height; ++y) ry_[size_t(y)] = float((y - cam.cy) / cam.fy);
  n_levels_ = scene.textures.empty() ? 1 : scene.textures[0].levels();
  for (const Texture& t : scene.textures) {
    if (t.levels() != n_levels_) throw Error("renderer: textures with different mip counts");
    for (int l = 0; l < n_levels_; ++l) levels_.push_back(t.level_data(l));
  }
}

void Renderer::render(double t_s, Frame& out, int threads) const {
  const int W = cam_.width, H = cam_.height;
  out.t_s = t_s;
  out.log_intensity.resize(size_t(W) * H);
  out.id.resize(size_t(W) * H);
  out.depth.resize(size_t(W) * H);
  out.surface.resize(size_t(W) * H);

  const Pose cp = scene_.camera.at(t_s);
  const Mat3 Rwc = cp.q.to_matrix();
  std::vector<Prepared> prep;
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
    p.surface = uint8_t(std::min<size_t>(si + 1, 255));
    p.x0 = 0, p.x1 = W - 1, p.y0 = 0, p.y1 = H - 1;
    // Every finite shape (objects, static look-alikes, background planes: a box covering the
    // screen costs nothing); the room and the occluders span the view.
    if (s.kind == ShapeKind::Ellipsoid || s.kind == ShapeKind::Box || s.kind == ShapeKind::Quad) {
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
    if (p.x0 <= p.x1 && p.y0 <= p.y1) prep.push_back(p);
  }
  const FrameConst fc{&scene_,
                      prep.data(),
                      int(prep.size()),
                      rx_.data(),
                      W,
                      float(cam_.fx),
                      log_eps_,
                      float(scene_.illumination),
                      float(scene_.ambient),
                      levels_.data(),
                      n_levels_};
  parallel_chunks(H, threads, [&](int, int y_begin, int y_end) {
    RowScratch r(W);
    for (int y = y_begin; y < y_end; ++y) {
      const size_t i = size_t(y) * size_t(W);
      render_row(fc, y, ry_[size_t(y)], r, &out.log_intensity[i], &out.id[i], &out.depth[i],
                 &out.surface[i]);
    }
  });
}

}  // namespace spikems::sim
