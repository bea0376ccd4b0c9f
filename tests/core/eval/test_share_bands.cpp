// Size bands (`spikems eval --share-bands`): each scored window carries the share of its input
// events that are truly moving, and the summaries split the windows by it. Hand-made windows
// with known shares, IoUs and detections; pooled sequences; bad edges. Also the moving-share
// filter (`--min-moving-share`), which keeps the top band only.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>

#include "core/eval/results.h"
#include "core/eval/window_scorer.h"
#include "core/util/error.h"

namespace spikems {
namespace {

// Window k of 1000 µs holds `moving` events labelled 1 at pixel 0 and `background` events
// labelled 0 at pixel 1.
void add_window(EventStream& e, int64_t k, int moving, int background) {
  const int n = moving + background;
  for (int i = 0; i < n; ++i)
    e.push_back(k * 1000 + i * 999 / n, i < moving ? 0 : 1, 0, 1, i < moving ? 1 : 0);
}

PredictionFrame frame(int64_t k, std::vector<uint8_t> fg) {
  PredictionFrame f;
  f.width = 4;
  f.height = 1;
  f.t0_us = k * 1000;
  f.t1_us = f.t0_us + 1000;
  f.foreground = std::move(fg);
  return f;
}

TEST(ShareBands, EachWindowCarriesTheShareOfItsEventsThatMove) {
  EventStream e;
  e.sensor = SensorSize{4, 1};
  add_window(e, 0, 1, 9);         // 10 %: the lowest edge of the top band belongs to it
  add_window(e, 1, 1, 99);        // 1 %
  add_window(e, 2, 1, 19);        // 5 %
  add_window(e, 3, 0, 5);         // nothing moves: skipped, no share recorded
  e.push_back(4000, 3, 0, 1, 0);  // completes window 3
  WindowScorer s(e.sensor, {1000});
  s.add_events(e);
  // G = {0} in windows 0-2. P: {0} (IoU 1), {0, 1} (IoU 1/2, no detection: 1 right, 1 wrong
  // is not more right than wrong), nothing (IoU 0).
  s.add_frame(frame(0, {1, 0, 0, 0}));
  s.add_frame(frame(1, {1, 1, 0, 0}));
  s.add_frame(frame(2, {0, 0, 0, 0}));
  s.add_frame(frame(3, {1, 1, 1, 1}));
  s.finish(4001);
  const WindowScores& w = s.scores()[0];
  ASSERT_EQ(w.windows(), 3u);
  EXPECT_EQ(w.skipped(), 1u);  // window 3 (no G); window 4 is partial, so dropped
  ASSERT_EQ(w.moving_shares().size(), 3u);
  EXPECT_DOUBLE_EQ(w.moving_shares()[0], 0.10);
  EXPECT_DOUBLE_EQ(w.moving_shares()[1], 0.01);
  EXPECT_DOUBLE_EQ(w.moving_shares()[2], 0.05);
  EXPECT_EQ(w.detections(), (std::vector<uint8_t>{1, 0, 0}));

  const WindowSummary sum = summarize(1000, {&w});
  ASSERT_EQ(sum.bands.size(), 3u);  // default edges 2 and 10 %
  EXPECT_EQ(sum.bands[0].lo_pct, 0);
  EXPECT_EQ(sum.bands[0].hi_pct, 2);
  EXPECT_EQ(sum.bands[2].lo_pct, 10);
  EXPECT_EQ(sum.bands[2].hi_pct, 100);
  EXPECT_EQ(sum.bands[0].windows, 1u);  // 1 %
  EXPECT_NEAR(sum.bands[0].iou_mean, 50.0, 1e-9);
  EXPECT_NEAR(sum.bands[0].detection_rate, 0.0, 1e-9);
  EXPECT_EQ(sum.bands[1].windows, 1u);  // 5 %
  EXPECT_NEAR(sum.bands[1].iou_mean, 0.0, 1e-9);
  EXPECT_EQ(sum.bands[2].windows, 1u);  // 10 %
  EXPECT_NEAR(sum.bands[2].iou_mean, 100.0, 1e-9);
  EXPECT_NEAR(sum.bands[2].detection_rate, 100.0, 1e-9);
  EXPECT_NEAR(sum.iou_mean, 50.0, 1e-9);  // the whole row is unchanged: (1 + 0.5 + 0) / 3

  // Other edges regroup the same windows: < 6 % holds the 1 % and 5 % windows.
  const WindowSummary six = summarize(1000, {&w}, {}, {6});
  ASSERT_EQ(six.bands.size(), 2u);
  EXPECT_EQ(six.bands[0].windows, 2u);
  EXPECT_NEAR(six.bands[0].iou_mean, 25.0, 1e-9);
  EXPECT_NEAR(six.bands[0].iou_std, 25.0, 1e-9);  // population std of {0.5, 0}
  EXPECT_EQ(six.bands[1].windows, 1u);
  EXPECT_TRUE(summarize(1000, {&w}, {}, {}).bands.empty());  // no edges: no bands
}

TEST(ShareBands, PoolsTheWindowsOfSeveralSequences) {
  MaskCounts hit{2, 2, 2}, half{1, 2, 1}, miss{0, 0, 3};  // IoU 1, 0.5, 0
  WindowScores a, b;
  a.add(hit, 0.5);
  a.add(miss, 0.001);
  b.add(half, 0.3);
  b.add(hit, 0.015);
  b.add(hit, 0.05);
  const WindowSummary s = summarize(20000, {&a, &b}, {}, {2, 10});
  ASSERT_EQ(s.bands.size(), 3u);
  EXPECT_EQ(s.bands[0].windows, 2u);  // 0.1 % (miss) and 1.5 % (hit)
  EXPECT_NEAR(s.bands[0].iou_mean, 50.0, 1e-9);
  EXPECT_NEAR(s.bands[0].detection_rate, 50.0, 1e-9);
  EXPECT_EQ(s.bands[1].windows, 1u);  // 5 %
  EXPECT_NEAR(s.bands[1].iou_mean, 100.0, 1e-9);
  EXPECT_EQ(s.bands[2].windows, 2u);  // 50 % (hit) and 30 % (half: IoU 0.5)
  EXPECT_NEAR(s.bands[2].iou_mean, 75.0, 1e-9);
  // half: |P∩G| = 1 > 0.5 |G| = 0.5 but not > |P \ G| = 1: no detection.
  EXPECT_NEAR(s.bands[2].detection_rate, 50.0, 1e-9);
  size_t n = 0;
  for (const auto& band : s.bands) n += band.windows;
  EXPECT_EQ(n, s.windows);
}

TEST(ShareBands, TrackingCanBeTurnedOffBeforeTheFirstEvents) {
  EventStream e;
  e.sensor = SensorSize{4, 1};
  add_window(e, 0, 1, 9);
  e.push_back(1000, 1, 0, 1, 0);
  WindowScorer s(e.sensor, {1000});
  s.track_moving_share(false);  // `--share-bands none`: the scores stay, the shares are unknown
  s.add_events(e);
  s.add_frame(frame(0, {1, 0, 0, 0}));
  s.finish(1001);
  ASSERT_EQ(s.scores()[0].windows(), 1u);
  EXPECT_DOUBLE_EQ(s.scores()[0].mean_iou(), 1.0);
  EXPECT_TRUE(std::isnan(s.scores()[0].moving_shares()[0]));
  EXPECT_TRUE(summarize(1000, {&s.scores()[0]}).bands.empty());
  WindowScorer late(e.sensor, {1000});
  late.add_events(e);
  EXPECT_THROW(late.track_moving_share(false), Error);
}

TEST(ShareBands, UnknownSharesGiveNoBands) {
  WindowScores w;  // as with boxes for truth: no labels, no share
  w.add(MaskCounts{1, 1, 1});
  w.add(MaskCounts{0, 1, 1});
  EXPECT_TRUE(std::isnan(w.moving_shares()[0]));
  const WindowSummary s = summarize(10000, {&w});
  EXPECT_EQ(s.windows, 2u);
  EXPECT_TRUE(s.bands.empty());
}

TEST(ShareBands, EdgesMustIncreaseInsideZeroToHundred) {
  EXPECT_NO_THROW(check_band_edges({}));
  EXPECT_NO_THROW(check_band_edges({2, 10}));
  EXPECT_THROW(check_band_edges({10, 2}), Error);
  EXPECT_THROW(check_band_edges({2, 2}), Error);
  EXPECT_THROW(check_band_edges({0}), Error);
  EXPECT_THROW(check_band_edges({100}), Error);
  EXPECT_THROW(check_band_edges({std::nan("")}), Error);
  WindowScores w;
  w.add(MaskCounts{1, 1, 1}, 0.5);
  EXPECT_THROW(summarize(1000, {&w}, {}, {50, 5}), Error);
}

// The authors' window filter (`spikems eval --min-moving-share`): only windows in which a
// given share of the input events moves are scored, the others with moving events counted as
// filtered; the summaries and files carry the count; refusals.

// Windows of shares 60 %, 50 %, 40 % and 0 % (nothing moves), each predicted {0, 1}: IoU 1/2
// where G = {0}. P for the 50 % window is {0} alone (IoU 1), so the kept windows' mean tells
// which were kept.
EventStream four_windows() {
  EventStream e;
  e.sensor = SensorSize{4, 1};
  add_window(e, 0, 6, 4);
  add_window(e, 1, 5, 5);
  add_window(e, 2, 4, 6);
  add_window(e, 3, 0, 5);
  e.push_back(4000, 3, 0, 1, 0);  // completes window 3
  return e;
}

void add_frames(WindowScorer& s) {
  s.add_frame(frame(0, {1, 1, 0, 0}));
  s.add_frame(frame(1, {1, 0, 0, 0}));
  s.add_frame(frame(2, {1, 1, 0, 0}));
  s.add_frame(frame(3, {1, 1, 0, 0}));
}

TEST(MovingShareFilter, KeepsWindowsAtOrAboveTheShareAndCountsTheRest) {
  const EventStream e = four_windows();
  WindowScorer s(e.sensor, {1000});
  s.track_moving_share(false);  // the filter needs the shares and turns them back on
  s.min_moving_share(0.5);
  s.add_events(e);
  add_frames(s);
  s.finish(4001);
  const WindowScores& w = s.scores()[0];
  ASSERT_EQ(w.windows(), 2u);   // 60 % and 50 % (the edge is kept, as the authors' `>` drops)
  EXPECT_EQ(w.filtered(), 1u);  // 40 %
  EXPECT_EQ(w.skipped(), 1u);   // nothing moving: skipped, not filtered
  EXPECT_DOUBLE_EQ(w.moving_shares()[0], 0.6);
  EXPECT_DOUBLE_EQ(w.moving_shares()[1], 0.5);
  EXPECT_NEAR(w.mean_iou(), 0.75, 1e-12);  // (1/2 + 1) / 2

  // Without the filter the same windows give three scored, none filtered.
  WindowScorer all(e.sensor, {1000});
  all.add_events(e);
  add_frames(all);
  all.finish(4001);
  EXPECT_EQ(all.scores()[0].windows(), 3u);
  EXPECT_EQ(all.scores()[0].filtered(), 0u);
  EXPECT_NEAR(all.scores()[0].mean_iou(), (0.5 + 1 + 0.5) / 3, 1e-12);

  // A threshold just above 50 % leaves the 60 % window only.
  WindowScorer strict(e.sensor, {1000});
  strict.min_moving_share(0.55);
  strict.add_events(e);
  add_frames(strict);
  strict.finish(4001);
  EXPECT_EQ(strict.scores()[0].windows(), 1u);
  EXPECT_EQ(strict.scores()[0].filtered(), 2u);
}

TEST(MovingShareFilter, SummariesAndFilesCarryTheFilteredCount) {
  const EventStream e = four_windows();
  WindowScorer s(e.sensor, {1000});
  s.min_moving_share(0.5);
  s.add_events(e);
  add_frames(s);
  s.finish(4001);
  const WindowSummary sum = summarize(1000, {&s.scores()[0], &s.scores()[0]});
  EXPECT_EQ(sum.windows, 4u);
  EXPECT_EQ(sum.filtered, 2u);
  EXPECT_EQ(sum.skipped, 2u);
  EXPECT_NEAR(sum.iou_mean, 75.0, 1e-9);

  EvalResults r;
  r.windows_us = {1000};
  r.min_moving_share_pct = 50;
  ModelResult m;
  m.path = "m.safetensors";
  DatasetResult d;
  d.data = "data/x";
  d.windows = {sum};
  m.datasets = {d};
  r.models = {m};
  const auto j = results_json(r);
  EXPECT_EQ(j["min_moving_share_pct"], 50.0);
  EXPECT_EQ(j["models"][0]["datasets"][0]["windows"][0]["filtered_windows"], 2u);
  EXPECT_TRUE(j["protocol"].contains("filtered"));
  const std::string csv = results_csv(r);
  EXPECT_NE(csv.find("output_gate_ms,filtered_windows\n"), std::string::npos) << csv;
  EXPECT_NE(csv.find(",2\n"), std::string::npos) << csv;  // the count ends the row
  const TextTable t = summary_table(r);
  ASSERT_EQ(t.header.size(), 13u);
  EXPECT_EQ(t.header[11], "filtered");
  EXPECT_EQ(t.rows[0][11], "2");
  EXPECT_NE(results_markdown(r).find("at least 50 %"), std::string::npos);

  r.min_moving_share_pct = 0;  // off: no column, null in the file
  EXPECT_EQ(summary_table(r).header.size(), 12u);
  EXPECT_TRUE(results_json(r)["min_moving_share_pct"].is_null());
}

TEST(MovingShareFilter, RefusesBadSharesBoxesAndLateCalls) {
  const EventStream e = four_windows();
  WindowScorer s(e.sensor, {1000});
  EXPECT_THROW(s.min_moving_share(1.0), Error);
  EXPECT_THROW(s.min_moving_share(-0.1), Error);
  auto boxes = std::make_shared<const BoxTruth>();
  WindowScorer b(e.sensor, {1000});
  b.use_boxes(boxes);
  EXPECT_THROW(b.min_moving_share(0.5), Error);  // boxes give no share
  WindowScorer b2(e.sensor, {1000});
  b2.min_moving_share(0.5);
  EXPECT_THROW(b2.use_boxes(boxes), Error);
  s.add_events(e);
  EXPECT_THROW(s.min_moving_share(0.5), Error);  // after the first events
}

}  // namespace
}  // namespace spikems
