// Geometry remapping, centred crops, centroids, the two denoising filters and thinning on
// hand-made events.
#include <gtest/gtest.h>

#include <cmath>

#include "core/events/event_ops.h"
#include "core/util/error.h"

using namespace spikems;

TEST(EventOps, RemapAgreesWithBinning) {
  EventStream ev;
  ev.sensor = {10, 8};
  ev.push_back(0, 2, 3, 1, 4);  // crop (0,0) -> flip x (4,0) -> /2 (2,0)
  ev.push_back(1, 1, 3, 1, 0);  // outside the crop
  ev.push_back(2, 6, 6, 0, 0);  // crop (4,3) -> flip (0,3) -> (0,1)
  BinningConfig cfg;
  cfg.crop_x = 2, cfg.crop_y = 3, cfg.crop_w = 5, cfg.crop_h = 4;
  cfg.flip_x = true, cfg.downsample = 2;
  EventStream r = remap_events(ev, cfg);
  EXPECT_EQ(r.sensor, (SensorSize{3, 2}));
  ASSERT_EQ(r.size(), 2u);
  EXPECT_EQ(r[0].x, 2);
  EXPECT_EQ(r[0].y, 0);
  EXPECT_EQ(r[0].label, 4);
  EXPECT_EQ(r[1].x, 0);
  EXPECT_EQ(r[1].y, 1);
  EXPECT_EQ(r[1].t, 2);
  // Binning the remapped events with the identity equals binning the originals with cfg.
  EXPECT_EQ(bin_events(r, 0, 5, BinningConfig{}).data, bin_events(ev, 0, 5, cfg).data);
}

TEST(EventOps, CentredCropStaysInsideTheSensor) {
  SensorSize s{346, 260};
  auto c = centred_crop(s, 172.5, 129.5, 128, 128);  // pixel (172,129) at the centre
  EXPECT_EQ(c.crop_x, 173 - 64);
  EXPECT_EQ(c.crop_y, 130 - 64);
  EXPECT_EQ(c.crop_w, 128);
  c = centred_crop(s, 3, 250, 128, 128);  // near the bottom-left corner: shifted inside
  EXPECT_EQ(c.crop_x, 0);
  EXPECT_EQ(c.crop_y, 260 - 128);
  c = centred_crop(s, 340, 0, 128, 128);
  EXPECT_EQ(c.crop_x, 346 - 128);
  EXPECT_EQ(c.crop_y, 0);
  EXPECT_THROW(centred_crop(s, 0, 0, 400, 10), Error);
  // The centre pixel of an even crop: (cx, cy) lands at index w/2 of the crop.
  c = centred_crop({100, 100}, 50, 40, 10, 10);
  EXPECT_EQ(50 - c.crop_x, 5);
  EXPECT_EQ(40 - c.crop_y, 5);
}

TEST(EventOps, ForegroundCentroid) {
  EventStream ev;
  ev.sensor = {20, 20};
  ev.push_back(0, 1, 1, 1, 0);
  ev.push_back(1, 4, 2, 1, 2);
  ev.push_back(2, 6, 8, 1, 2);
  ev.push_back(3, 10, 10, 1, 3);
  ev.push_back(9, 0, 0, 1, 2);  // outside [0, 5)
  double cx, cy;
  ASSERT_TRUE(foreground_centroid(ev, 0, 5, {}, cx, cy));
  EXPECT_DOUBLE_EQ(cx, 20.0 / 3);
  EXPECT_DOUBLE_EQ(cy, 20.0 / 3);
  ASSERT_TRUE(foreground_centroid(ev, 0, 5, {2}, cx, cy));
  EXPECT_DOUBLE_EQ(cx, 5);
  EXPECT_DOUBLE_EQ(cy, 5);
  EXPECT_FALSE(foreground_centroid(ev, 0, 5, {7}, cx, cy));
  EventStream unl;
  unl.sensor = {2, 2};
  unl.push_back(0, 0, 0, 1);
  EXPECT_FALSE(foreground_centroid(unl, 0, 5, {}, cx, cy));
}

TEST(EventOps, RefractoryFilter) {
  EventStream ev;
  ev.sensor = {2, 1};
  ev.push_back(0, 0, 0, 1);    // kept
  ev.push_back(50, 0, 0, 0);   // 50 after a kept one: dropped (either polarity)
  ev.push_back(60, 1, 0, 1);   // other pixel: kept
  ev.push_back(99, 0, 0, 1);   // 99 < 100: dropped
  ev.push_back(100, 0, 0, 1);  // exactly the period: kept
  ev.push_back(150, 0, 0, 1);  // 50 after the kept one at 100: dropped
  auto f = refractory_filter(ev, 100);
  std::vector<int64_t> want{0, 60, 100};
  EXPECT_EQ(f.t, want);
}

