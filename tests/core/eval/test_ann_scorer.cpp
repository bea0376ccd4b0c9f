// Scoring an ANN-2D model: P = the window's event pixels where the logit is positive. With
// zero weights the logit is the last bias everywhere, so a positive bias must score exactly as
// the all-events baseline and a negative one as an empty prediction; and a window's prediction
// depends on its own events only.
#include <gtest/gtest.h>

#include "core/eval/ann_scorer.h"
#include "core/eval/baseline_scorer.h"
#include "core/util/error.h"

namespace spikems {
namespace {

EventStream hand_events() {
  EventStream e;
  e.sensor = SensorSize{12, 9};
  e.push_back(0, 0, 0, 1, 1);
  e.push_back(300, 1, 0, 0, 1);
  e.push_back(900, 2, 0, 1, 0);
  e.push_back(2100, 5, 4, 1, 1);
  e.push_back(2500, 6, 4, 0, 0);
  e.push_back(2600, 7, 8, 0, 0);
  e.push_back(3000, 7, 8, 1, 0);
  e.push_back(4100, 11, 1, 1, 0);
  e.push_back(6000, 3, 0, 1, 1);
  return e;
}

ModelSpec constant_logit(float bias) {
  ModelSpec m = ann2d_architecture();
  m.layers.back().bias[0] = bias;
  return m;
}

TEST(AnnScorer, ConstantLogitsGiveTheBaselineOrNothing) {
  LabelledSequence s{"hand", hand_events()};
  const std::vector<int64_t> windows = {2000, 4000};
  const SequenceScore base = score_all_events(s, windows);
  const SequenceScore yes = score_ann_sequence(constant_logit(1.f), s, windows);
  const SequenceScore no = score_ann_sequence(constant_logit(-1.f), s, windows);
  ASSERT_TRUE(yes.complete);
  EXPECT_EQ(yes.events, base.events);
  EXPECT_EQ(yes.span_us, base.span_us);
  for (size_t i = 0; i < windows.size(); ++i) {
    EXPECT_EQ(yes.scores[i].windows(), base.scores[i].windows());
    EXPECT_EQ(yes.scores[i].skipped(), base.scores[i].skipped());
    EXPECT_NEAR(yes.scores[i].mean_iou(), base.scores[i].mean_iou(), 1e-12);
    EXPECT_NEAR(yes.scores[i].detection_rate(), base.scores[i].detection_rate(), 1e-12);
    EXPECT_EQ(no.scores[i].windows(), base.scores[i].windows());
    EXPECT_EQ(no.scores[i].mean_iou(), 0.0);
  }
  EXPECT_NEAR(yes.scores[0].mean_iou(), (2.0 / 3 + 1.0 / 3) / 2, 1e-12);
}

TEST(AnnScorer, ThreadsGiveTheSameScoresAsOne) {
  // Random weights and events: windows scored on 3 threads, in chunks, equal one thread's.
  ModelSpec m = ann2d_architecture();
  uint64_t r = 12345;
  auto next = [&] {
    r = r * 6364136223846793005ULL + 1442695040888963407ULL;
    return float(int64_t(r >> 33) % 2001 - 1000) / 1000.f;
  };
  for (auto& l : m.layers) {
    for (float& w : l.weight) w = 0.6f * next();
    for (float& b : l.bias) b = 0.1f * next();
  }
  EventStream e;
  e.sensor = SensorSize{12, 9};
  for (int i = 0; i < 3000; ++i)
    e.push_back(i * 10, uint16_t((next() + 1) * 5.9f), uint16_t((next() + 1) * 4.4f),
                uint8_t(next() > 0), uint16_t(next() > 0.3f));
  LabelledSequence s{"random", e};
  const std::vector<int64_t> windows = {1000, 3000};
  SequenceScoreOptions one, three;
  three.threads = 3;
  const SequenceScore a = score_ann_sequence(m, s, windows, one);
  const SequenceScore b = score_ann_sequence(m, s, windows, three);
  for (size_t i = 0; i < windows.size(); ++i) {
    EXPECT_GT(a.scores[i].windows(), 5);
    EXPECT_EQ(a.scores[i].windows(), b.scores[i].windows());
    EXPECT_EQ(a.scores[i].mean_iou(), b.scores[i].mean_iou());
    EXPECT_EQ(a.scores[i].detection_rate(), b.scores[i].detection_rate());
    EXPECT_EQ(a.events_pr[i].precision(), b.events_pr[i].precision());
  }
  EXPECT_GT(a.scores[0].mean_iou(), 0.0);  // the case predicts something
  EXPECT_LT(a.scores[0].mean_iou(), 1.0);
}

// A model that reads only its past frame (history 1): on a 2 x 2 sensor one level sees every
// pixel, and the logit is 10 x (the previous window's event count feature) - 1 everywhere, so
// a window is called moving exactly where its events fell when the window before it had
// events. Windows of 1 ms start at the first event (t = 100 us); the one at 2100 us is empty.
TEST(AnnScorer, HistoryReadsTheWindowsBeforeNotAfter) {
  EventStream e;
  e.sensor = SensorSize{2, 2};
  e.push_back(100, 0, 0, 1, 1);   // window 0: nothing before it
  e.push_back(1100, 1, 1, 1, 1);  // window 1: window 0 had an event
  e.push_back(3100, 0, 1, 0, 1);  // window 3: window 2 was empty
  e.push_back(4100, 1, 0, 1, 1);  // window 4: window 3 had an event
  e.push_back(5200, 1, 1, 0, 0);  // unlabelled, so the span covers window 4 whole
  LabelledSequence s{"past", e};
  auto model = [](int history, int channel) {
    ModelSpec m = ann2d_architecture({1}, false, {}, history);
    for (int k = 0; k < 9; ++k) {
      m.layers[0].weight[size_t(channel * 9 + k)] = 1.f;  // count channel (OFF + ON)
      m.layers[0].weight[size_t((channel + 1) * 9 + k)] = 1.f;
      m.layers[1].weight[size_t(k)] = 10.f;
    }
    m.layers[1].bias[0] = -1.f;
    return m;
  };
  const SequenceScore past = score_ann_sequence(model(1, 4), s, {1000});
  ASSERT_EQ(past.scores[0].windows(), 4u);
  EXPECT_NEAR(past.scores[0].mean_iou(), 0.5, 1e-12);  // windows 1 and 4: 1; 0 and 3: 0
  EXPECT_NEAR(past.scores[0].detection_rate(), 0.5, 1e-12);
  // The same reading the window's own frame (channels 0, 1): every window right.
  const SequenceScore own = score_ann_sequence(model(1, 0), s, {1000});
  EXPECT_NEAR(own.scores[0].mean_iou(), 1.0, 1e-12);
}

TEST(AnnScorer, BadInput) {
  LabelledSequence s{"hand", hand_events()};
  EXPECT_THROW(score_ann_sequence(constant_logit(1.f), s, {1500}), Error);  // not whole steps
  EXPECT_THROW(score_ann_sequence(spikems_architecture(true), s, {2000}), Error);  // an SNN
  LabelledSequence unlabelled{"u", hand_events()};
  unlabelled.events.label.clear();
  EXPECT_THROW(score_ann_sequence(constant_logit(1.f), unlabelled, {2000}), Error);
}

}  // namespace
}  // namespace spikems
