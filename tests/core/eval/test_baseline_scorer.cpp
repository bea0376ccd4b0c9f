// The "every event moving" baseline: P = pixels with any event in the window, scored by the
// same WindowScorer as the models; hand-made sequences with known answers, and `evaluate`
// running it beside a model on the same windows.
#include <gtest/gtest.h>

#include "core/eval/baseline_scorer.h"
#include "core/util/error.h"

namespace spikems {
namespace {

// A 4x2 sensor (pixel = y*4 + x); windows of 2 ms from the first event.
EventStream two_windows() {
  EventStream e;
  e.sensor = SensorSize{4, 2};
  e.push_back(0, 0, 0, 1, 1);     // window 0: moving px 0
  e.push_back(300, 1, 0, 0, 1);   //           moving px 1
  e.push_back(900, 2, 0, 1, 0);   //           background px 2 -> IoU 2/3
  e.push_back(2100, 0, 1, 1, 1);  // window 1: moving px 4
  e.push_back(2500, 1, 1, 0, 0);  //           background px 5
  e.push_back(2600, 2, 1, 0, 0);  //           background px 6
  e.push_back(3000, 2, 1, 1, 0);  //           px 6 again -> IoU 1/3
  e.push_back(4100, 3, 1, 1, 0);  // window 2: background only (skipped)
  e.push_back(6000, 3, 0, 1, 1);  // window 3 is partial (data ends at 6001): dropped
  return e;
}

TEST(BaselineScorer, AllEventsIsTheEventFootprint) {
  LabelledSequence s{"hand", two_windows()};
  SequenceScore r = score_all_events(s, {2000, 4000});
  ASSERT_TRUE(r.complete);
  EXPECT_EQ(r.events, 9u);
  EXPECT_EQ(r.span_us, 6001);
  // 2 ms: windows 0 and 1 scored, window 2 has no moving event (skipped), window 3 partial.
  EXPECT_EQ(r.scores[0].windows(), 2u);
  EXPECT_EQ(r.scores[0].skipped(), 1u);
  EXPECT_NEAR(r.scores[0].mean_iou(), (2.0 / 3 + 1.0 / 3) / 2, 1e-12);
  // Detection (0-MMS): window 0 (2 of 2 found, 1 false) yes; window 1 (1 found, 2 false) no.
  EXPECT_NEAR(r.scores[0].detection_rate(), 0.5, 1e-12);
  // 4 ms: one window [0, 4000): G = {0, 1, 4}, P = {0, 1, 2, 4, 5, 6} -> 3/6.
  EXPECT_EQ(r.scores[1].windows(), 1u);
  EXPECT_NEAR(r.scores[1].mean_iou(), 0.5, 1e-12);
}

TEST(BaselineScorer, CutAndBadInput) {
  LabelledSequence s{"hand", two_windows()};
  SequenceScoreOptions o;
  o.max_us = 2000;  // only window 0
  SequenceScore r = score_all_events(s, {2000}, o);
  EXPECT_EQ(r.scores[0].windows(), 1u);
  EXPECT_NEAR(r.scores[0].mean_iou(), 2.0 / 3, 1e-12);
  EXPECT_THROW(score_all_events(s, {0}), Error);
  LabelledSequence unlabelled{"u", two_windows()};
  unlabelled.events.label.clear();
  EXPECT_THROW(score_all_events(unlabelled, {2000}), Error);
}

}  // namespace
}  // namespace spikems
