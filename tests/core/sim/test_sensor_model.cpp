// The DVS pixel additions: light-dependent photoreceptor bandwidth, ON/OFF asymmetric
// thresholds, intensity-dependent shot noise, per-sequence sensor draws and lighting flicker.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "core/sim/event_generator.h"
#include "core/sim/presets.h"
#include "core/sim/simulate.h"
#include "core/util/error.h"
#include "sim_test_util.h"

using namespace spikems;
using namespace spikems::sim;

namespace {

constexpr double kPi = 3.141592653589793;

// Events of one pixel that steps at t = 0 from intensity i0 to i1 and stays there.
EventStream step_response(const NoiseParams& p, double i0, double i1, int64_t T, int64_t dt) {
  EventGenerator g(1, 1, p, 1);
  float L = float(std::log(p.log_eps + i0));
  uint16_t id = 0;
  g.reset(&L, &id, 0);
  EventStream out;
  out.add_zero_labels();
  L = float(std::log(p.log_eps + i1));
  for (int64_t t = dt; t <= T; t += dt) g.step(&L, &id, t, out);
  return out;
}

}  // namespace

// First-order low-pass with tau = (1 + floor) / (2 pi f_c (I1 + floor)): after a step of dL
// the filtered L crosses k C at t_k = -tau ln(1 - k C / dL). Both pixels step by ln 3; the
// dark one (I 0.01 -> 0.05) has a 7.5x longer tau than the bright one (0.29 -> 0.89).
TEST(SensorModel, DarkPixelsRespondLater) {
  NoiseParams p;
  p.threshold = 0.2;
  p.photoreceptor_cutoff_hz = 200;
  p.photoreceptor_light_dependent = true;
  const double dL = std::log(3.0), C = 0.2;
  const int n = int(std::floor(dL / C));  // 5
  double first[2] = {0, 0};
  const double lo[2] = {0.01, 0.29}, hi[2] = {0.05, 0.89};
  for (int k = 0; k < 2; ++k) {
    const double tau =
        (1 + kIntensityFloor) / (2 * kPi * p.photoreceptor_cutoff_hz * (hi[k] + kIntensityFloor));
    EventStream ev = step_response(p, lo[k], hi[k], 40000, 10);
    ASSERT_EQ(ev.size(), size_t(n)) << k;
    for (int j = 0; j < n; ++j) {
      const double expect_us = -tau * std::log(1 - (j + 1) * C / dL) * 1e6;
      // Linear interpolation of the exponential within 10 us steps, plus rounding.
      EXPECT_NEAR(double(ev.t[size_t(j)]), expect_us, 3.0) << "pixel " << k << " event " << j;
      EXPECT_EQ(ev.p[size_t(j)], 1);
    }
    first[k] = double(ev.t[0]);
  }
  EXPECT_GT(first[0], 5 * first[1]);  // 1340 us vs 178 us
  // Without the light dependence both respond with tau = 1 / (2 pi f_c).
  p.photoreceptor_light_dependent = false;
  const double tau = 1 / (2 * kPi * p.photoreceptor_cutoff_hz);
  for (int k = 0; k < 2; ++k) {
    EventStream ev = step_response(p, lo[k], hi[k], 20000, 10);
    ASSERT_EQ(ev.size(), size_t(n));
    EXPECT_NEAR(double(ev.t[0]), -tau * std::log(1 - C / dL) * 1e6, 3.0);
  }
}

// C_on = C (1 + a) = 0.25, C_off = C (1 - a) = 0.15: a ramp up by 1.37 gives floor(1.37 / 0.25)
// = 5 ON events at k C_on / dL T; the reference is then 1.25 above the start, and a ramp down
// to 1.0 below it gives floor(1.0 / 0.15) = 6 OFF events at the matching times.
TEST(SensorModel, AsymmetricThresholdsCountOnAndOff) {
  NoiseParams p;
  p.threshold = 0.2;
  p.threshold_asymmetry = 0.25;
  EventGenerator g(1, 1, p, 1);
  const float L0 = 0.3f;
  float L = L0;
  uint16_t id = 0;
  g.reset(&L, &id, 0);
  EventStream out;
  out.add_zero_labels();
  const int64_t T = 10000;
  for (int64_t t = 500; t <= T; t += 500) {
    L = L0 + 1.37f * float(t) / float(T);
    g.step(&L, &id, t, out);
  }
  ASSERT_EQ(out.size(), 5u);
  for (size_t i = 0; i < 5; ++i) {
    EXPECT_EQ(out.p[i], 1);
    EXPECT_NEAR(double(out.t[i]), double(i + 1) * 0.25 / 1.37 * T, 1.0);
  }
  const float top = L0 + 1.37f, bottom = L0 + 1.25f - 1.0f;  // 1.12 down in T
  for (int64_t t = 500; t <= T; t += 500) {
    L = top + (bottom - top) * float(t) / float(T);
    g.step(&L, &id, T + t, out);
  }
  ASSERT_EQ(out.size(), 11u);
  for (size_t i = 5; i < 11; ++i) {
    EXPECT_EQ(out.p[i], 0);
    const double level = 1.25 - 0.15 * double(i - 4);  // above L0
    EXPECT_NEAR(double(out.t[i]), T + (1.37 - level) / 1.12 * T, 1.0) << i;
  }
}

