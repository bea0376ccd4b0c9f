#include "core/sim/texture.h"

#include <algorithm>
#include <cmath>
#include <random>

#include "core/sim/fast_math.h"
#include "core/util/error.h"

namespace spikems::sim {

namespace {

constexpr double kTwoPi = 6.283185307179586;

// Deterministic hash of lattice coordinates -> [0,1).
double lattice(uint64_t seed, int i, int j) {
  uint64_t h = seed * 0x9E3779B97F4A7C15ull ^ (uint64_t(uint32_t(i)) * 0xBF58476D1CE4E5B9ull) ^
               (uint64_t(uint32_t(j)) * 0x94D049BB133111EBull);
  h ^= h >> 31;
  h *= 0xD6E8FEB86659FD93ull;
  h ^= h >> 32;
  return double(h >> 11) * (1.0 / 9007199254740992.0);
}

// Periodic value noise with `period` cells per tile at tile coordinates (u, v) in [0,1).
double value_noise(uint64_t seed, int period, double u, double v) {
  double x = u * period, y = v * period;
  int i = int(std::floor(x)), j = int(std::floor(y));
  double fx = x - i, fy = y - j;
  auto wrap = [period](int a) { return ((a % period) + period) % period; };
  auto s = [](double t) { return t * t * (3 - 2 * t); };
  double a = lattice(seed, wrap(i), wrap(j)), b = lattice(seed, wrap(i + 1), wrap(j));
  double c = lattice(seed, wrap(i), wrap(j + 1)), d = lattice(seed, wrap(i + 1), wrap(j + 1));
  double sx = s(fx), sy = s(fy);
  return (a * (1 - sx) + b * sx) * (1 - sy) + (c * (1 - sx) + d * sx) * sy;
}

double fbm(uint64_t seed, int base, double u, double v, int octaves) {
  double sum = 0, amp = 1, norm = 0;
  for (int o = 0; o < octaves; ++o) {
    sum += amp * value_noise(seed + uint64_t(o) * 7919, base << o, u, v);
    norm += amp;
    amp *= 0.5;
  }
  return sum / norm;
}

// Smooth square wave in [0,1]: sharp but not aliased at tile resolution.
double soft_square(double phase) {
  return std::clamp(0.5 + 2.5 * std::sin(phase), 0.0, 1.0);
}

// Smooth shading: a handful of broad Gaussians of either sign, summed over the 3 x 3
// neighbouring tiles so the result is periodic and smooth across the tile border.
std::vector<float> gradient_values(uint64_t seed) {
  const int n = Texture::kTile;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> U(0, 1);
  // A Gaussian is separable, and so is its sum over the 3 x 3 tiles: per bump, one periodic
  // profile per axis.
  const int count = 3 + int(U(rng) * 4);  // 3..6
  std::vector<double> amp(static_cast<size_t>(count));
  std::vector<double> gx(size_t(count) * n), gy(size_t(count) * n);
  for (int b = 0; b < count; ++b) {
    double bu = U(rng), bv = U(rng), sigma = 0.15 + 0.2 * U(rng);
    amp[size_t(b)] = 2 * U(rng) - 1;
    const double k2 = 1 / (2 * sigma * sigma);
    for (int x = 0; x < n; ++x) {
      double su = 0, sv = 0, u = (x + 0.5) / n;
      for (int i = -1; i <= 1; ++i) {
        su += std::exp(-(u - bu + i) * (u - bu + i) * k2);
        sv += std::exp(-(u - bv + i) * (u - bv + i) * k2);
      }
      gx[size_t(b) * n + x] = su;
      gy[size_t(b) * n + x] = sv;
    }
  }
  // A faint shading wave, one period per tile along an axis or a diagonal (integer wave
  // vector, so periodic).
  static constexpr int kDirs[4][2] = {{1, 0}, {0, 1}, {1, 1}, {1, -1}};
  const int* k = kDirs[int(U(rng) * 4)];
  double tilt = 0.3 * U(rng), phase = kTwoPi * U(rng);
  std::vector<float> out(size_t(n) * n);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      double u = (x + 0.5) / n, v = (y + 0.5) / n;
      double val = tilt * std::cos(kTwoPi * (k[0] * u + k[1] * v) + phase);
      for (int b = 0; b < count; ++b)
        val += amp[size_t(b)] * gx[size_t(b) * n + x] * gy[size_t(b) * n + y];
      out[size_t(y) * n + x] = float(val);
    }
  return out;
}

}  // namespace

