// Sensor non-idealities in the manner of v2e (Hu, Liu, Delbruck, CVPR-W 2021): per-pixel
// threshold mismatch, leak events (a slow drift of the reference level), shot noise (Poisson
// events of random polarity), hot pixels, and a refractory period (applied by the generator).
#pragma once

#include <cstdint>
#include <random>
#include <vector>

#include "core/events/event_stream.h"

namespace spikems::sim {

struct NoiseParams {
  double threshold = 0.2;      // nominal C (ON and OFF)
  double threshold_sigma = 0;  // per-pixel mismatch, std in log units
  int64_t refractory_us = 0;
  double leak_hz = 0;  // per-pixel leak event rate (ON)
  double shot_hz = 0;  // per-pixel shot-noise rate (both polarities together)
  double hot_pixel_fraction = 0;
  double hot_pixel_hz = 0;
  bool random_initial_reference = false;  // random reset state per pixel (real sensors)
  double photoreceptor_cutoff_hz = 0;     // first-order low-pass on L (0: off)
};

// Per-pixel parameters drawn once per sequence.
struct PixelParams {
  std::vector<float> c_on, c_off;  // thresholds
  std::vector<uint32_t> hot;       // indices of hot pixels
};

PixelParams draw_pixel_params(int width, int height, const NoiseParams& p, std::mt19937_64& rng);

// Shot noise and hot-pixel events in [t0_us, t1_us), appended to out with label 0 (unsorted).
void add_poisson_noise(int width, int height, const NoiseParams& p, const PixelParams& px,
                       int64_t t0_us, int64_t t1_us, std::mt19937_64& rng, EventStream& out);

}  // namespace spikems::sim