// Shot noise at shot_hz x (1 + (k - 1) I): a static uniform scene of intensity 0.8 with
// k = 0.25 fires at 0.4 x shot_hz per pixel (Poisson count within 5 sigma).
TEST(SensorModel, ShotNoiseLowerInBrightPixels) {
  SimConfig cfg = test::clean_config(64, 48, 1.0);
  cfg.shot_hz = 5;
  cfg.shot_intensity_factor = 0.25;
  Scene s;
  test::flat_light(s);
  s.shapes.push_back(test::plane(s, 3.0, 50.0, test::uniform_texture(s, 0.8)));
  Recording rec = simulate_scene(s, Camera::for_sensor(64, 48), cfg, 11);
  const double mean = cfg.shot_hz * (1 - 0.75 * 0.8) * 64 * 48 * 1.0;
  EXPECT_NEAR(double(rec.events.size()), mean, 5 * std::sqrt(mean));
}

// Range keys are drawn from the sequence's generator after the scene: the same seed gives the
// same values, different seeds different ones, all within their ranges; fixed keys keep their
// value; the values land in the sequence's metadata.
TEST(SensorModel, RangeKeysDrawnPerSequence) {
  SimConfig c = parse_sim_config(
      "[events]\nthreshold = [0.1, 0.4]\nrefractory_us = [100, 2000]\n"
      "threshold_asymmetry = [-0.2, 0.2]\n[scene]\nflicker_hz = [50, 120]\n"
      "flicker_depth = [0.1, 0.3]\n",
      "x");
  EXPECT_EQ(c.event_ranges.size(), 3u);
  EXPECT_DOUBLE_EQ(c.threshold, 0.25);  // midpoint until drawn
  std::mt19937_64 r1(5), r2(5), r3(6);
  SimConfig a = draw_sequence_config(c, r1), b = draw_sequence_config(c, r2),
            d = draw_sequence_config(c, r3);
  EXPECT_FALSE(has_sequence_ranges(a));
  EXPECT_EQ(a.threshold, b.threshold);
  EXPECT_EQ(a.refractory_us, b.refractory_us);
  EXPECT_EQ(a.flicker_hz.lo, b.flicker_hz.lo);
  EXPECT_EQ(a.flicker_phase, b.flicker_phase);
  EXPECT_NE(a.threshold, d.threshold);
  EXPECT_NE(a.refractory_us, d.refractory_us);
  EXPECT_NE(a.flicker_depth.lo, d.flicker_depth.lo);
  for (const SimConfig* s : {&a, &d}) {
    EXPECT_GE(s->threshold, 0.1);
    EXPECT_LE(s->threshold, 0.4);
    EXPECT_GE(s->refractory_us, 100);
    EXPECT_LE(s->refractory_us, 2000);
    EXPECT_GE(s->flicker_hz.lo, 50);
    EXPECT_LE(s->flicker_hz.hi, 120);
    EXPECT_EQ(s->threshold_sigma, c.threshold_sigma);  // fixed key untouched
  }
  // End to end: the draw follows the scene's draws from the same generator; metadata has it.
  SimConfig tiny = preset_config("tiny");
  tiny.duration_us = 20000;
  tiny.event_ranges = {{"threshold", {0.15, 0.35}}};
  std::mt19937_64 rng(77);
  Camera cam = camera_from_config(tiny);
  (void)make_random_scene(tiny, cam, rng);
  const double expect = draw_sequence_config(tiny, rng).threshold;
  SimulateOptions so;
  so.keep_masks = false;
  auto meta = nlohmann::json::parse(simulate_sequence(tiny, 77, so).metadata_json);
  EXPECT_DOUBLE_EQ(meta["threshold"].get<double>(), expect);
  EXPECT_TRUE(meta.contains("flicker"));
}