TEST(EventOps, BackgroundActivityFilter) {
  EventStream ev;
  ev.sensor = {5, 5};
  ev.push_back(0, 2, 2, 1, 7);    // no neighbour yet: dropped
  ev.push_back(10, 3, 3, 1, 7);   // neighbour (2,2) 10 us ago: kept
  ev.push_back(20, 3, 3, 0, 7);   // own pixel does not count; (2,2) 20 ago: kept
  ev.push_back(30, 0, 4, 1, 0);   // isolated noise: dropped
  ev.push_back(200, 4, 4, 1, 0);  // (3,3) last at 20: 180 > 100: dropped
  ev.push_back(250, 4, 3, 1, 0);  // (4,4) at 200 (dropped events still count): kept
  auto f = background_activity_filter(ev, 100);
  std::vector<int64_t> want{10, 20, 250};
  EXPECT_EQ(f.t, want);
  std::vector<uint16_t> want_l{7, 7, 0};
  EXPECT_EQ(f.label, want_l);
  EventStream unknown;
  EXPECT_THROW(background_activity_filter(unknown, 10), Error);
}

TEST(EventOps, FiltersGiveTheSameResultChunkByChunk) {
  EventStream ev;
  ev.sensor = {6, 4};
  uint32_t r = 12345;
  int64_t t = 0;
  for (int i = 0; i < 3000; ++i) {
    r = r * 1103515245u + 12345u;
    t += (r >> 8) % 40;
    ev.push_back(t, uint16_t((r >> 12) % 6), uint16_t((r >> 20) % 4), uint8_t((r >> 28) & 1));
  }
  auto whole_ba = background_activity_filter(ev, 60);
  auto whole_rf = refractory_filter(ev, 90);
  BackgroundActivityFilter ba(ev.sensor, 60);
  RefractoryFilter rf(ev.sensor, 90);
  EventStream parts_ba, parts_rf;
  for (size_t b = 0; b < ev.size(); b += 257) {
    auto chunk = ev.slice_index(b, b + 257);
    parts_ba.append(ba.apply(chunk));
    parts_rf.append(rf.apply(chunk));
  }
  EXPECT_EQ(parts_ba.t, whole_ba.t);
  EXPECT_EQ(parts_rf.t, whole_rf.t);
  // Both filters drop something and keep something on this input.
  EXPECT_GT(whole_ba.size(), 0u);
  EXPECT_LT(whole_ba.size(), ev.size());
  EXPECT_GT(whole_rf.size(), 0u);
  EXPECT_LT(whole_rf.size(), ev.size());
}

TEST(EventOps, ThinningKeepsTheAskedShareRepeatably) {
  EventStream ev;
  ev.sensor = {64, 48};
  const size_t n = 200000;
  for (size_t i = 0; i < n; ++i)
    ev.push_back(int64_t(i), uint16_t(i % 64), uint16_t(i / 64 % 48), uint8_t(i % 2),
                 uint16_t(i % 3 == 0));
  for (double keep : {0.5, 0.25, 0.1}) {
    const EventStream a = thin_events(ev, keep);
    // Binomial(n, keep): 5 standard deviations is ~0.1-0.2 % of n here.
    const double sd = std::sqrt(double(n) * keep * (1 - keep));
    EXPECT_NEAR(double(a.size()), double(n) * keep, 5 * sd) << keep;
    EXPECT_EQ(a.sensor.width, 64);
    ASSERT_TRUE(a.has_labels());
    // Each kept event is an input event unchanged (time = index here), in order; the labelled
    // share is kept too.
    size_t labelled = 0;
    for (size_t i = 0; i < a.size(); ++i) {
      const size_t j = size_t(a.t[i]);
      ASSERT_LT(j, n);
      if (i) ASSERT_GT(a.t[i], a.t[i - 1]);
      EXPECT_EQ(a.x[i], ev.x[j]);
      EXPECT_EQ(a.y[i], ev.y[j]);
      EXPECT_EQ(a.p[i], ev.p[j]);
      EXPECT_EQ(a.label[i], ev.label[j]);
      labelled += a.label[i];
    }
    EXPECT_NEAR(double(labelled) / double(a.size()), 1.0 / 3.0, 0.01) << keep;
    // The same seed gives the same events; another seed others.
    EXPECT_EQ(thin_events(ev, keep).t, a.t);
    EXPECT_NE(thin_events(ev, keep, 7).t, a.t);
  }
  // 1 keeps everything.
  EXPECT_EQ(thin_events(ev, 1.0).size(), n);
  for (double bad : {0.0, -0.5, 1.5, std::nan("")})
    EXPECT_THROW(thin_events(ev, bad), Error) << bad;
}
