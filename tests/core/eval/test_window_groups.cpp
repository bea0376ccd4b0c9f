// Groups of windows (`spikems eval --group-windows N`, WindowScorer::group_windows): the SpikeMS
// authors' test scores the sum of a batch of 8 consecutive samples, so P and G of a group's
// kept windows are united before the IoU, and the group counts once per kept window.
// Hand-made windows whose unions have a known IoU; skipped and filtered windows inside a
// group; the short last group; the files; refusals.
#include <gtest/gtest.h>

#include <cmath>

#include "core/eval/results.h"
#include "core/eval/window_scorer.h"
#include "core/util/error.h"

namespace spikems {
namespace {

constexpr int kWidth = 8;

// Window k of 1000 µs: `moving` events labelled 1 at pixel `px`, `background` events
// labelled 0 at pixel 7.
void add_window(EventStream& e, int64_t k, uint16_t px, int moving, int background) {
  const int n = moving + background;
  for (int i = 0; i < n; ++i)
    e.push_back(k * 1000 + i * 999 / n, i < moving ? px : 7, 0, 1, i < moving ? 1 : 0);
}

PredictionFrame frame(int64_t k, std::vector<uint16_t> on) {
  PredictionFrame f;
  f.width = kWidth;
  f.height = 1;
  f.t0_us = k * 1000;
  f.t1_us = f.t0_us + 1000;
  f.foreground.assign(kWidth, 0);
  for (uint16_t px : on) f.foreground[px] = 1;
  return f;
}

// Five windows: G = {0}, {1}, {} (nothing moves), {2}, {3}; P = {0}, {0}, {}, {5}, {3}.
// Per window the IoUs are 1, 0, (skipped), 0, 1. Window 1 holds `w1_moving` moving and
// `w1_background` background events.
EventStream five_windows(int w1_moving = 4, int w1_background = 0) {
  EventStream e;
  e.sensor = SensorSize{kWidth, 1};
  add_window(e, 0, 0, 4, 0);
  add_window(e, 1, 1, w1_moving, w1_background);
  add_window(e, 2, 0, 0, 4);
  add_window(e, 3, 2, 4, 0);
  add_window(e, 4, 3, 4, 0);
  e.push_back(5000, 7, 0, 1, 0);  // completes window 4
  return e;
}

WindowScores run(int group, double min_share = 0, const EventStream& e = five_windows()) {
  WindowScorer s(e.sensor, {1000});
  s.group_windows(group);
  s.min_moving_share(min_share);
  s.add_events(e);
  s.add_frame(frame(0, {0}));
  s.add_frame(frame(1, {0}));
  s.add_frame(frame(2, {}));
  s.add_frame(frame(3, {5}));
  s.add_frame(frame(4, {3}));
  s.finish(5001);
  return s.scores()[0];
}

TEST(WindowGroups, OneIsEveryWindowAlone) {
  const WindowScores w = run(1);
  ASSERT_EQ(w.windows(), 4u);
  EXPECT_EQ(w.skipped(), 1u);
  EXPECT_NEAR(w.mean_iou(), 0.5, 1e-12);  // (1 + 0 + 0 + 1) / 4
  EXPECT_NEAR(w.detection_rate(), 0.5, 1e-12);
}

TEST(WindowGroups, UnitesPAndGOverAGroupAndWeighsItByItsWindows) {
  // Groups of 2: {w0, w1}: P = {0}, G = {0, 1}: IoU 1/2, no detection (|P∩G| = |G| / 2),
  // twice. {w2, w3}: w2 has no G (skipped), w3 alone: IoU 0, once. {w4} (the short last
  // group): IoU 1, once. Mean (1/2 + 1/2 + 0 + 1) / 4.
  const WindowScores w = run(2);
  ASSERT_EQ(w.windows(), 4u);
  EXPECT_EQ(w.skipped(), 1u);
  EXPECT_NEAR(w.ious()[0], 0.5, 1e-12);
  EXPECT_NEAR(w.ious()[1], 0.5, 1e-12);
  EXPECT_NEAR(w.ious()[2], 0.0, 1e-12);
  EXPECT_NEAR(w.ious()[3], 1.0, 1e-12);
  EXPECT_NEAR(w.mean_iou(), 0.5, 1e-12);
  EXPECT_NEAR(w.std_iou(), std::sqrt((0.25 + 0.25) / 4), 1e-12);
  EXPECT_NEAR(w.detection_rate(), 0.25, 1e-12);  // the last group only

  // Groups of 5 hold everything: P = {0, 5, 3}, G = {0, 1, 2, 3}: |P∩G| = 2, |P∪G| = 5;
  // counted once per kept window (4).
  const WindowScores all = run(5);
  ASSERT_EQ(all.windows(), 4u);
  for (double v : all.ious()) EXPECT_NEAR(v, 0.4, 1e-12);
  EXPECT_NEAR(all.detection_rate(), 0.0, 1e-12);  // |P∩G| = |G| / 2 is not more than half
  // The group's moving share pools its kept windows' events (16 moving of 16: all move).
  for (double v : all.moving_shares()) EXPECT_DOUBLE_EQ(v, 1.0);
}

TEST(WindowGroups, FilteredWindowsStayOutOfTheUnions) {
  // Window 1 made 20 % moving: with the authors' filter (50 %) it is left out, so the first
  // group of 2 is w0 alone (IoU 1) and the mean is (1 + 0 + 1) / 3.
  const EventStream e = five_windows(1, 4);
  const WindowScores w = run(2, 0.5, e);
  ASSERT_EQ(w.windows(), 3u);
  EXPECT_EQ(w.filtered(), 1u);
  EXPECT_EQ(w.skipped(), 1u);
  EXPECT_NEAR(w.mean_iou(), 2.0 / 3.0, 1e-12);
  // Without the filter the 20 % window joins its group: P = {0}, G = {0, 1}: 1/2, twice.
  const WindowScores u = run(2, 0, e);
  ASSERT_EQ(u.windows(), 4u);
  EXPECT_NEAR(u.ious()[0], 0.5, 1e-12);
  EXPECT_NEAR(u.ious()[1], 0.5, 1e-12);
}

TEST(WindowGroups, FilesSayTheGroupsAndBadSizesAreRefused) {
  EvalResults r;
  r.windows_us = {1000};
  EXPECT_EQ(results_json(r)["group_windows"], 1);
  EXPECT_EQ(results_markdown(r).find("groups of"), std::string::npos);
  r.group_windows = 8;
  const auto j = results_json(r);
  EXPECT_EQ(j["group_windows"], 8);
  EXPECT_NE(j["protocol"]["iou"].get<std::string>().find("group_windows"), std::string::npos);
  EXPECT_NE(results_markdown(r).find("groups of 8 consecutive"), std::string::npos);

  const EventStream e = five_windows();
  WindowScorer s(e.sensor, {1000});
  EXPECT_THROW(s.group_windows(0), Error);
  s.add_events(e);
  EXPECT_THROW(s.group_windows(8), Error);  // after the first events
}

}  // namespace
}  // namespace spikems