DeadLeaves bake_dead_leaves(uint64_t seed) {
  const int n = Texture::kTile, S = DeadLeaves::kSuper, N = n * S;  // N: subsample grid
  std::vector<float> sub(size_t(N) * N, -1.0f);                     // -1: bare
  int64_t bare = int64_t(N) * N;
  std::vector<int> bare_in_row(size_t(N), N);  // lets late leaves skip covered rows
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> U(0, 1);
  // Inverse CDF of p(r) ~ r^-3 on [a, b]: r = (a^-2 - u (a^-2 - b^-2))^-1/2.
  const double ia2 = 1 / (DeadLeaves::kRMin * DeadLeaves::kRMin);
  const double ib2 = 1 / (DeadLeaves::kRMax * DeadLeaves::kRMax);
  DeadLeaves out;
  while (bare > 0 && out.leaves < DeadLeaves::kMaxLeaves) {
    ++out.leaves;
    const int shape = int(U(rng) * 3);  // 0 disc, 1 ellipse, 2 rectangle
    const double r = N / std::sqrt(ia2 - U(rng) * (ia2 - ib2));
    const double aspect = shape == 0 ? 1.0 : 0.3 + 0.7 * U(rng);
    const double th = kTwoPi * U(rng), c = std::cos(th), s = std::sin(th);
    const double cx = N * U(rng), cy = N * U(rng);
    const float val = float(U(rng));
    // Bounding half-extent; at most kRMax x sqrt(2) < 1/2 tile, so wrapping never overlaps.
    const double ext = shape == 2 ? r * std::sqrt(1 + aspect * aspect) : r;
    const double ir2 = 1 / (r * r), ib2s = 1 / (r * r * aspect * aspect), rb = r * aspect;
    const int x0 = int(std::floor(cx - ext)), x1 = int(std::ceil(cx + ext));
    const int y0 = int(std::floor(cy - ext)), y1 = int(std::ceil(cy + ext));
    for (int y = y0; y <= y1; ++y) {
      int& row_bare = bare_in_row[size_t(y & (N - 1))];
      if (row_bare == 0) continue;
      float* row = &sub[size_t(y & (N - 1)) * N];
      const double dy = y + 0.5 - cy;
      for (int x = x0; x <= x1; ++x) {
        float& px = row[x & (N - 1)];
        if (px >= 0) continue;
        const double dx = x + 0.5 - cx;
        const double a = dx * c + dy * s, b = -dx * s + dy * c;
        const bool in =
            shape == 2 ? std::fabs(a) <= r && std::fabs(b) <= rb : a * a * ir2 + b * b * ib2s <= 1;
        if (in) {
          px = val;
          --bare;
          --row_bare;
        }
      }
    }
  }
  out.holes = bare;
  if (bare > 0) {  // a last leaf behind all others
    const float val = float(U(rng));
    for (auto& px : sub)
      if (px < 0) px = val;
  }
  out.v.assign(size_t(n) * n, 0.0f);
  const float w = 1.0f / float(S * S);
  for (int y = 0; y < N; ++y)
    for (int x = 0; x < N; ++x) out.v[size_t(y / S) * n + x / S] += sub[size_t(y) * N + x] * w;
  return out;
}

TextureKind texture_kind_from_name(const std::string& n) {
  if (n == "noise") return TextureKind::Noise;
  if (n == "stripes") return TextureKind::Stripes;
  if (n == "checkers") return TextureKind::Checkers;
  if (n == "grid") return TextureKind::Grid;
  if (n == "blobs") return TextureKind::Blobs;
  if (n == "natural") return TextureKind::Natural;
  if (n == "uniform") return TextureKind::Uniform;
  if (n == "dead_leaves") return TextureKind::DeadLeaves;
  if (n == "gradient") return TextureKind::Gradient;
  fail("texture", "",
       "unknown texture kind '" + n + "' (use " + texture_kind_names() + ", or dir:PATH)");
}

