// Sensor non-idealities in the manner of v2e (Hu, Liu, Delbruck, CVPR-W 2021): per-pixel
// threshold mismatch with separate ON / OFF thresholds, leak events (a slow drift of the
// reference level), shot noise (Poisson events of random polarity, optionally more frequent in
// dark pixels), hot pixels, and a refractory period and light-dependent photoreceptor bandwidth
// (both applied by the generator).
#pragma once

#include <cstdint>
#include <random>
#include <vector>

#include "core/events/event_stream.h"

namespace spikems::sim {

// v2e's photoreceptor intensity floor: the cutoff scales with (I + kIntensityFloor) /
// (1 + kIntensityFloor), I in [0, 1] (v2e: (luma + 20) / 275 with luma in 0..255).
inline constexpr double kIntensityFloor = 20.0 / 255.0;

struct NoiseParams {
  double threshold = 0.2;          // nominal C: C_on = C (1 + a), C_off = C (1 - a)
  double threshold_asymmetry = 0;  // a in (-1, 1)
  double threshold_sigma = 0;      // per-pixel mismatch, std in log units (each polarity)
  int64_t refractory_us = 0;
  double leak_hz = 0;  // per-pixel leak event rate (ON)
  double shot_hz = 0;  // per-pixel shot-noise rate (both polarities together) at I = 0
  // Shot-noise rate factor at full intensity (v2e: 0.25); the rate is shot_hz x (1 + (k - 1) I),
  // I clamped to [0, 1]. 1: the same in every pixel.
  double shot_intensity_factor = 1;
  double hot_pixel_fraction = 0;
  double hot_pixel_hz = 0;
  bool random_initial_reference = false;  // random reset state per pixel (real sensors)
  // The random state: L - ref uniform in [0, C_on) (false: a pixel that only leaked, the
  // original model) or in (-C_off, C_on) (true: a pixel that has seen changes of both signs;
  // without it a short clip of small changes gets mostly ON events).
  bool balanced_initial_reference = false;
  double photoreceptor_cutoff_hz = 0;  // first-order low-pass on L (0: off)
  // Cutoff x (I + floor) / (1 + floor) with the pixel's intensity I = exp(L) - log_eps: dark
  // pixels are slower (v2e).
  bool photoreceptor_light_dependent = false;
  double log_eps = 0.01;  // L = log(log_eps + I), as rendered

  double c_on() const { return threshold * (1 + threshold_asymmetry); }
  double c_off() const { return threshold * (1 - threshold_asymmetry); }
};

// Per-pixel parameters drawn once per sequence.
struct PixelParams {
  std::vector<float> c_on, c_off;  // thresholds
  std::vector<uint32_t> hot;       // indices of hot pixels
};

PixelParams draw_pixel_params(int width, int height, const NoiseParams& p, std::mt19937_64& rng);

// Shot noise and hot-pixel events in [t0_us, t1_us), appended to out with label 0 (unsorted).
// log_intensity (the pixels' input L at t1) is needed when shot_intensity_factor != 1.
void add_poisson_noise(int width, int height, const NoiseParams& p, const PixelParams& px,
                       int64_t t0_us, int64_t t1_us, std::mt19937_64& rng, EventStream& out,
                       const float* log_intensity = nullptr);

}  // namespace spikems::sim
