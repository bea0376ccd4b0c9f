// Labels against projected footprints, mask areas, and parallax.
#include <gtest/gtest.h>

#include <cmath>

#include "core/sim/renderer.h"
#include "core/sim/simulate.h"
#include "sim_test_util.h"

using namespace spikems;
using namespace spikems::sim;

// A textured sphere of radius r moving across a textured wall, static camera. Every event
// labelled 1 lies within the sphere's projected outline at its time, within 1 px (angular test
// on the viewing cone), and the mask area at the moment the sphere is on the optical axis is
// the exact projected disc pi f^2 r^2 / (Z^2 - r^2) within 3%.
TEST(SimLabels, SphereFootprintAndMaskArea) {
  const int W = 96, H = 72;
  Camera cam{W, H, 100.0, 100.0, 47.5, 35.5};
  Scene s;
  TextureParams tp;
  tp.kind = TextureKind::Checkers;
  tp.frequency = 4;
  tp.seed = 5;
  s.textures.emplace_back(tp);
  tp.kind = TextureKind::Noise;
  tp.seed = 9;
  tp.mean = 0.3;
  s.textures.emplace_back(tp);
  s.shapes.push_back(test::plane(s, 6.0, 50.0, 0, 0.8));
  Shape ball;
  ball.kind = ShapeKind::Ellipsoid;
  const double r = 0.3, Z = 2.0;
  ball.half = {r, r, r};
  ball.id = 1;
  ball.texture = 1;
  ball.tile_m = 0.4;
  ball.motion.position = {0, 0, Z};
  ball.motion.t_ref = 0.05;
  ball.motion.velocity = {3.0, 1.0, 0};
  ball.motion.spin = {0, 2, 1};
  s.shapes.push_back(ball);
  s.ambient = 0.4;
  SimConfig cfg = test::clean_config(W, H, 0.1);
  Recording rec = simulate_scene(s, cam, cfg, 3);

  size_t labelled = 0;
  for (size_t i = 0; i < rec.events.size(); ++i) {
    if (rec.events.label[i] != 1) continue;
    ++labelled;
    Vec3 c = ball.motion.at(rec.events.t[i] * 1e-6).t;
    Vec3 ray{(rec.events.x[i] - cam.cx) / cam.fx, (rec.events.y[i] - cam.cy) / cam.fy, 1};
    double ang = std::acos(std::clamp(ray.normalized().dot(c.normalized()), -1.0, 1.0));
    double cone = std::asin(r / c.norm());
    EXPECT_LE(ang, cone + 1.0 / cam.fx) << "event " << i;
  }
  EXPECT_GT(labelled, 500u);
  // Mask at t = 50 ms: the sphere is centred on the axis.
  const MaskFrame* m = nullptr;
  for (const auto& f : rec.masks)
    if (f.t_us == 50000) m = &f;
  ASSERT_NE(m, nullptr);
  double area = 0;
  for (auto id : m->ids) area += id == 1;
  double expect = M_PI * cam.fx * cam.fx * r * r / (Z * Z - r * r);
  EXPECT_NEAR(area, expect, 0.03 * expect);
  // Poses: camera (id 0) and the ball (id 1) at every mask time.
  EXPECT_EQ(rec.poses.size(), 2 * rec.masks.size());
  EXPECT_EQ(rec.moving_ids, std::vector<uint16_t>{1});
}

// With the camera translating sideways, a near plane moves across the image faster than a far
// one: measured image shifts (best integer shift of a row profile) match f * v * dt / Z.
TEST(SimGeometry, ParallaxNearFasterThanFar) {
  const int W = 200, H = 60;
  Camera cam{W, H, 100.0, 100.0, 99.5, 29.5};
  Scene s;
  TextureParams tp;
  tp.kind = TextureKind::Noise;
  tp.frequency = 8;
  tp.seed = 1;
  s.textures.emplace_back(tp);
  tp.seed = 2;
  s.textures.emplace_back(tp);
  // Far plane at 8 m fills the view; near plane at 1 m covers the top half of the image.
  s.shapes.push_back(test::plane(s, 8.0, 100.0, 0, 4.0));
  Shape near = test::plane(s, 1.0, 10.0, 1, 0.5);
  near.half = {10.0, 0.15, 0};
  near.motion.position = {0, -0.15, 1.0};
  s.shapes.push_back(near);
  test::flat_light(s);
  s.camera.velocity = {0.5, 0, 0};  // m/s along x
  Renderer rend(s, cam, 0.01);
  Frame a, b;
  const double dt = 0.04;  // near: 100 * 0.5 * 0.04 / 1 = 2 px... use a longer interval
  rend.render(0.0, a);
  rend.render(4 * dt, b);  // near 8 px, far 1 px
  auto best_shift = [&](int y0, int y1) {
    int best = 0;
    double best_err = 1e30;
    for (int sh = -20; sh <= 20; ++sh) {
      double err = 0;
      int n = 0;
      for (int y = y0; y < y1; ++y)
        for (int x = 30; x < W - 30; ++x) {
          double d = a.log_intensity[size_t(y) * W + x] - b.log_intensity[size_t(y) * W + x + sh];
          err += d * d;
          ++n;
        }
      if (err / n < best_err) best_err = err / n, best = sh;
    }
    return best;
  };
  int near_shift = best_shift(5, 25);  // rows seeing the near plane
  int far_shift = best_shift(40, 55);  // rows seeing the far plane
  // Camera moves +x, so the scene moves -x in the image: b(x + shift) = a(x), shift < 0.
  EXPECT_EQ(near_shift, -8);
  EXPECT_EQ(far_shift, -1);
  EXPECT_GT(std::abs(near_shift), std::abs(far_shift));
}
