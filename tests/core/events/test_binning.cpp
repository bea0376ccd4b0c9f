// Binning and window ground truth on hand-made events with known answers.
#include <gtest/gtest.h>

#include <random>

#include "core/events/binning.h"
#include "core/util/error.h"

using namespace spikems;

namespace {

EventStream stream(int w, int h) {
  EventStream ev;
  ev.sensor = {w, h};
  return ev;
}

}  // namespace

TEST(Binning, WindowBoundsAreStartInclusiveEndExclusive) {
  auto ev = stream(4, 3);
  ev.push_back(999, 0, 0, 1);   // before the window
  ev.push_back(1000, 1, 0, 1);  // first microsecond: in, step 0
  ev.push_back(3999, 2, 0, 1);  // last microsecond: in, step 2
  ev.push_back(4000, 3, 0, 1);  // end: out
  BinningConfig cfg;
  cfg.step_us = 1000;
  auto s = bin_events(ev, 1000, 3000, cfg);
  EXPECT_EQ(s.T, 3);
  EXPECT_EQ(s.H, 3);
  EXPECT_EQ(s.W, 4);
  EXPECT_EQ(s.data.size(), size_t(3 * 2 * 3 * 4));
  EXPECT_EQ(s.count(), 2u);
  EXPECT_EQ(s.at(0, 1, 0, 1), 1);
  EXPECT_EQ(s.at(2, 1, 0, 2), 1);
  EXPECT_EQ(s.at(0, 1, 0, 0), 0);
  EXPECT_EQ(s.at(2, 1, 0, 3), 0);
}

TEST(Binning, StepBoundariesAndPartialLastStep) {
  auto ev = stream(2, 1);
  ev.push_back(0, 0, 0, 0);     // step 0
  ev.push_back(999, 1, 0, 0);   // step 0
  ev.push_back(1000, 0, 0, 0);  // step 1
  ev.push_back(2000, 1, 0, 0);  // step 2 (the partial step of a 2.5 ms window)
  ev.push_back(2499, 0, 0, 1);  // step 2
  BinningConfig cfg;
  auto s = bin_events(ev, 0, 2500, cfg);
  EXPECT_EQ(s.T, 3);  // ceil(2500 / 1000)
  EXPECT_EQ(s.at(0, 0, 0, 0), 1);
  EXPECT_EQ(s.at(0, 0, 0, 1), 1);
  EXPECT_EQ(s.at(1, 0, 0, 0), 1);
  EXPECT_EQ(s.at(1, 0, 0, 1), 0);
  EXPECT_EQ(s.at(2, 0, 0, 1), 1);
  EXPECT_EQ(s.at(2, 1, 0, 0), 1);
  EXPECT_EQ(s.count(), 5u);
}

TEST(Binning, DuplicatesCollapseAndPolarityPicksTheChannel) {
  auto ev = stream(3, 2);
  for (int i = 0; i < 5; ++i) ev.push_back(100 + i * 10, 2, 1, 1);  // 5 ON events, one step
  ev.push_back(200, 2, 1, 0);                                       // OFF at the same pixel
  ev.push_back(1200, 2, 1, 1);                                      // ON next step
  BinningConfig cfg;
  auto s = bin_events(ev, 0, 2000, cfg);
  EXPECT_EQ(s.count(), 3u);
  EXPECT_EQ(s.at(0, 1, 1, 2), 1);
  EXPECT_EQ(s.at(0, 0, 1, 2), 1);
  EXPECT_EQ(s.at(1, 1, 1, 2), 1);
  EXPECT_EQ(s.at(1, 0, 1, 2), 0);
  // Layout check: time-major [T, 2, H, W].
  EXPECT_EQ(s.index(1, 0, 1, 2), size_t(((1 * 2 + 0) * 2 + 1) * 3 + 2));
}

