// Static scene, static camera: only noise events, at the configured rates (Poisson counts
// within 5 sigma over all pixels); none at all with noise off.
#include <gtest/gtest.h>

#include <cmath>

#include "core/sim/simulate.h"
#include "sim_test_util.h"

using namespace spikems;
using namespace spikems::sim;

namespace {

Recording static_scene(const SimConfig& cfg) {
  Scene s;
  TextureParams tp;
  tp.kind = TextureKind::Noise;
  tp.seed = 3;
  s.textures.emplace_back(tp);
  s.shapes.push_back(test::plane(s, 3.0, 50.0, 0, 0.7));
  Camera cam = Camera::for_sensor(cfg.width, cfg.height);
  return simulate_scene(s, cam, cfg, 11);
}

}  // namespace

TEST(SensorNoise, NoneWhenClean) {
  SimConfig cfg = test::clean_config(64, 48, 0.5);
  Recording rec = static_scene(cfg);
  EXPECT_EQ(rec.events.size(), 0u);
  EXPECT_EQ(rec.masks.size(), 501u);  // t = 0, 1 ms, ..., 500 ms
}

TEST(SensorNoise, ShotNoiseRate) {
  SimConfig cfg = test::clean_config(64, 48, 1.0);
  cfg.shot_hz = 5;
  Recording rec = static_scene(cfg);
  const double mean = cfg.shot_hz * 64 * 48 * 1.0;  // Poisson: variance = mean
  EXPECT_NEAR(double(rec.events.size()), mean, 5 * std::sqrt(mean));
  size_t on = 0;
  for (auto p : rec.events.p) on += p;
  EXPECT_NEAR(double(on), mean / 2, 5 * std::sqrt(mean / 4) + 5 * std::sqrt(mean) / 2);
  for (auto l : rec.events.label) EXPECT_EQ(l, 0);
  EXPECT_TRUE(rec.events.is_time_sorted());
}

// Leak: the reference drifts by leak_hz * C per second; with a uniformly random initial
// reference each pixel fires leak_hz * C / C_on(pixel) ON events per second on average, with a
// per-pixel variance below 1/4.
TEST(SensorNoise, LeakRateWithMismatch) {
  SimConfig cfg = test::clean_config(64, 48, 1.0);
  cfg.noise = "noisy";  // random initial reference
  cfg.leak_hz = 3;
  cfg.threshold_sigma = 0.03;
  Recording rec = static_scene(cfg);
  // E[C / C_on] for C_on = C (1 + x), x ~ N(0, s = 0.15): 1 + s^2 + 3 s^4 = 1.0235; its
  // sampling spread over n pixels is about s / sqrt(n).
  const double n = 64 * 48, s = cfg.threshold_sigma / cfg.threshold;
  const double mean = cfg.leak_hz * n * 1.0 * (1 + s * s + 3 * s * s * s * s);
  const double tol = 5 * std::sqrt(n / 4.0) + 5 * cfg.leak_hz * s * std::sqrt(n);
  EXPECT_NEAR(double(rec.events.size()), mean, tol);
  for (auto p : rec.events.p) EXPECT_EQ(p, 1);
}

TEST(SensorNoise, HotPixels) {
  SimConfig cfg = test::clean_config(64, 48, 1.0);
  cfg.hot_pixel_fraction = 0.01;
  cfg.hot_pixel_hz = 100;
  Recording rec = static_scene(cfg);
  std::vector<int> count(64 * 48, 0);
  for (size_t i = 0; i < rec.events.size(); ++i) ++count[rec.events.y[i] * 64 + rec.events.x[i]];
  int hot = 0;
  double total = 0;
  for (int c : count)
    if (c > 0) ++hot, total += c;
  // About 31 hot pixels (binomial), each ~Poisson(100).
  EXPECT_NEAR(hot, 0.01 * 64 * 48, 5 * std::sqrt(0.01 * 64 * 48));
  EXPECT_NEAR(total / hot, 100.0, 5 * std::sqrt(100.0 / hot));
}
