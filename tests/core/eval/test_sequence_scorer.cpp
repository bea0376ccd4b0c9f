// Window scoring: hand-made prediction frames with known answers, causality through the real
// Segmenter, and several window lengths from one run against one run per length.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "common/tiny_models.h"
#include "core/eval/sequence_scorer.h"
#include "core/eval/window_scorer.h"
#include "core/events/event_ops.h"
#include "core/runtime/segmenter.h"
#include "core/util/error.h"

namespace spikems {
namespace {

// A 4x2 sensor: pixel index = y*4 + x.
PredictionFrame frame(int64_t t0, int64_t len, std::initializer_list<int> pixels) {
  PredictionFrame f;
  f.t0_us = t0;
  f.t1_us = t0 + len;
  f.index = int(t0 / len);
  f.width = 4;
  f.height = 2;
  f.foreground.assign(8, 0);
  f.events.assign(8, 0);
  for (int p : pixels) f.foreground[size_t(p)] = 1;
  return f;
}

EventStream hand_events() {
  EventStream e;
  e.sensor = SensorSize{4, 2};
  e.push_back(0, 0, 0, 1, 1);     // px 0, moving: the origin
  e.push_back(500, 2, 0, 0, 1);   // px 2, moving
  e.push_back(2100, 0, 1, 1, 1);  // px 4, moving
  e.push_back(2200, 1, 1, 0, 1);  // px 5, moving
  e.push_back(3000, 3, 1, 1, 0);  // px 7, background
  e.push_back(4500, 3, 0, 1, 0);  // px 3, background
  e.push_back(6500, 1, 0, 0, 2);  // px 1, another moving object (any id != 0 counts)
  e.push_back(8200, 2, 0, 1, 1);  // px 2, moving (in the partial last window)
  e.push_back(8500, 0, 0, 1, 0);  // px 0, background: the last event, data ends at 8501
  return e;
}

// Frames of 2 ms (the gcd of 2 and 4 ms).
std::vector<PredictionFrame> hand_frames(bool with_empty_frame = true) {
  std::vector<PredictionFrame> f = {frame(0, 2000, {0, 1}), frame(2000, 2000, {4, 5, 6})};
  if (with_empty_frame) f.push_back(frame(4000, 2000, {}));
  f.push_back(frame(6000, 2000, {1}));
  f.push_back(frame(8000, 2000, {2}));
  return f;
}

TEST(WindowScorer, HandMadeFramesGiveKnownScores) {
  for (bool with_empty : {true, false}) {  // a frame left out is an empty prediction
    auto s = score_frames(hand_frames(with_empty), hand_events(), {2000, 4000}, 8501);
    ASSERT_EQ(s.size(), 2u);
    // 2 ms: windows [0,2) [2,4) [4,6) [6,8) ms; [8,10) is partial (data ends at 8.501 ms).
    //   w0: P {0,1}, G {0,2}: I 1, U 3 -> 1/3; 2*1 > |G| = 2 fails -> no detection.
    //   w1: P {4,5,6}, G {4,5} (px 7 is background): I 2, U 3 -> 2/3; 4 > 2 and 2 > |P\G| = 1
    //       -> detection.
    //   w2: G empty (px 3 is background) -> skipped.
    //   w3: P {1}, G {1}: IoU 1, detection.
    // Mean (1/3 + 2/3 + 1) / 3 = 2/3; deviations -1/3, 0, 1/3 -> std sqrt(2/27).
    EXPECT_EQ(s[0].windows(), 3u);
    EXPECT_EQ(s[0].skipped(), 1u);
    EXPECT_NEAR(s[0].mean_iou(), 2.0 / 3, 1e-12);
    EXPECT_NEAR(s[0].std_iou(), std::sqrt(2.0 / 27), 1e-12);
    EXPECT_NEAR(s[0].detection_rate(), 2.0 / 3, 1e-12);
    // 4 ms: [0,4) P {0,1,4,5,6}, G {0,2,4,5}: I {0,4,5} = 3, U {0,1,2,4,5,6} = 6 -> 0.5;
    //   2*3 > 4 and 3 > |P\G| = |{1,6}| = 2 -> detection. [4,8): P {1}, G {1} -> 1, detection.
    //   [8,12) partial -> dropped.
    EXPECT_EQ(s[1].windows(), 2u);
    EXPECT_EQ(s[1].skipped(), 0u);
    EXPECT_NEAR(s[1].mean_iou(), 0.75, 1e-12);
    EXPECT_NEAR(s[1].std_iou(), 0.25, 1e-12);
    EXPECT_NEAR(s[1].detection_rate(), 1.0, 1e-12);
  }
  // Keeping the partial last window: 2 ms [8,10): P {2}, G {2} -> IoU 1, four windows, mean
  // (1/3 + 2/3 + 1 + 1) / 4 = 0.75. 4 ms [8,12): P {2} (frame [10,12) never came: empty),
  // G {2} -> 1; mean (0.5 + 1 + 1) / 3 = 5/6.
  auto k = score_frames(hand_frames(), hand_events(), {4000, 2000}, 8501, true);
  EXPECT_EQ(k[0].windows(), 3u);  // 4 ms first: results follow the order given
  EXPECT_NEAR(k[0].mean_iou(), 5.0 / 6, 1e-12);
  EXPECT_EQ(k[1].windows(), 4u);
  EXPECT_NEAR(k[1].mean_iou(), 0.75, 1e-12);
  EXPECT_NEAR(k[1].detection_rate(), 0.75, 1e-12);
}

TEST(WindowScorer, StreamingInChunksGivesTheSameScores) {
  // Events chunk by chunk, each chunk's frames after it (as sequence_scorer feeds them).
  const EventStream all = hand_events();
  WindowScorer w(all.sensor, {2000, 4000});
  EXPECT_EQ(w.frame_us(), 2000);
  const auto frames = hand_frames();
  size_t next = 0;
  for (size_t i = 0; i < all.size(); ++i) {
    w.add_events(all.slice_index(i, i + 1));
    while (next < frames.size() && frames[next].t1_us <= all.t[i]) w.add_frame(frames[next++]);
  }
  while (next < frames.size()) w.add_frame(frames[next++]);
  w.finish(8501);
  auto once = score_frames(frames, all, {2000, 4000}, 8501);
  for (size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(w.scores()[i].ious(), once[i].ious());
    EXPECT_EQ(w.scores()[i].skipped(), once[i].skipped());
    EXPECT_EQ(w.scores()[i].detection_rate(), once[i].detection_rate());
  }
}

TEST(WindowScorer, RejectsMisuse) {
  EventStream plain = hand_events();
  plain.label.clear();
  EXPECT_THROW(score_frames({}, plain, {2000}, 8501), Error);  // no labels
  EXPECT_THROW(score_frames({frame(500, 2000, {})}, hand_events(), {2000}, 8501), Error);
  EXPECT_THROW(score_frames({frame(0, 1000, {})}, hand_events(), {2000}, 8501), Error);
  EXPECT_THROW(score_frames({frame(0, 2000, {}), frame(0, 2000, {})}, hand_events(), {2000}, 8501),
               Error);
  PredictionFrame wrong = frame(0, 2000, {});
  wrong.foreground.resize(9);
  EXPECT_THROW(score_frames({wrong}, hand_events(), {2000}, 8501), Error);
  EXPECT_THROW(WindowScorer(SensorSize{4, 2}, {0}), Error);
  EXPECT_EQ(frame_length_us({20000, 100000, 30000}), 10000);
}

// A 1x1 convolution passing OFF events (input channel 0) to output channel 0 with weight 1;
// ON events meet a zero weight. With the sampled kernel eps[0] = 0 and eps[1] = 0.82 > theta,
// an OFF event in step s makes an output spike at step s + 1 (one step per layer).
ModelSpec pass_off_model() {
  return test::pointwise_model({1.f, 0.f, 0.f, 0.f});
}

LabelledSequence one_moving_event(int64_t t) {
  LabelledSequence s;
  s.name = "one event at " + std::to_string(t) + " us";
  s.events.sensor = SensorSize{8, 8};
  s.events.push_back(0, 0, 0, 1, 0);      // ON, background: fixes the origin, predicts nothing
  s.events.push_back(t, 3, 3, 0, 1);      // OFF at (3, 3), moving
  s.events.push_back(25000, 0, 0, 1, 0);  // the data goes on to 25 ms: windows 0, 1 complete
  return s;
}

TEST(SequenceScorer, ASpikeAfterTheWindowsEndDoesNotCount) {
  const ModelSpec m = pass_off_model();
  for (int block : {1, 16}) {
    SequenceScoreOptions o;
    o.block_steps = block;
    // The event in step 8 of window [0, 10) ms: its spike at step 9 starts at 9 ms, inside.
    // P = G = {(3,3)}: IoU 1, a detection; window [10, 20) has no moving event: skipped.
    auto in = score_sequence(m, one_moving_event(8500), {10000}, o);
    EXPECT_EQ(in.scores[0].windows(), 1u);
    EXPECT_EQ(in.scores[0].skipped(), 1u);
    EXPECT_DOUBLE_EQ(in.scores[0].mean_iou(), 1.0);
    EXPECT_DOUBLE_EQ(in.scores[0].detection_rate(), 1.0);
    // The event in step 9, the window's last: its spike at step 10 starts at 10 ms, one step
    // after the window's end. P is empty: IoU 0, no detection.
    auto late = score_sequence(m, one_moving_event(9500), {10000}, o);
    EXPECT_EQ(late.scores[0].windows(), 1u);
    EXPECT_EQ(late.scores[0].skipped(), 1u);
    EXPECT_DOUBLE_EQ(late.scores[0].mean_iou(), 0.0);
    EXPECT_DOUBLE_EQ(late.scores[0].detection_rate(), 0.0);
  }
  // The spike is there, one step late: 1 ms frames from the Segmenter show it in step 10.
  SegmenterOptions so;
  so.mask_window_us = 1000;
  const LabelledSequence seq = one_moving_event(9500);
  Segmenter seg(m, seq.events.sensor, so);
  seg.push(seq.events);
  seg.finish();
  const size_t px = 3 * 8 + 3;
  ASSERT_GT(seg.frames().size(), 10u);
  EXPECT_EQ(seg.frames()[9].t0_us, 9000);
  EXPECT_EQ(seg.frames()[9].foreground[px], 0);
  EXPECT_EQ(seg.frames()[10].foreground[px], 1);
}

// A 32x24 sensor: a 6x6 square moving 1 px per 2 ms (labelled moving, both polarities on its
// edges) over background noise (label 0), 300 ms.
LabelledSequence moving_square() {
  LabelledSequence s;
  s.name = "moving square";
  s.events.sensor = SensorSize{32, 24};
  std::mt19937 rng(7);
  for (int64_t t = 0; t < 300000; t += 250) {
    const int x0 = int(2 + (t / 2000) % 24), y0 = 9;
    for (int y = y0; y < y0 + 6; ++y) s.events.push_back(t, uint16_t(x0), uint16_t(y), 0, 1);
    for (int y = y0; y < y0 + 6; ++y)
      s.events.push_back(t + 50, uint16_t(x0 + 5), uint16_t(y), 1, 1);
    for (int k = 0; k < 3; ++k)
      s.events.push_back(t + 100 + k, uint16_t(rng() % 32), uint16_t(rng() % 24),
                         uint8_t(rng() % 2), 0);
  }
  return s;
}

// Two 3x3 convolutions (padding 1) with seeded random weights, mostly excitatory.
ModelSpec random_model() {
  return test::random_conv_model(3, -0.1f, 0.35f);
}

TEST(SequenceScorer, SeveralWindowLengthsFromOneRunEqualOneRunEach) {
  const ModelSpec m = random_model();
  const LabelledSequence seq = moving_square();
  const std::vector<int64_t> windows = {1000, 2000, 5000, 10000, 20000, 25000};
  SequenceScoreOptions o;
  auto all = score_sequence(m, seq, windows, o);
  ASSERT_EQ(all.scores.size(), windows.size());
  const int64_t span = seq.events.t_last() + 1 - seq.events.t_first();
  EXPECT_EQ(all.span_us, span);
  bool some_overlap = false;
  for (size_t i = 0; i < windows.size(); ++i) {
    auto one = score_sequence(m, seq, {windows[i]}, o);
    const WindowScores &a = all.scores[i], &b = one.scores[0];
    EXPECT_EQ(a.ious(), b.ious()) << windows[i] << " us";
    EXPECT_EQ(a.skipped(), b.skipped()) << windows[i] << " us";
    EXPECT_EQ(a.detection_rate(), b.detection_rate()) << windows[i] << " us";
    // Every complete window is counted, scored or skipped; the partial last one is not.
    EXPECT_EQ(int64_t(a.windows() + a.skipped()), span / windows[i]) << windows[i] << " us";
    some_overlap = some_overlap || a.mean_iou() > 0.05;
    EXPECT_LT(a.mean_iou(), 1.0);
  }
  EXPECT_TRUE(some_overlap) << "the test network predicts nothing: the comparison is vacuous";
  // A shorter cut ends exactly at first event + max_us.
  o.max_us = 100000;
  auto cut = score_sequence(m, seq, {20000, 25000}, o);
  EXPECT_EQ(cut.span_us, 100000);
  EXPECT_EQ(cut.scores[0].windows() + cut.scores[0].skipped(), 5u);
  EXPECT_EQ(cut.scores[1].windows() + cut.scores[1].skipped(), 4u);
  // Threads and blocks change nothing.
  o.max_us = 0;
  o.threads = 2;
  o.block_steps = 5;
  auto threaded = score_sequence(m, seq, windows, o);
  for (size_t i = 0; i < windows.size(); ++i)
    EXPECT_EQ(threaded.scores[i].ious(), all.scores[i].ious()) << windows[i] << " us";
}

// A downsampled network is scored on its grid: scoring the 32x24 square with the network at
// half resolution equals scoring the sequence converted to 16x12 (`convert --downsample 2`) at
// full, window for window and event for event; the factor comes from the model's training grid
// when not given (auto), and an explicit 1 overrides it.
TEST(SequenceScorer, DownsampledNetworkEqualsTheConvertedSequence) {
  ModelSpec m = random_model();
  const LabelledSequence seq = moving_square();
  LabelledSequence half = seq;
  BinningConfig geo;
  geo.downsample = 2;
  half.events = remap_events(seq.events, geo);
  ASSERT_EQ(half.events.sensor.width, 16);
  const std::vector<int64_t> windows = {2000, 10000};
  SequenceScoreOptions o;
  const SequenceScore converted = score_sequence(m, half, windows, o);
  o.downsample = 2;
  const SequenceScore ds = score_sequence(m, seq, windows, o);
  m.train_width = 16;
  m.train_height = 12;
  o.downsample = 0;  // auto: 32x24 comes nearest 16x12 at 2
  const SequenceScore autods = score_sequence(m, seq, windows, o);
  o.downsample = 1;
  const SequenceScore full = score_sequence(m, seq, windows, o);
  bool differs = false;
  for (size_t i = 0; i < windows.size(); ++i) {
    EXPECT_EQ(ds.scores[i].ious(), converted.scores[i].ious()) << windows[i];
    EXPECT_EQ(ds.scores[i].skipped(), converted.scores[i].skipped()) << windows[i];
    EXPECT_EQ(ds.scores[i].detection_rate(), converted.scores[i].detection_rate()) << windows[i];
    EXPECT_EQ(autods.scores[i].ious(), ds.scores[i].ious()) << windows[i];
    EXPECT_GT(ds.scores[i].windows(), 10u);
    differs = differs || full.scores[i].ious() != ds.scores[i].ious();
  }
  ASSERT_EQ(ds.events_pr.size(), converted.events_pr.size());
  for (size_t i = 0; i < ds.events_pr.size(); ++i) {
    EXPECT_EQ(ds.events_pr[i].tp, converted.events_pr[i].tp);
    EXPECT_EQ(ds.events_pr[i].fp, converted.events_pr[i].fp);
    EXPECT_EQ(ds.events_pr[i].fn, converted.events_pr[i].fn);
  }
  EXPECT_TRUE(differs) << "full and half resolution score alike: the comparison is vacuous";
}

TEST(SequenceScorer, WindowsMustBeWholeStepsAndDataLabelled) {
  EXPECT_NO_THROW(check_windows({1000, 20000}, 1000, "m"));
  EXPECT_THROW(check_windows({1500}, 1000, "m"), Error);
  EXPECT_THROW(check_windows({0}, 1000, "m"), Error);
  EXPECT_THROW(check_windows({}, 1000, "m"), Error);
  try {
    check_windows({20000, 2500}, 1000, "model.safetensors");
    FAIL();
  } catch (const Error& e) {
    const std::string w = e.what();
    EXPECT_NE(w.find("model.safetensors"), std::string::npos) << w;
    EXPECT_NE(w.find("2.5 ms"), std::string::npos) << w;
  }
  LabelledSequence plain = one_moving_event(8500);
  plain.events.label.clear();
  EXPECT_THROW(score_sequence(pass_off_model(), plain, {10000}), Error);
}

}  // namespace
}  // namespace spikems