TEST(Binning, StepLargerThanOneMillisecond) {
  auto ev = stream(1, 1);
  ev.push_back(0, 0, 0, 1);
  ev.push_back(4999, 0, 0, 0);
  ev.push_back(5000, 0, 0, 1);
  BinningConfig cfg;
  cfg.step_us = 5000;
  auto s = bin_events(ev, 0, 10000, cfg);
  EXPECT_EQ(s.T, 2);
  EXPECT_EQ(s.at(0, 1, 0, 0), 1);
  EXPECT_EQ(s.at(0, 0, 0, 0), 1);
  EXPECT_EQ(s.at(1, 1, 0, 0), 1);
  EXPECT_EQ(s.at(1, 0, 0, 0), 0);
}

TEST(Binning, CropFlipDownsampleGeometry) {
  // 10x8 sensor, crop 5x4 at (2, 3); flip x; downsample 2 -> output ceil(4/2) x ceil(5/2) = 2x3.
  auto ev = stream(10, 8);
  ev.push_back(0, 2, 3, 1);  // crop (0,0) -> flip x (4,0) -> (2,0)
  ev.push_back(0, 6, 6, 1);  // crop (4,3) -> flip (0,3) -> (0,1)
  ev.push_back(0, 1, 3, 1);  // left of the crop: dropped
  ev.push_back(0, 7, 3, 1);  // right of the crop (x = 2 + 5): dropped
  ev.push_back(0, 4, 7, 0);  // below the crop (y = 3 + 4): dropped
  ev.push_back(0, 3, 4, 0);  // crop (1,1) -> flip (3,1) -> (1,0)
  BinningConfig cfg;
  cfg.crop_x = 2;
  cfg.crop_y = 3;
  cfg.crop_w = 5;
  cfg.crop_h = 4;
  cfg.flip_x = true;
  cfg.downsample = 2;
  auto [H, W] = binned_size({10, 8}, cfg);
  EXPECT_EQ(H, 2);
  EXPECT_EQ(W, 3);
  auto s = bin_events(ev, 0, 1000, cfg);
  ASSERT_EQ(s.H, 2);
  ASSERT_EQ(s.W, 3);
  EXPECT_EQ(s.count(), 3u);
  EXPECT_EQ(s.at(0, 1, 0, 2), 1);
  EXPECT_EQ(s.at(0, 1, 1, 0), 1);
  EXPECT_EQ(s.at(0, 0, 0, 1), 1);
}

TEST(Binning, FlipY) {
  auto ev = stream(3, 4);
  ev.push_back(0, 1, 0, 1);
  BinningConfig cfg;
  cfg.flip_y = true;
  auto s = bin_events(ev, 0, 1000, cfg);
  EXPECT_EQ(s.at(0, 1, 3, 1), 1);
  EXPECT_EQ(s.count(), 1u);
}

TEST(Binning, BadConfigurationsThrow) {
  auto ev = stream(10, 8);
  BinningConfig cfg;
  cfg.crop_w = 11;
  cfg.crop_h = 8;
  EXPECT_THROW(binned_size(ev.sensor, cfg), Error);
  cfg = {};
  cfg.downsample = 0;
  EXPECT_THROW(binned_size(ev.sensor, cfg), Error);
  cfg = {};
  cfg.step_us = 0;
  EXPECT_THROW(bin_events(ev, 0, 1000, cfg), Error);
  EXPECT_THROW(binned_size({0, 0}, BinningConfig{}), Error);
  EXPECT_THROW(bin_events(ev, 0, -1, BinningConfig{}), Error);
}

TEST(Binning, EmptyWindowGivesZeros) {
  auto ev = stream(2, 2);
  ev.push_back(5000, 0, 0, 1);
  auto s = bin_events(ev, 0, 1000, BinningConfig{});
  EXPECT_EQ(s.T, 1);
  EXPECT_EQ(s.count(), 0u);
}