TEST(SensorModel, RangeKeysValidated) {
  EXPECT_THROW(parse_sim_config("[events]\nhot_pixel_hz = [1, 2]\n", "x"), Error);
  EXPECT_THROW(parse_sim_config("[events]\nthreshold = [0.3, 0.2]\n", "x"), Error);
  EXPECT_THROW(parse_sim_config("[events]\nthreshold = [0.001, 0.2]\n", "x"), Error);
  EXPECT_THROW(parse_sim_config("[events]\nthreshold = [0.1, 0.3]\nthreshold_sigma = 0.12\n", "x"),
               Error);  // sigma must stay below the smallest threshold
  EXPECT_THROW(parse_sim_config("[events]\nthreshold_asymmetry = [0, 0.95]\n", "x"), Error);
  EXPECT_THROW(parse_sim_config("[events]\nrefractory_us = \"long\"\n", "x"), Error);
  EXPECT_THROW(parse_sim_config("[events]\nshot_intensity_factor = 2\n", "x"), Error);
  EXPECT_THROW(parse_sim_config("[events]\nphotoreceptor_light_dependent = \"yes\"\n", "x"), Error);
  EXPECT_THROW(parse_sim_config("[scene]\nflicker_depth = [0, 1.0]\n", "x"), Error);
  EXPECT_THROW(parse_sim_config("[scene]\nflicker_hz = -1\n", "x"), Error);
  SimConfig c = parse_sim_config("[scene]\nflicker_hz = 100\n", "x");
  EXPECT_EQ(c.flicker_hz.lo, 100);
  EXPECT_EQ(c.flicker_hz.hi, 100);
  // --noise clean drops the noise ranges with the noise.
  SimConfig m = parse_sim_config("[events]\nleak_hz = [0, 1]\nthreshold = [0.1, 0.3]\n", "x");
  apply_noise_setting(m, "clean");
  ASSERT_EQ(m.event_ranges.size(), 1u);
  EXPECT_EQ(m.event_ranges[0].first, "threshold");
}

// The poster preset's calibrated sensor lies inside the ranges the mod preset draws from.
TEST(SensorModel, PosterSensorWithinModRanges) {
  SimConfig mod = preset_config("mod"), poster = preset_config("poster");
  auto value = [](const SimConfig& c, const std::string& k) {
    if (k == "threshold") return c.threshold;
    if (k == "threshold_sigma") return c.threshold_sigma;
    if (k == "threshold_asymmetry") return c.threshold_asymmetry;
    if (k == "refractory_us") return double(c.refractory_us);
    if (k == "leak_hz") return c.leak_hz;
    if (k == "shot_hz") return c.shot_hz;
    if (k == "hot_pixel_fraction") return c.hot_pixel_fraction;
    return c.photoreceptor_cutoff_hz;
  };
  for (const char* k : kDrawnEventKeys) {
    double v = value(poster, k), lo = value(mod, k), hi = lo;
    for (const auto& [name, r] : mod.event_ranges)
      if (name == k) lo = r.lo, hi = r.hi;
    EXPECT_GE(v, lo) << k;
    EXPECT_LE(v, hi) << k;
  }
}

// A static uniform scene under 100 Hz flicker of depth 0.5: L swings between
// log(eps + I (1 -+ d)); every pixel fires the ESIM count of the swings' extrema sequence
// (mid -> max -> min -> ... -> mid over 5 periods), ON events only while the light rises and
// OFF only while it falls (within one 200 us step).
TEST(SensorModel, FlickerOnStaticScene) {
  const int W = 8, H = 8;
  SimConfig cfg = test::clean_config(W, H, 0.05);
  cfg.dt_max_us = 200;
  const double f = 100, d = 0.5, I = 0.5, C = cfg.threshold, eps = cfg.log_eps;
  cfg.flicker_hz = {f, f};
  cfg.flicker_depth = {d, d};
  cfg.flicker_phase = 0;
  Scene s;
  test::flat_light(s);
  s.shapes.push_back(test::plane(s, 3.0, 50.0, test::uniform_texture(s, I)));
  Recording rec = simulate_scene(s, Camera::for_sensor(W, H), cfg, 3);
  // Analytic: the ideal reference follows the extrema.
  const double mid = std::log(eps + I), mx = std::log(eps + I * (1 + d)),
               mn = std::log(eps + I * (1 - d));
  std::vector<double> ext{mx};
  for (int k = 0; k < 5; ++k) {
    ext.push_back(mn);
    ext.push_back(k < 4 ? mx : mid);
  }
  double ref = mid;
  int on = 0, off = 0;
  for (double e : ext) {
    while (e >= ref + C) ref += C, ++on;
    while (e <= ref - C) ref -= C, ++off;
  }
  ASSERT_GE(on, 20);  // 4 or 5 per swing of 5.36 C
  std::vector<int> n_on(W * H, 0), n_off(W * H, 0);
  int wrong_phase = 0;
  for (size_t i = 0; i < rec.events.size(); ++i) {
    const int px = rec.events.y[i] * W + rec.events.x[i];
    (rec.events.p[i] ? n_on : n_off)[size_t(px)]++;
    // Rising while cos(2 pi f t) > 0; allow one step (200 us = 0.02 period) around the turns.
    const double t = double(rec.events.t[i]) * 1e-6, c = std::cos(2 * kPi * f * t);
    const double margin = std::sin(2 * kPi * 0.02);
    if (rec.events.p[i] ? c < -margin : c > margin) ++wrong_phase;
  }
  EXPECT_EQ(wrong_phase, 0);
  for (int k = 0; k < W * H; ++k) {
    EXPECT_NEAR(n_on[size_t(k)], on, 1) << k;
    EXPECT_NEAR(n_off[size_t(k)], off, 1) << k;
  }
}
