// [sensor] sizes and hfov_deg: a camera drawn per sequence (draw_camera), the recordings and
// the manifest that carry it, and the config errors that name the key.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>

#include "common/test_paths.h"
#include "core/events/io.h"
#include "core/sim/presets.h"
#include "core/sim/simulate.h"
#include "core/util/error.h"

using namespace spikems;
using namespace spikems::sim;

namespace {

constexpr double kPi = 3.141592653589793;

SimConfig with_sensor(const std::string& lines) {
  return parse_sim_config("[sensor]\n" + lines + "\n", "cam.toml");
}

double hfov_deg(const Camera& c) {
  return 2 * std::atan(0.5 * c.width / c.fx) * 180 / kPi;
}

}  // namespace

TEST(SensorDraw, WithoutTheKeysEverySequenceHasTheConfiguredCamera) {
  SimConfig c = with_sensor("width = 240\nheight = 180\nfx = 199");
  const Camera ref = camera_from_config(c);
  for (uint64_t s = 0; s < 20; ++s) {
    const Camera d = draw_camera(c, sequence_seed(3, int(s)));
    EXPECT_EQ(d.width, 240);
    EXPECT_EQ(d.height, 180);
    EXPECT_EQ(d.fx, ref.fx);
    EXPECT_EQ(d.fy, 199);
    EXPECT_EQ(d.cx, ref.cx);
  }
}

TEST(SensorDraw, SizesAreDrawnUniformlyWithTheirOwnCentre) {
  SimConfig c = with_sensor("sizes = [[346, 260], [240, 180], [640, 480]]");
  std::map<int, int> count;
  const int n = 600;
  for (int i = 0; i < n; ++i) {
    const Camera d = draw_camera(c, sequence_seed(9, i));
    ++count[d.width];
    const int h = d.width == 346 ? 260 : d.width == 240 ? 180 : 480;
    ASSERT_EQ(d.height, h) << d.width;
    // No hfov_deg: the default lens of that size (fx = fy = 0.65 width), centred.
    EXPECT_DOUBLE_EQ(d.fx, 0.65 * d.width);
    EXPECT_DOUBLE_EQ(d.fy, d.fx);
    EXPECT_DOUBLE_EQ(d.cx, (d.width - 1) * 0.5);
    EXPECT_DOUBLE_EQ(d.cy, (d.height - 1) * 0.5);
  }
  ASSERT_EQ(count.size(), 3u);
  // Each size's share within 5 standard deviations of 1/3 (binomial, n = 600: sd 0.019).
  for (auto [w, k] : count) EXPECT_NEAR(double(k) / n, 1.0 / 3, 0.096) << w;
  // The same seed gives the same camera.
  EXPECT_EQ(draw_camera(c, 77).width, draw_camera(c, 77).width);
}

TEST(SensorDraw, FieldOfViewSetsTheFocalLength) {
  // A fixed field of view: 90 degrees puts the image's edge at 45 degrees, fx = width / 2.
  SimConfig fixed = with_sensor("width = 240\nheight = 180\nhfov_deg = 90");
  const Camera f = draw_camera(fixed, 5);
  EXPECT_NEAR(f.fx, 120, 1e-9);
  EXPECT_NEAR(f.fy, 120, 1e-9);
  // A range: every draw inside it, the range covered, mean near the middle.
  SimConfig c = with_sensor("sizes = [[346, 260], [240, 180]]\nhfov_deg = [50, 90]");
  double lo = 1e9, hi = 0, sum = 0;
  const int n = 400;
  for (int i = 0; i < n; ++i) {
    const Camera d = draw_camera(c, sequence_seed(4, i));
    const double v = hfov_deg(d);
    lo = std::min(lo, v);
    hi = std::max(hi, v);
    sum += v;
    EXPECT_DOUBLE_EQ(d.fy, d.fx);
  }
  EXPECT_GE(lo, 50 - 1e-9);
  EXPECT_LE(hi, 90 + 1e-9);
  EXPECT_LT(lo, 52);
  EXPECT_GT(hi, 88);
  EXPECT_NEAR(sum / n, 70, 2.0);  // uniform: sd of the mean 11.5 / sqrt(400) = 0.58
  // The size is the same draw with or without hfov_deg (two draws whatever is set).
  SimConfig sizes_only = with_sensor("sizes = [[346, 260], [240, 180]]");
  for (int i = 0; i < 50; ++i)
    EXPECT_EQ(draw_camera(c, sequence_seed(4, i)).width,
              draw_camera(sizes_only, sequence_seed(4, i)).width);
}