bool is_texture_kind_name(const std::string& n) {
  for (auto k : {TextureKind::Noise, TextureKind::Stripes, TextureKind::Checkers, TextureKind::Grid,
                 TextureKind::Blobs, TextureKind::Natural, TextureKind::Uniform,
                 TextureKind::DeadLeaves, TextureKind::Gradient})
    if (n == texture_kind_name(k)) return true;
  return false;
}

const char* texture_kind_names() {
  return "noise stripes checkers grid blobs natural uniform dead_leaves gradient";
}

const char* texture_kind_name(TextureKind k) {
  switch (k) {
    case TextureKind::Noise:
      return "noise";
    case TextureKind::Stripes:
      return "stripes";
    case TextureKind::Checkers:
      return "checkers";
    case TextureKind::Grid:
      return "grid";
    case TextureKind::Blobs:
      return "blobs";
    case TextureKind::Natural:
      return "natural";
    case TextureKind::Uniform:
      return "uniform";
    case TextureKind::DeadLeaves:
      return "dead_leaves";
    case TextureKind::Gradient:
      return "gradient";
    case TextureKind::Image:
      return "image";
  }
  return "?";
}

std::vector<float> texture_values(const TextureParams& p) {
  const int n = Texture::kTile;
  const int f = std::max(1, p.frequency);
  std::vector<float> img(size_t(n) * n);
  // Blobs: random discs placed periodically.
  struct Blob {
    double u, v, r, val;
  };
  std::vector<Blob> blobs;
  if (p.kind == TextureKind::Blobs) {
    std::mt19937_64 rng(p.seed);
    std::uniform_real_distribution<double> U(0, 1);
    int count = f * f;
    for (int i = 0; i < count; ++i)
      blobs.push_back({U(rng), U(rng), (0.2 + 0.5 * U(rng)) / f, U(rng) < 0.5 ? 0.0 : 1.0});
  }
  // Stripes run along an angle that keeps the tile periodic: integer wave vector.
  int kx = int(std::lround(f * std::cos(p.angle))), ky = int(std::lround(f * std::sin(p.angle)));
  if (kx == 0 && ky == 0) kx = 1;
  if (p.kind == TextureKind::DeadLeaves) img = bake_dead_leaves(p.seed).v;
  if (p.kind == TextureKind::Gradient) img = gradient_values(p.seed);
  if (p.kind == TextureKind::Image) {
    if (!p.image || p.image->size() != img.size())
      fail(p.image_path, "", "image texture is not a " + std::to_string(n) + "^2 tile");
    img = *p.image;
  }
  for (int y = 0; y < n; ++y) {
    for (int x = 0; x < n; ++x) {
      double u = (x + 0.5) / n, v = (y + 0.5) / n, val = 0.5;
      switch (p.kind) {
        case TextureKind::Noise:
          val = fbm(p.seed, f, u, v, 5);
          break;
        case TextureKind::Stripes:
          val = soft_square(kTwoPi * (kx * u + ky * v));
          break;
        case TextureKind::Checkers: {
          double s = std::sin(kTwoPi * f * u) * std::sin(kTwoPi * f * v);
          val = std::clamp(0.5 + 4 * s, 0.0, 1.0);
          break;
        }
        case TextureKind::Grid: {
          double gu = std::fabs(std::sin(M_PI * f * u)), gv = std::fabs(std::sin(M_PI * f * v));
          double line = std::min(gu, gv);
          val = line < 0.15 ? 0.0 : 1.0 - 0.3 * fbm(p.seed, 8, u, v, 3);
          break;
        }
        case TextureKind::Blobs: {
          val = 0.4 + 0.2 * fbm(p.seed, 4, u, v, 3);
          for (const auto& b : blobs) {
            double du = u - b.u, dv = v - b.v;
            du -= std::round(du);
            dv -= std::round(dv);
            double d = std::sqrt(du * du + dv * dv) / b.r;
            if (d < 1)
              val = b.val * std::clamp((1 - d) * 8, 0.0, 1.0) +
                    val * (1 - std::clamp((1 - d) * 8, 0.0, 1.0));
          }
          break;
        }
        case TextureKind::Natural: {
          // Domain-warped fBm: irregular, bark/stone-like patterns.
          double wu = fbm(p.seed + 11, f, u, v, 3), wv = fbm(p.seed + 23, f, u, v, 3);
          double uu = u + 0.35 * (wu - 0.5), vv = v + 0.35 * (wv - 0.5);
          uu -= std::floor(uu);
          vv -= std::floor(vv);
          val = fbm(p.seed, f, uu, vv, 6);
          break;
        }
        case TextureKind::Uniform:
          val = 0.5;
          break;
        case TextureKind::DeadLeaves:
        case TextureKind::Gradient:
        case TextureKind::Image:
          val = img[size_t(y) * n + x];  // baked above
          break;
      }
      img[size_t(y) * n + x] = float(val);
    }
  }
  // Normalise to [0,1].
  auto [mn, mx] = std::minmax_element(img.begin(), img.end());
  float lo = *mn, hi = *mx;
  for (auto& v : img) v = hi > lo ? (v - lo) / (hi - lo) : 0.5f;
  // After the normalisation, so a patch keeps the level 1/2 that the albedo map sends to `mean`.
  if (p.flat_fraction > 0) apply_flat_patches(img, p.flat_fraction, p.seed ^ 0x9e3779b97f4a7c15ull);
  return img;
}

