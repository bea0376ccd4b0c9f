// The report's pieces: which windows are shown, their P and G captured while scoring (no
// second pass), the picture of a window, and report.html with its plots and images.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>

#include "common/test_paths.h"
#include "core/eval/baseline_scorer.h"
#include "core/eval/report.h"
#include "core/util/error.h"
#include "core/viz/event_frame.h"
#include "core/viz/svg_plot.h"

namespace spikems {
namespace {

namespace fs = std::filesystem;

// A 4x2 sensor (pixel = y*4 + x); windows of 2 ms from the first event (as in
// test_baseline_scorer.cpp).
EventStream two_windows() {
  EventStream e;
  e.sensor = SensorSize{4, 2};
  e.push_back(0, 0, 0, 1, 1);     // window 0: moving px 0
  e.push_back(300, 1, 0, 0, 1);   //           moving px 1
  e.push_back(900, 2, 0, 1, 0);   //           background px 2
  e.push_back(2100, 0, 1, 1, 1);  // window 1: moving px 4
  e.push_back(2500, 1, 1, 0, 0);  //           background px 5
  e.push_back(2600, 2, 1, 0, 0);  //           background px 6
  e.push_back(3000, 2, 1, 1, 0);  //           px 6 again
  e.push_back(4100, 3, 1, 1, 0);  // window 2: background only (px 7)
  e.push_back(6000, 3, 0, 1, 1);  // window 3 is partial (data ends at 6001)
  return e;
}

std::vector<uint8_t> mask(std::initializer_list<int> pixels, size_t n = 8) {
  std::vector<uint8_t> m(n, 0);
  for (int p : pixels) m[size_t(p)] = 1;
  return m;
}

TEST(Report, ExampleWindowsAreEvenlySpacedOverWindowsWithMovingObjects) {
  LabelledSequence s{"hand", two_windows()};
  // Moving events lie in windows 0, 1 and the partial window 3 (not complete: never shown).
  EXPECT_EQ(example_windows(s, 2000, 3), (std::vector<int64_t>{0, 1}));
  EXPECT_EQ(example_windows(s, 2000, 1), (std::vector<int64_t>{1}));  // the middle of {0, 1}
  EXPECT_TRUE(example_windows(s, 2000, 0).empty());
  EXPECT_EQ(example_windows(s, 2000, 3, 2000), (std::vector<int64_t>{0}));  // cut at 2 ms

  // Ten 1 ms windows, each with a moving event; three shown: the middles of three equal
  // shares of 0..9 = indices 10/6, 30/6, 50/6 = 1, 5, 8.
  EventStream e;
  e.sensor = SensorSize{4, 2};
  for (int k = 0; k <= 10; ++k) e.push_back(k * 1000, 0, 0, 1, 1);
  LabelledSequence ten{"ten", e};
  EXPECT_EQ(example_windows(ten, 1000, 3), (std::vector<int64_t>{1, 5, 8}));
}

TEST(Report, CapturedWindowsAreThoseScored) {
  LabelledSequence s{"hand", two_windows()};
  SequenceScoreOptions o;
  o.capture_window_us = 2000;
  o.capture_windows = {2, 0, 1};
  SequenceScore r = score_all_events(s, {2000, 4000}, o);
  ASSERT_EQ(r.captured.size(), 3u);  // in time order
  const CapturedWindow& w0 = r.captured[0];
  EXPECT_EQ(w0.index, 0);
  EXPECT_EQ(w0.t0_us, 0);
  EXPECT_EQ(w0.t1_us, 2000);
  EXPECT_EQ(w0.width, 4);
  EXPECT_EQ(w0.height, 2);
  EXPECT_EQ(w0.predicted, mask({0, 1, 2}));  // every pixel with an event
  EXPECT_EQ(w0.truth, mask({0, 1}));
  EXPECT_EQ(w0.counts.intersection, 2u);
  EXPECT_EQ(w0.counts.predicted, 3u);
  EXPECT_EQ(w0.counts.truth, 2u);
  const CapturedWindow& w1 = r.captured[1];
  EXPECT_EQ(w1.t0_us, 2000);
  EXPECT_EQ(w1.predicted, mask({4, 5, 6}));
  EXPECT_EQ(w1.truth, mask({4}));
  // Window 2 has no moving object: skipped by the scores, still captured with its P.
  EXPECT_EQ(r.captured[2].predicted, mask({7}));
  EXPECT_EQ(r.captured[2].truth, mask({}));
  EXPECT_EQ(r.captured[2].counts.truth, 0u);
  // The scores are those without capturing.
  EXPECT_NEAR(r.scores[0].mean_iou(), (2.0 / 3 + 1.0 / 3) / 2, 1e-12);

  o.capture_window_us = 3000;  // not a scored length
  EXPECT_THROW(score_all_events(s, {2000, 4000}, o), Error);
}

TEST(Report, ExampleWindowLengthPrefers20ms) {
  EXPECT_EQ(example_window_length({10000, 20000, 100000}), 20000);
  EXPECT_EQ(example_window_length({10000, 25000}), 25000);
  EXPECT_EQ(example_window_length({15000, 25000}), 15000);  // a tie: the shorter
  EXPECT_EQ(example_window_length({100000}), 100000);
}

ExampleWindow hand_window() {
  ExampleWindow w;
  w.t0_us = 2000;
  w.t1_us = 4000;
  w.width = 4;
  w.height = 2;
  w.events = render_events(two_windows(), 0, 2000, SensorSize{4, 2});
  w.truth = mask({0, 1});
  w.predicted = {mask({0, 2})};
  w.counts = {count_masks(w.predicted[0], w.truth)};
  return w;
}

TEST(Report, ExampleImageIsEventsTruthAndPrediction) {
  const ExampleWindow w = hand_window();
  // 4 pixels wide: enlarged 4 times (the most) to 16x8, framed 18x10; 3 panels, gaps of 6.
  const Image img = example_image(w);
  ASSERT_EQ(img.width, 3 * 18 + 2 * 6);
  ASSERT_EQ(img.height, 10);
  auto is = [&](int x, int y, Rgb c) { return img.is(x, y, c.r, c.g, c.b); };
  EXPECT_TRUE(is(1, 1, kOnColor));                 // events: px 0 is ON
  EXPECT_TRUE(is(1 + 4, 1, kOffColor));            // px 1 is OFF
  EXPECT_TRUE(is(24 + 1, 1, kMaskColor));          // truth: px 0
  EXPECT_TRUE(is(24 + 1 + 8, 1, kBackground));     // px 2 is not moving
  EXPECT_TRUE(is(48 + 1, 1, kTruePositive));       // prediction: px 0 found
  EXPECT_TRUE(is(48 + 1 + 4, 1, kFalseNegative));  // px 1 missed
  EXPECT_TRUE(is(48 + 1 + 8, 1, kFalsePositive));  // px 2 predicted, not moving
  ExampleWindow bad = w;
  bad.predicted[0].pop_back();
  EXPECT_THROW(example_image(bad), Error);
}

std::string slurp(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

TEST(Report, PageHasTablesPlotsAndEveryImageItLinks) {
  LabelledSequence s{"data/hand.h5", two_windows()};
  SequenceScoreOptions o;
  o.capture_window_us = 2000;
  o.capture_windows = example_windows(s, 2000, 3);
  const SequenceScore sc = score_all_events(s, {2000, 4000}, o);
  EvalResults r;
  r.command_line = "spikems eval --baseline all-events --data data/hand.h5 --windows 2,4";
  r.date = "2024-01-01T00:00:00Z";
  r.windows_us = {2000, 4000};
  ModelResult m;
  m.path = "baseline:all-events";
  m.name = "every event moving";
  m.datasets = {dataset_result("data/hand.h5", "", {sc})};
  r.models = {m};
  EvalExamples ex;
  ex.window_us = 2000;
  SequenceExamples se;
  se.name = s.name;
  for (const CapturedWindow& c : sc.captured) {
    ExampleWindow w;
    w.t0_us = c.t0_us;
    w.t1_us = c.t1_us;
    w.width = c.width;
    w.height = c.height;
    w.events = render_events(s.events, c.t0_us, c.t1_us, s.events.sensor);
    w.truth = c.truth;
    w.predicted = {c.predicted};
    w.counts = {c.counts};
    se.windows.push_back(std::move(w));
  }
  ex.datasets = {{se}};

  const std::string dir = test::scratch_dir() + "/out";
  const std::string path = write_report(r, ex, dir);
  EXPECT_EQ(path, dir + "/report.html");
  const std::string html = slurp(path);
  // Both tables, with the rows the text tables have.
  EXPECT_NE(html.find("<caption>per dataset and window length</caption>"), std::string::npos);
  EXPECT_NE(html.find("<caption>per sequence and window length</caption>"), std::string::npos);
  for (const auto& h : summary_table(r).header)
    EXPECT_NE(html.find("<th>" + xml_escape(h) + "</th>"), std::string::npos) << h;
  // IoU 2 ms: windows 0 (2/3) and 1 (1/3): 50.0 ± 16.7; detections 1 of 2.
  EXPECT_NE(html.find("<td>50.0 ± 16.7</td><td>50.0</td>"), std::string::npos) << html;
  EXPECT_NE(html.find("src=\"plots/iou_by_window_1.svg\""), std::string::npos);
  EXPECT_NE(html.find("src=\"plots/iou_per_sequence_1.svg\""), std::string::npos);
  // The size bands: their table (labelled events, so the shares are known) and their bars.
  EXPECT_NE(html.find("src=\"plots/iou_by_share_1.svg\""), std::string::npos);
  for (const auto& h : band_table(r).header)
    EXPECT_NE(html.find("<th>" + xml_escape(h) + "</th>"), std::string::npos) << h;
  EXPECT_EQ(band_table(r).header.size(), 7u);  // 4 + the three default bands
  // Two example windows (0 and 1); the first caption carries its IoU, 2 of 3 pixels.
  EXPECT_NE(html.find("src=\"windows/hand_000000000us.png\""), std::string::npos);
  EXPECT_NE(html.find("src=\"windows/hand_000002000us.png\""), std::string::npos);
  EXPECT_NE(html.find("0–2 ms: baseline:all-events IoU 66.7 %"), std::string::npos) << html;
  // Every image the page names exists beside it; the PNGs are the pictures of the windows.
  const std::regex src("src=\"([^\"]+)\"");
  int images = 0;
  for (auto it = std::sregex_iterator(html.begin(), html.end(), src); it != std::sregex_iterator();
       ++it, ++images)
    EXPECT_TRUE(fs::is_regular_file(dir + "/" + (*it)[1].str())) << (*it)[1].str();
  EXPECT_EQ(images, 5);
  const Image png = read_png_rgb(dir + "/windows/hand_000000000us.png");
  const Image want = example_image(ex.datasets[0][0].windows[0]);
  EXPECT_EQ(png.width, want.width);
  EXPECT_EQ(png.rgb, want.rgb);
  // The line plot has the baseline's two points (2 and 4 ms).
  const std::string svg = slurp(dir + "/plots/iou_by_window_1.svg");
  EXPECT_NE(svg.find("baseline:all-events"), std::string::npos);
  EXPECT_NE(svg.find("x=2, y=50"), std::string::npos) << svg;
}

}  // namespace
}  // namespace spikems
