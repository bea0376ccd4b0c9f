#include "core/sim/sensor_noise.h"

#include <algorithm>
#include <cmath>

namespace spikems::sim {

PixelParams draw_pixel_params(int width, int height, const NoiseParams& p, std::mt19937_64& rng) {
  const size_t n = size_t(width) * size_t(height);
  const double on = p.c_on(), off = p.c_off();
  PixelParams px;
  px.c_on.assign(n, float(on));
  px.c_off.assign(n, float(off));
  if (p.threshold_sigma > 0) {
    std::normal_distribution<double> N(0, p.threshold_sigma);
    // A pixel never gets a near-zero threshold.
    const double lo_on = 0.2 * on, lo_off = 0.2 * off;
    for (size_t i = 0; i < n; ++i) {
      px.c_on[i] = float(std::max(lo_on, on + N(rng)));
      px.c_off[i] = float(std::max(lo_off, off + N(rng)));
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
                       int64_t t0, int64_t t1, std::mt19937_64& rng, EventStream& out,
                       const float* L) {
  const double dt = double(t1 - t0) * 1e-6;
  if (dt <= 0) return;
  const uint64_t npix = uint64_t(width) * uint64_t(height);
  std::uniform_int_distribution<int64_t> T(t0, t1 - 1);
  if (p.shot_hz > 0) {
    // Candidates at the dark-pixel rate, thinned by the pixel's intensity factor.
    const bool thin = p.shot_intensity_factor != 1 && L;
    std::poisson_distribution<int64_t> P(p.shot_hz * double(npix) * dt);
    int64_t n = P(rng);
    std::uniform_int_distribution<uint64_t> Pix(0, npix - 1);
    std::bernoulli_distribution pol(0.5);
    std::uniform_real_distribution<double> U(0, 1);
    for (int64_t k = 0; k < n; ++k) {
      uint64_t i = Pix(rng);
      int64_t t = T(rng);
      uint8_t polarity = uint8_t(pol(rng));
      if (thin) {
        double I = std::clamp(std::exp(double(L[i])) - p.log_eps, 0.0, 1.0);
        if (U(rng) >= 1 + (p.shot_intensity_factor - 1) * I) continue;
      }
      out.push_back(t, uint16_t(i % uint64_t(width)), uint16_t(i / uint64_t(width)), polarity, 0);
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
