// Box ground truth (`spikems eval --boxes`, core/eval/boxes.h): the CSV parser on good and
// bad hand-made files (every error names file:line), which events lie in a valid box, and
// the window scores with G = box pixels on a hand-made case counted by hand.
#include <gtest/gtest.h>

#include <random>
#include <sstream>

#include "core/eval/boxes.h"
#include "core/eval/window_scorer.h"
#include "core/util/error.h"

namespace spikems {
namespace {

BoxTruth parse(const std::string& text) {
  std::istringstream in(text);
  return BoxTruth::parse(in, "b.csv");
}

// The message of the Error parse() throws ("" when it does not throw).
std::string parse_error(const std::string& text) {
  try {
    parse(text);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(BoxParser, ReadsRowsCommentsAndBothHeaders) {
  const BoxTruth b = parse(
      "# EED-style boxes\r\n"
      "t_start_us, t_end_us, x0, y0, x1, y1, id\r\n"
      "\r\n"
      "1000,21000,10,10,19,19,3\r\n"
      "1000,5000, 0,0,0,0,4\r\n"  // same start: several objects at once
      "# a comment between rows\n"
      "30000,40000,2,5,7,9,3\n");
  ASSERT_EQ(b.boxes().size(), 3u);
  const Box& a = b.boxes()[0];
  EXPECT_EQ(a.t_start_us, 1000);
  EXPECT_EQ(a.t_end_us, 21000);
  EXPECT_EQ(a.x0, 10);
  EXPECT_EQ(a.y0, 10);
  EXPECT_EQ(a.x1, 19);
  EXPECT_EQ(a.y1, 19);
  EXPECT_EQ(a.id, 3);
  EXPECT_EQ(a.line, 4u);
  EXPECT_EQ(b.boxes()[1].id, 4);
  EXPECT_EQ(b.boxes()[2].line, 7u);
  EXPECT_EQ(b.boxes()[2].x0, 2);
  EXPECT_EQ(b.boxes()[2].y1, 9);
  const BoxTruth n = parse("t_start_us,t_end_us,x0,y0,x1,y1\n0,1,0,0,5,5\n");
  ASSERT_EQ(n.boxes().size(), 1u);
  EXPECT_EQ(n.boxes()[0].id, -1);
  EXPECT_EQ(n.boxes()[0].x1, 5);
}

TEST(BoxParser, EveryBadFileNamesFileLineAndReason) {
  const std::string h = "t_start_us,t_end_us,x0,y0,x1,y1\n";
  struct Case {
    std::string text, where, why;
  };
  const Case cases[] = {
      {"", "b.csv: at line 1", "empty file"},
      {"# only a comment\n\n", "b.csv: at line 1", "empty file"},
      {"t_us,x0,y0,x1,y1\n0,0,0,1,1\n", "b.csv: at line 1", "expected the header"},
      {"0,10,0,0,1,1\n", "b.csv: at line 1", "expected the header"},  // no header
      {h, "b.csv: at line 1", "no box after the header"},
      {h + "0,10,0,0,1\n", "b.csv: at line 2", "expected 6 comma-separated fields, found 5"},
      {h + "0,10,0,0,1,1,7\n", "b.csv: at line 2", "expected 6"},  // id without its header
      {h + "0,10,a,0,1,1\n", "b.csv: at line 2", "x0 = \"a\" is not a whole number"},
      {h + "0,10,0,0,1.5,1\n", "b.csv: at line 2", "x1 = \"1.5\" is not a whole number"},
      {h + "0,,0,0,1,1\n", "b.csv: at line 2", "t_end_us = \"\" is not a whole number"},
      {h + "0,10,-1,0,1,1\n", "b.csv: at line 2", "x0 = -1 is negative"},
      {h + "0,10,5,0,4,1\n", "b.csv: at line 2", "x1 (4) is left of x0 (5)"},
      {h + "0,10,0,5,1,4\n", "b.csv: at line 2", "y1 (4) is above y0 (5)"},
      {h + "10,10,0,0,1,1\n", "b.csv: at line 2", "t_end_us (10) must be after t_start_us (10)"},
      {h + "0,10,0,0,1,1\n\n5,20,0,0,1,1\n3,20,0,0,1,1\n", "b.csv: at line 5", "times go back"},
  };
  for (const Case& c : cases) {
    const std::string e = parse_error(c.text);
    EXPECT_NE(e.find(c.where), std::string::npos) << "file:\n" << c.text << "\nerror: " << e;
    EXPECT_NE(e.find(c.why), std::string::npos) << "file:\n" << c.text << "\nerror: " << e;
  }
  // A missing file: named, with the reason.
  try {
    BoxTruth::read("/nonexistent/boxes.csv");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/boxes.csv"), std::string::npos);
  }
}

TEST(BoxParser, BoxesOutsideTheSensorAreRefusedByLine) {
  const BoxTruth b = parse("t_start_us,t_end_us,x0,y0,x1,y1\n0,10,0,0,31,31\n0,10,0,0,32,5\n");
  EXPECT_NO_THROW(b.check_sensor({33, 32}));
  try {
    b.check_sensor({32, 32});
    FAIL() << "no error";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("b.csv: at line 3"), std::string::npos) << m;
    EXPECT_NE(m.find("outside the 32x32 sensor"), std::string::npos) << m;
  }
  try {
    b.check_sensor({40, 31});  // now the first box's y1 = 31 is out
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("at line 2"), std::string::npos) << e.what();
  }
}

TEST(BoxTruthEvents, MovingMeansInsideABoxValidAtTheEventsTime) {
  // Box A over [1000, 2000) at x 2..4, y 1..3; box B over [1500, 9000) at pixel (0, 0) only;
  // box C starts after A and B and is long: the walk back must still find B behind it.
  const BoxTruth b = parse(
      "t_start_us,t_end_us,x0,y0,x1,y1\n1000,2000,2,1,4,3\n1500,9000,0,0,0,0\n1600,1700,8,8,8,8\n");
  EXPECT_FALSE(b.contains(999, 2, 1));   // before A starts
  EXPECT_TRUE(b.contains(1000, 2, 1));   // start inclusive, corner inclusive
  EXPECT_TRUE(b.contains(1999, 4, 3));   // far corner inclusive
  EXPECT_FALSE(b.contains(2000, 4, 3));  // end exclusive
  EXPECT_FALSE(b.contains(1500, 5, 3));  // right of A
  EXPECT_FALSE(b.contains(1500, 4, 4));  // below A
  EXPECT_TRUE(b.contains(8999, 0, 0));   // B, long after C ended
  EXPECT_FALSE(b.contains(9000, 0, 0));
  EXPECT_TRUE(b.contains(1650, 8, 8));  // C
  EXPECT_FALSE(b.contains(1700, 8, 8));

  EventStream e;
  e.sensor = {10, 10};
  e.push_back(500, 2, 1, 1, 7);   // before any box: 0 (its old label replaced)
  e.push_back(1200, 3, 2, 0, 0);  // inside A: 1
  e.push_back(1600, 0, 0, 1, 0);  // inside B: 1
  e.push_back(2500, 3, 2, 1, 0);  // A has ended: 0
  b.label(e);
  EXPECT_EQ(e.label, (std::vector<uint16_t>{0, 1, 1, 0}));
}

// label() sweeps over the events; contains() searches the boxes: the same answer for random
// boxes (long ones among short ones, equal starts) and events, sorted or not.
TEST(BoxTruthEvents, TheSweepAgreesWithTheSearch) {
  std::mt19937 rng(7);
  std::ostringstream f;
  f << "t_start_us,t_end_us,x0,y0,x1,y1\n";
  int64_t t = 0;
  for (int i = 0; i < 200; ++i) {
    t += int64_t(rng() % 3) * 100;  // equal starts now and then
    const int64_t len = rng() % 10 == 0 ? 50000 : 50 + rng() % 500;
    const int x0 = int(rng() % 20), y0 = int(rng() % 20);
    f << t << ',' << t + len << ',' << x0 << ',' << y0 << ',' << x0 + int(rng() % 5) << ','
      << y0 + int(rng() % 5) << '\n';
  }
  const BoxTruth b = parse(f.str());
  for (bool sorted : {true, false}) {
    EventStream e;
    e.sensor = {25, 25};
    for (int i = 0; i < 5000; ++i)
      e.push_back(sorted ? int64_t(i) * 6 : int64_t(rng() % 30000), uint16_t(rng() % 25),
                  uint16_t(rng() % 25), 1, 0);
    b.label(e);
    size_t moving = 0;
    for (size_t i = 0; i < e.size(); ++i) {
      ASSERT_EQ(e.label[i] != 0, b.contains(e.t[i], e.x[i], e.y[i])) << "event " << i;
      moving += e.label[i];
    }
    EXPECT_GT(moving, 100u);  // the case is not trivially all outside
    EXPECT_LT(moving, e.size());
  }
}

// Sensor 32x32; windows of 10 ms from the first event at t = 0.
//   box A: [0, 20000), pixels x 10..19, y 10..19 (10x10 = 100 pixels): windows 0 and 1;
//   box B: [25000, 26000), pixels x 30..31, y 30..31 (4 pixels): window 2 only.
//   Window 0: P = x 10..15, y 10..19 (60 pixels inside A) + x 0..9, y 0 (10 outside):
//             |P∩G| = 60, |P∪G| = 110, IoU = 6/11; detection (60 > 50 and 60 > 10).
//   Window 1: P empty: IoU 0, no detection.
//   Window 2: P = (30, 30): |P∩G| = 1, |P∪G| = 4, IoU = 1/4; no detection (1 <= 0.5 * 4).
//   Window 3: no valid box: skipped, whatever is predicted (here the whole box A again).
// The events carry no labels and sit away from the boxes: G is box pixels, not event pixels.
TEST(BoxTruthWindows, GIsTheBoxPixelsOfTheWindowCountedByHand) {
  const auto boxes = std::make_shared<const BoxTruth>(
      parse("t_start_us,t_end_us,x0,y0,x1,y1,id\n0,20000,10,10,19,19,1\n"
            "25000,26000,30,30,31,31,2\n"));
  EventStream e;
  e.sensor = {32, 32};
  e.push_back(0, 1, 1, 1, 0);
  e.push_back(39999, 1, 1, 1, 0);
  e.label.clear();  // unlabelled, as an EED recording
  ASSERT_FALSE(e.has_labels());

  auto frame = [](int64_t t0, auto&& set) {
    PredictionFrame f;
    f.width = f.height = 32;
    f.t0_us = t0;
    f.t1_us = t0 + 10000;
    f.foreground.assign(32 * 32, 0);
    set(f.foreground);
    return f;
  };
  auto rect = [](std::vector<uint8_t>& m, int x0, int y0, int x1, int y1) {
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) m[size_t(y) * 32 + size_t(x)] = 1;
  };
  WindowScorer s(e.sensor, {10000});
  s.use_boxes(boxes);
  s.capture(10000, {0});
  s.add_events(e);
  s.add_frame(frame(0, [&](auto& m) {
    rect(m, 10, 10, 15, 19);
    rect(m, 0, 0, 9, 0);
  }));
  s.add_frame(frame(10000, [](auto&) {}));
  s.add_frame(frame(20000, [&](auto& m) { rect(m, 30, 30, 30, 30); }));
  s.add_frame(frame(30000, [&](auto& m) { rect(m, 10, 10, 19, 19); }));
  s.finish(40000);
  const WindowScores& w = s.scores()[0];
  ASSERT_EQ(w.windows(), 3u);
  EXPECT_EQ(w.skipped(), 1u);
  ASSERT_EQ(w.ious().size(), 3u);
  EXPECT_NEAR(w.ious()[0], 6.0 / 11.0, 1e-12);
  EXPECT_NEAR(w.ious()[1], 0.0, 1e-12);
  EXPECT_NEAR(w.ious()[2], 0.25, 1e-12);
  EXPECT_NEAR(w.detection_rate(), 1.0 / 3.0, 1e-12);
  // The captured window shows the box as G.
  ASSERT_EQ(s.captured().size(), 1u);
  const CapturedWindow& c = s.captured()[0];
  EXPECT_EQ(c.counts.truth, 100u);
  EXPECT_EQ(c.counts.intersection, 60u);
  EXPECT_EQ(c.counts.predicted, 70u);
  EXPECT_EQ(c.truth[size_t(10) * 32 + 10], 1);
  EXPECT_EQ(c.truth[size_t(19) * 32 + 19], 1);
  EXPECT_EQ(c.truth[size_t(20) * 32 + 19], 0);

  // Without boxes, unlabelled events are refused as before; boxes outside the sensor or set
  // after the first events are refused too.
  WindowScorer plain(e.sensor, {10000});
  EXPECT_THROW(plain.add_events(e), Error);
  WindowScorer small({16, 16}, {10000});
  EXPECT_THROW(small.use_boxes(boxes), Error);
  WindowScorer late(e.sensor, {10000});
  late.use_boxes(boxes);
  late.add_events(e);
  EXPECT_THROW(late.use_boxes(boxes), Error);
}

}  // namespace
}  // namespace spikems