double apply_flat_patches(std::vector<float>& v, double fraction, uint64_t seed) {
  const int n = Texture::kTile;
  if (v.size() != size_t(n) * n)
    fail("texture", "", "flat patches need a " + std::to_string(n) + "^2 tile");
  if (!(fraction >= 0 && fraction <= 1)) fail("texture", "", "flat fraction must be in [0, 1]");
  // Per texel the smallest contrast factor of the patches over it (1 = outside every patch).
  std::vector<float> k(v.size(), 1.0f);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> U(0, 1);
  size_t covered = 0;
  const size_t target = size_t(std::ceil(fraction * double(v.size())));
  for (int i = 0; i < kMaxFlatPatches && covered < target; ++i) {
    const bool disc = U(rng) < 0.3;
    const double cu = U(rng), cv = U(rng);
    const double hu = 0.08 + 0.22 * U(rng), hv = disc ? hu : 0.08 + 0.22 * U(rng);
    const float factor = float(0.3 * U(rng));
    // Texel rows and columns the patch's box spans, wrapped onto the tile.
    const int x0 = int(std::floor((cu - hu) * n)), x1 = int(std::ceil((cu + hu) * n));
    const int y0 = int(std::floor((cv - hv) * n)), y1 = int(std::ceil((cv + hv) * n));
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x) {
        const double du = (x + 0.5) / n - cu, dv = (y + 0.5) / n - cv;
        const bool inside =
            disc ? du * du + dv * dv < hu * hu : std::fabs(du) < hu && std::fabs(dv) < hv;
        if (!inside) continue;
        float& kk = k[size_t((y % n + n) % n) * n + size_t((x % n + n) % n)];
        if (kk == 1.0f) ++covered;
        kk = std::min(kk, factor);
      }
  }
  for (size_t i = 0; i < v.size(); ++i) v[i] = 0.5f + (v[i] - 0.5f) * k[i];
  return double(covered) / double(v.size());
}

Texture::Texture(const TextureParams& p) : params_(p) {
  const int n = kTile;
  // Albedo = mean * exp(log_contrast * (v - 0.5)).
  std::vector<float> img = texture_values(p);
  for (auto& v : img)
    v = float(std::clamp(p.mean * std::exp(p.log_contrast * (v - 0.5)), 0.01, 1.0));
  mips_.push_back(std::move(img));
  for (int s = n / 2; s >= 1; s /= 2) {
    const auto& prev = mips_.back();
    std::vector<float> m(size_t(s) * s);
    for (int y = 0; y < s; ++y)
      for (int x = 0; x < s; ++x) {
        size_t ps = size_t(s) * 2;
        m[size_t(y) * s + x] =
            0.25f * (prev[(2 * y) * ps + 2 * x] + prev[(2 * y) * ps + 2 * x + 1] +
                     prev[(2 * y + 1) * ps + 2 * x] + prev[(2 * y + 1) * ps + 2 * x + 1]);
      }
    mips_.push_back(std::move(m));
  }
}

}  // namespace spikems::sim