TEST(SensorDraw, DatasetRecordsEachSequencesCamera) {
  if (!find_format("spikems-h5")) GTEST_SKIP() << "spikems-h5 format not in this build";
  SimConfig c = preset_config("tiny");
  c.duration_us = 30000;
  c.sizes = {{64, 48}, {48, 40}};
  c.hfov_deg = {60, 80};
  DatasetOptions o;
  o.sequences = 6;
  o.seed = 12;
  o.progress = false;
  o.threads = 2;
  o.out_dir = test::scratch_dir() + "/sizes";
  simulate_dataset(c, o);
  std::ifstream mf(o.out_dir + "/manifest.json");
  const auto m = nlohmann::json::parse(mf);
  std::set<std::pair<int, int>> seen;
  for (const auto& e : m["sequences"]) {
    const Recording r = read_recording(o.out_dir + "/" + e["file"].get<std::string>());
    const Camera d = draw_camera(c, e["seed"].get<uint64_t>());
    EXPECT_EQ(r.events.sensor.width, d.width);
    EXPECT_EQ(r.events.sensor.height, d.height);
    EXPECT_EQ(e["sensor"][0].get<int>(), d.width);
    EXPECT_EQ(e["sensor"][1].get<int>(), d.height);
    ASSERT_TRUE(r.intrinsics.has_value());
    EXPECT_NEAR(r.intrinsics->fx, d.fx, 1e-9);
    EXPECT_NEAR(e["fx"].get<double>(), d.fx, 1e-9);
    ASSERT_FALSE(r.masks.empty());
    EXPECT_EQ(r.masks[0].width, d.width);
    // Every event inside its own sensor.
    for (size_t i = 0; i < r.events.size(); ++i)
      ASSERT_TRUE(r.events.x[i] < d.width && r.events.y[i] < d.height);
    seen.insert({d.width, d.height});
  }
  // Several sizes: the manifest lists them (sorted); one size would be a plain [w, h].
  ASSERT_EQ(seen.size(), 2u) << "6 draws from 2 sizes gave one (chance 1/32): change the seed";
  EXPECT_EQ(m["sensor"], nlohmann::json::parse("[[48, 40], [64, 48]]"));
}

TEST(SensorDraw, BadKeysAreNamed) {
  auto refused = [](const std::string& lines, const std::string& needle) {
    try {
      with_sensor(lines);
      ADD_FAILURE() << "accepted: " << lines;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("cam.toml"), std::string::npos) << e.what();
    }
  };
  refused("sizes = []", "sizes");
  refused("sizes = [[346, 260, 1]]", "sizes");
  refused("sizes = [[346, \"a\"]]", "sizes");
  refused("sizes = [346, 260]", "sizes");
  refused("sizes = [[4, 260]]", "sizes");
  refused("sizes = [[346, 5000]]", "sizes");
  refused("sizes = [[346, 260]]\ncx = 100", "sizes");
  refused("hfov_deg = [5, 60]", "hfov_deg");
  refused("hfov_deg = [60, 175]", "hfov_deg");
  refused("hfov_deg = [80, 60]", "hfov_deg");
  refused("hfov_deg = 70\nfx = 200", "hfov_deg");
  refused("hfov_deg = \"wide\"", "hfov_deg");
  // Accepted: the keys alone and together.
  EXPECT_EQ(with_sensor("sizes = [[240, 180]]\nhfov_deg = [55, 80]").sizes.size(), 1u);
}
