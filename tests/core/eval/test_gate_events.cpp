// Event gating (`spikems eval --gate-events`): P becomes P ∩ E, E = the pixels with any input
// event in the window. A hand-made case where the prediction spills onto pixels without
// events, scored with and without the gate.
#include <gtest/gtest.h>

#include "core/eval/window_scorer.h"
#include "core/util/error.h"

namespace spikems {
namespace {

TEST(GateEvents, PredictionsWhereNoEventFellStopCounting) {
  EventStream e;
  e.sensor = SensorSize{4, 1};    // pixels 0..3
  e.push_back(0, 0, 0, 1, 1);     // window 0: moving event at px 0
  e.push_back(500, 1, 0, 1, 0);   //           background event at px 1
  e.push_back(2000, 3, 0, 1, 0);  // window 1 starts (so window 0 is complete)
  PredictionFrame f;
  f.width = 4;
  f.height = 1;
  f.t0_us = 0;
  f.t1_us = 2000;
  f.foreground = {1, 0, 1, 1};  // px 0 right, px 2 and 3 spill where no event fell
  for (bool gate : {false, true}) {
    WindowScorer s(e.sensor, {2000});
    s.gate_by_events(gate);
    s.add_events(e);
    s.add_frame(f);
    s.finish(2000);
    ASSERT_EQ(s.scores()[0].windows(), 1u);
    // Ungated: P = {0, 2, 3}, G = {0}: IoU 1/3, no detection (2 false pixels > 1 right).
    // Gated: P = {0} (E = {0, 1}): IoU 1, a detection.
    EXPECT_NEAR(s.scores()[0].mean_iou(), gate ? 1.0 : 1.0 / 3, 1e-12);
    EXPECT_NEAR(s.scores()[0].detection_rate(), gate ? 1.0 : 0.0, 1e-12);
  }
  WindowScorer late(e.sensor, {2000});
  late.add_events(e);
  EXPECT_THROW(late.gate_by_events(true), Error);  // after the first events: refused
}

}  // namespace
}  // namespace spikems
