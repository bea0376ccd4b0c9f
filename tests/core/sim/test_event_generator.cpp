// The ESIM event model on analytic inputs: event counts and interpolated times.
#include <gtest/gtest.h>

#include <cmath>

#include "core/sim/event_generator.h"
#include "core/sim/renderer.h"
#include "core/sim/simulate.h"
#include "sim_test_util.h"

using namespace spikems;
using namespace spikems::sim;

// A log intensity ramp sampled at several points: floor(dL/C) events, at the times where the
// linear interpolation crosses k*C (within 1 us of rounding).
TEST(EventGenerator, LinearRampCountAndTimes) {
  NoiseParams p;
  p.threshold = 0.2;
  EventGenerator g(1, 1, p, 1);
  const float L0 = -1.0f, dL = 1.37f;  // floor(1.37 / 0.2) = 6 events
  const int64_t T = 10000;
  float L = L0;
  uint16_t id = 0;
  g.reset(&L, &id, 0);
  EventStream out;
  out.add_zero_labels();
  for (int k = 1; k <= 7; ++k) {  // uneven samples: the ramp is linear so times are exact
    int64_t t = k == 7 ? T : int64_t(T * (k * k) / 49.0);
    L = L0 + dL * float(t) / float(T);
    g.step(&L, &id, t, out);
  }
  ASSERT_EQ(out.size(), 6u);
  for (size_t i = 0; i < out.size(); ++i) {
    double expect = (i + 1) * 0.2 / dL * T;
    EXPECT_NEAR(double(out.t[i]), expect, 1.0) << i;
    EXPECT_EQ(out.p[i], 1);
  }
  // Going back down by 1.0 gives 5 OFF events (reference now at L0 + 1.2).
  L = L0 + dL - 1.0f;
  g.step(&L, &id, T + 1000, out);
  size_t off = 0;
  for (size_t i = 6; i < out.size(); ++i) off += out.p[i] == 0;
  // From L0+1.37 (ref L0+1.2) down to L0+0.37: crossings at ref-0.2 ... = L0+1.0,...,L0+0.4
  EXPECT_EQ(off, 4u);
  EXPECT_EQ(out.size(), 10u);
}

// A sharp edge of known contrast crossing pixels at a known speed: every pixel the edge passes
// gives floor(|dL| / C) ON events, all within one time step of the analytic crossing time of
// the pixel centre. The motion bound makes that step <= max_displacement_px / speed
// (0.5 px / 2000 px/s = 250 us), the stated tolerance (+1 us rounding).
TEST(EventGenerator, MovingEdgeCountsAndTimes) {
  const int W = 40, H = 4;
  Camera cam{W, H, 20.0, 20.0, 0.0, 1.5};  // pixel x sees X/Z = x/20
  Scene s;
  test::flat_light(s);
  int dark = test::uniform_texture(s, 0.1), bright = test::uniform_texture(s, 0.8);
  s.shapes.push_back(test::plane(s, 5.0, 100.0, dark));
  Shape edge = test::plane(s, 2.0, 10.0, bright);
  edge.id = 1;
  // Right edge at X = -0.2 + v t (image x = 20 * X / 2 = 10 X): 2000 px/s.
  const double v = 200.0;
  edge.motion.position = {-0.2 - 10.0, 0, 2.0};
  edge.motion.velocity = {v, 0, 0};
  s.shapes.push_back(edge);
  SimConfig cfg = test::clean_config(W, H, 0.03);
  cfg.dt_min_us = 20;
  const double tol_us = cfg.max_displacement_px / (10.0 * v) * 1e6 + 1;
  Recording rec = simulate_scene(s, cam, cfg, 7);
  const double eps = cfg.log_eps;
  const double dL = std::log(eps + 0.8) - std::log(eps + 0.1);
  const int per_pixel = int(std::floor(dL / cfg.threshold));
  ASSERT_GT(per_pixel, 5);
  // Pixel x is crossed when 10 * (-0.2 + v t) = x  ->  t = (x / 10 + 0.2) / v.
  int checked = 0;
  for (int x = 0; x < W; ++x) {
    double tc = (x / 10.0 + 0.2) / v;
    if (tc > 0.029) continue;
    for (int y = 0; y < H; ++y) {
      int n = 0;
      for (size_t i = 0; i < rec.events.size(); ++i) {
        if (rec.events.x[i] != x || rec.events.y[i] != y) continue;
        ++n;
        EXPECT_EQ(rec.events.p[i], 1);
        EXPECT_EQ(rec.events.label[i], 1);
        EXPECT_NEAR(double(rec.events.t[i]), tc * 1e6, tol_us) << x;
      }
      EXPECT_EQ(n, per_pixel) << "pixel " << x << "," << y;
      ++checked;
    }
  }
  EXPECT_EQ(checked, W * H);
}