TEST(WindowTruth, LabelsAndMovingIds) {
  auto ev = stream(4, 2);
  ev.push_back(0, 0, 0, 1, 0);     // background
  ev.push_back(100, 1, 0, 0, 3);   // object 3
  ev.push_back(200, 2, 0, 1, 7);   // object 7
  ev.push_back(300, 3, 1, 1, 7);   // object 7
  ev.push_back(1000, 0, 1, 1, 3);  // outside the window
  auto all = window_truth(ev, 0, 1000, BinningConfig{});
  EXPECT_EQ(all.H, 2);
  EXPECT_EQ(all.W, 4);
  std::vector<uint8_t> any{1, 1, 1, 0, 0, 0, 0, 1};
  std::vector<uint8_t> fg_all{0, 1, 1, 0, 0, 0, 0, 1};
  EXPECT_EQ(all.any, any);
  EXPECT_EQ(all.fg, fg_all);
  auto only7 = window_truth(ev, 0, 1000, BinningConfig{}, {7});
  std::vector<uint8_t> fg7{0, 0, 1, 0, 0, 0, 0, 1};
  EXPECT_EQ(only7.fg, fg7);
  EXPECT_EQ(only7.any, any);
}

TEST(WindowTruth, DownsampleMergesPixelsAndNoLabelsMeansNoForeground) {
  auto ev = stream(4, 4);
  ev.push_back(0, 3, 3, 1);
  ev.push_back(0, 2, 2, 0);
  BinningConfig cfg;
  cfg.downsample = 2;
  auto w = window_truth(ev, 0, 10, cfg);
  EXPECT_EQ(w.H, 2);
  EXPECT_EQ(w.W, 2);
  std::vector<uint8_t> any{0, 0, 0, 1};
  EXPECT_EQ(w.any, any);
  EXPECT_EQ(w.fg, std::vector<uint8_t>(4, 0));
}

TEST(PixelMap, AgreesWithBinnedSize) {
  BinningConfig cfg;
  cfg.downsample = 3;
  PixelMap pm({346, 260}, cfg);
  auto [H, W] = binned_size({346, 260}, cfg);
  EXPECT_EQ(pm.H, H);
  EXPECT_EQ(pm.W, W);
  EXPECT_EQ(W, 116);  // ceil(346 / 3)
  int ox, oy;
  ASSERT_TRUE(pm.map(345, 259, ox, oy));
  EXPECT_EQ(ox, 115);
  EXPECT_EQ(oy, 86);
}

// The fast path (lookup tables, step walk) against the plain definition on random events.
TEST(Binning, MatchesThePlainDefinitionOnRandomEvents) {
  std::mt19937 rng(7);
  EventStream ev;
  ev.sensor = {37, 23};
  int64_t t = 0;
  for (int i = 0; i < 20000; ++i) {
    t += int64_t(rng() % 7);
    ev.push_back(t, uint16_t(rng() % 37), uint16_t(rng() % 23), uint8_t(rng() % 2));
  }
  std::vector<BinningConfig> cfgs(4);
  cfgs[1].step_us = 700;
  cfgs[2].crop_x = 3, cfgs[2].crop_y = 5, cfgs[2].crop_w = 30, cfgs[2].crop_h = 11;
  cfgs[2].flip_x = true, cfgs[2].downsample = 4, cfgs[2].step_us = 333;
  cfgs[3].flip_y = true, cfgs[3].downsample = 3, cfgs[3].step_us = 2500;
  for (const auto& cfg : cfgs)
    for (int64_t t0 : {int64_t(0), int64_t(1234), int64_t(30001)})
      for (int64_t win : {int64_t(1), int64_t(999), int64_t(10000)}) {
        SpikeTensor fast = bin_events(ev, t0, win, cfg);
        PixelMap pm(ev.sensor, cfg);
        SpikeTensor ref;
        ref.T = int((win + cfg.step_us - 1) / cfg.step_us);
        ref.H = pm.H;
        ref.W = pm.W;
        ref.data.assign(size_t(ref.T) * 2 * size_t(ref.H) * size_t(ref.W), 0);
        for (size_t i = 0; i < ev.size(); ++i) {
          int ox, oy;
          if (ev.t[i] < t0 || ev.t[i] >= t0 + win || !pm.map(ev.x[i], ev.y[i], ox, oy)) continue;
          ref.data[ref.index(int((ev.t[i] - t0) / cfg.step_us), ev.p[i], oy, ox)] = 1;
        }
        ASSERT_EQ(fast.T, ref.T);
        ASSERT_EQ(fast.data, ref.data) << "t0 " << t0 << " window " << win;
        EXPECT_GT(ref.count() + (win < 100 ? 1 : 0), 0u);
      }
}
