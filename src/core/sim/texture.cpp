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

}  // namespace

TextureKind texture_kind_from_name(const std::string& n) {
  if (n == "noise") return TextureKind::Noise;
  if (n == "stripes") return TextureKind::Stripes;
  if (n == "checkers") return TextureKind::Checkers;
  if (n == "grid") return TextureKind::Grid;
  if (n == "blobs") return TextureKind::Blobs;
  if (n == "natural") return TextureKind::Natural;
  if (n == "uniform") return TextureKind::Uniform;
  fail("texture", "",
       "unknown texture kind '" + n +
           "' (use noise, stripes, checkers, grid, blobs, natural, uniform)");
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
  }
  return "?";
}

Texture::Texture(const TextureParams& p) : params_(p) {
  const int n = kTile;
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
      }
      img[size_t(y) * n + x] = float(val);
    }
  }
  // Normalise to [0,1] then map to albedo mean * exp(log_contrast * (v - 0.5)).
  auto [mn, mx] = std::minmax_element(img.begin(), img.end());
  float lo = *mn, hi = *mx;
  for (auto& v : img) {
    float t = hi > lo ? (v - lo) / (hi - lo) : 0.5f;
    v = float(std::clamp(p.mean * std::exp(p.log_contrast * (t - 0.5)), 0.01, 1.0));
  }
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
