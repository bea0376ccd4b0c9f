#include "core/sim/sensor_noise.h"

#include <algorithm>

namespace spikems::sim {

PixelParams draw_pixel_params(int width, int height, const NoiseParams& p, std::mt19937_64& rng) {
  const size_t n = size_t(width) * size_t(height);
  PixelParams px;
  px.c_on.assign(n, float(p.threshold));
  px.c_off.assign(n, float(p.threshold));
  if (p.threshold_sigma > 0) {
    std::normal_distribution<double> N(0, p.threshold_sigma);
    const double lo = 0.2 * p.threshold;  // a pixel never gets a near-zero threshold
    for (size_t i = 0; i < n; ++i) {
      px.c_on[i] = float(std::max(lo, p.threshold + N(rng)));
      px.c_off[i] = float(std::max(lo, p.threshold + N(rng)));
    }
  }
  if (p.hot_pixel_fraction > 0) {
    std::uniform_real_distribution<double> U(0, 1);
    for (size_t i = 0; i < n; ++i)
      if (U(rng) < p.hot_pixel_fraction) px.hot.push_back(uint32_t(i));
  }
  return px;
}

void add_poisson_noise(int width, int height, const NoiseParams& p, const PixelParams& px,
                       int64_t t0, int64_t t1, std::mt19937_64& rng, EventStream& out) {
  const double dt = double(t1 - t0) * 1e-6;
  if (dt <= 0) return;
  const uint64_t npix = uint64_t(width) * uint64_t(height);
  std::uniform_int_distribution<int64_t> T(t0, t1 - 1);
  if (p.shot_hz > 0) {
    std::poisson_distribution<int64_t> P(p.shot_hz * double(npix) * dt);
    int64_t n = P(rng);
    std::uniform_int_distribution<uint64_t> Pix(0, npix - 1);
    std::bernoulli_distribution pol(0.5);
    for (int64_t k = 0; k < n; ++k) {
      uint64_t i = Pix(rng);
      out.push_back(T(rng), uint16_t(i % uint64_t(width)), uint16_t(i / uint64_t(width)),
                    uint8_t(pol(rng)), 0);
    }
  }
  if (p.hot_pixel_hz > 0 && !px.hot.empty()) {
    std::poisson_distribution<int64_t> P(p.hot_pixel_hz * dt);
    for (uint32_t i : px.hot) {
      int64_t n = P(rng);
      for (int64_t k = 0; k < n; ++k)
        out.push_back(T(rng), uint16_t(i % uint32_t(width)), uint16_t(i / uint32_t(width)), 1, 0);
    }
  }
}

}  // namespace spikems::sim
