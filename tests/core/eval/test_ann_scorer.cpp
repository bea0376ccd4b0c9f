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
