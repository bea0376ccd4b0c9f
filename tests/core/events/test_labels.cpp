// Labels from mask frames: nearest frame in time, dilation, moving-id filter, gaps.
#include <gtest/gtest.h>

#include "core/events/labels.h"
#include "core/util/error.h"

using namespace spikems;

namespace {

MaskFrame frame(int64_t t, int w, int h, std::vector<uint16_t> ids) {
  MaskFrame m;
  m.t_us = t;
  m.width = w;
  m.height = h;
  m.ids = std::move(ids);
  return m;
}

}  // namespace

TEST(Labels, NearestFrameInTimeWithTiesToTheEarlierFrame) {
  // Frame A at t=1000 labels pixel (0,0) with id 1; frame B at t=2000 labels it with id 2.
  std::vector<MaskFrame> masks{frame(2000, 2, 1, {2, 0}), frame(1000, 2, 1, {1, 0})};  // unsorted
  EventStream ev;
  ev.sensor = {2, 1};
  ev.push_back(0, 0, 0, 1);     // before all frames -> A
  ev.push_back(1499, 0, 0, 1);  // nearer A
  ev.push_back(1500, 0, 0, 1);  // exact tie -> earlier frame A
  ev.push_back(1501, 0, 0, 1);  // nearer B
  ev.push_back(9000, 0, 0, 1);  // after all frames -> B
  ev.push_back(1000, 1, 0, 1);  // background pixel
  label_from_masks(ev, masks, {});
  ASSERT_TRUE(ev.has_labels());
  std::vector<uint16_t> want{1, 1, 1, 2, 2, 0};
  EXPECT_EQ(ev.label, want);
}

TEST(Labels, MaxGapClearsFarEvents) {
  std::vector<MaskFrame> masks{frame(1000, 1, 1, {5})};
  EventStream ev;
  ev.sensor = {1, 1};
  ev.push_back(500, 0, 0, 1);   // gap 500
  ev.push_back(1501, 0, 0, 1);  // gap 501
  LabelOptions opt;
  opt.max_gap_us = 500;
  label_from_masks(ev, masks, opt);
  std::vector<uint16_t> want{5, 0};
  EXPECT_EQ(ev.label, want);
}

TEST(Labels, MovingIdsFilter) {
  std::vector<MaskFrame> masks{frame(0, 3, 1, {1, 2, 3})};
  EventStream ev;
  ev.sensor = {3, 1};
  for (uint16_t x = 0; x < 3; ++x) ev.push_back(0, x, 0, 1);
  LabelOptions opt;
  opt.moving_ids = {2, 3};
  label_from_masks(ev, masks, opt);
  std::vector<uint16_t> want{0, 2, 3};
  EXPECT_EQ(ev.label, want);
}

TEST(Labels, DilationGrowsRegionsAndClipsAtTheBorder) {
  // 5x4 mask, object 4 at the corner (0,0).
  std::vector<uint16_t> ids(20, 0);
  ids[0] = 4;
  auto d = dilate_mask(frame(0, 5, 4, ids), 3);
  // 3x3 around (0,0), clipped: (0,0), (1,0), (0,1), (1,1).
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 5; ++x) EXPECT_EQ(d.at(x, y), (x <= 1 && y <= 1) ? 4 : 0) << x << "," << y;
  auto d5 = dilate_mask(frame(0, 5, 4, ids), 5);
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 5; ++x) EXPECT_EQ(d5.at(x, y), (x <= 2 && y <= 2) ? 4 : 0) << x << "," << y;
}

TEST(Labels, DilationOverlapGoesToTheNearestOriginalPixel) {
  // Row of 7: id 1 at x=0, id 2 at x=3 and x=6... use 1 at 0 and 2 at 3.
  std::vector<uint16_t> ids{1, 0, 0, 2, 0, 0, 0};
  auto d = dilate_mask(frame(0, 7, 1, ids), 5);
  // x=1: dist 1 to id1, 2 to id2 -> 1. x=2: dist 2 to id1, 1 to id2 -> 2. x=4,5: 2. x=6: 0.
  std::vector<uint16_t> want{1, 1, 2, 2, 2, 2, 0};
  EXPECT_EQ(d.ids, want);
  // Equal distance: the smaller id wins.
  auto t = dilate_mask(frame(0, 3, 1, {9, 0, 4}), 3);
  std::vector<uint16_t> want_tie{9, 4, 4};
  EXPECT_EQ(t.ids, want_tie);
  // Diagonal neighbours are in the square but farther than straight ones.
  auto g = dilate_mask(frame(0, 2, 2, {7, 0, 0, 8}), 3);
  std::vector<uint16_t> want_g{7, 7, 7, 8};  // (1,0): dist 1 to 7 and 1 to 8 -> 7 (smaller)
  EXPECT_EQ(g.ids, want_g);
}

TEST(Labels, FilterBeforeDilation) {
  // Static object 1 next to moving object 2: after filtering, 2 grows over 1's pixels.
  std::vector<MaskFrame> masks{frame(0, 4, 1, {1, 1, 0, 2})};
  EventStream ev;
  ev.sensor = {4, 1};
  for (uint16_t x = 0; x < 4; ++x) ev.push_back(0, x, 0, 1);
  LabelOptions opt;
  opt.moving_ids = {2};
  opt.dilation = 5;
  label_from_masks(ev, masks, opt);
  std::vector<uint16_t> want{0, 2, 2, 2};
  EXPECT_EQ(ev.label, want);
}

TEST(Labels, Errors) {
  EventStream ev;
  ev.sensor = {2, 2};
  ev.push_back(0, 0, 0, 1);
  EXPECT_THROW(label_from_masks(ev, {}, {}), Error);
  EXPECT_THROW(label_from_masks(ev, {frame(0, 3, 2, std::vector<uint16_t>(6, 0))}, {}), Error);
  LabelOptions even;
  even.dilation = 4;
  EXPECT_THROW(label_from_masks(ev, {frame(0, 2, 2, std::vector<uint16_t>(4, 0))}, even), Error);
  EXPECT_THROW(dilate_mask(frame(0, 1, 1, {0}), 2), Error);
}
