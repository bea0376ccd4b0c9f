// Event precision and recall: the confusion counts, their sums per window length, and the
// runtime's labels through score_sequence on hand-made events.
#include <gtest/gtest.h>

#include "common/tiny_models.h"
#include "core/eval/baseline_scorer.h"
#include "core/eval/results.h"
#include "core/eval/sequence_scorer.h"
#include "core/eval/window_scorer.h"
#include "core/util/error.h"

namespace spikems {
namespace {

TEST(EventCounts, PrecisionAndRecall) {
  EventCounts c;
  EXPECT_FALSE(c.has_precision());
  EXPECT_FALSE(c.has_recall());
  c.add(true, true);    // tp
  c.add(true, true);    // tp
  c.add(true, false);   // fn
  c.add(false, true);   // fp
  c.add(false, false);  // tn
  EXPECT_EQ(c.tp, 2u);
  EXPECT_EQ(c.fn, 1u);
  EXPECT_EQ(c.fp, 1u);
  EXPECT_EQ(c.tn, 1u);
  EXPECT_DOUBLE_EQ(c.precision(), 2.0 / 3);
  EXPECT_DOUBLE_EQ(c.recall(), 2.0 / 3);
  EventCounts none;
  none.add(false, false);
  EXPECT_FALSE(none.has_precision());  // nothing predicted, nothing moving: undefined
  EXPECT_FALSE(none.has_recall());
}

TEST(EventTally, SumsTheWholeWindowsOfEachLength) {
  EventTally t(0, 1000);      // frames of 1 ms
  t.add(100, true, true);     // frame 0: tp
  t.add(1500, true, false);   // frame 1: fn
  t.add(2500, false, true);   // frame 2: fp
  t.add(3999, false, false);  // frame 3: tn
  t.add(4100, true, true);    // frame 4: tp
  // Data ends at 6 ms: 3 whole 2 ms windows (frames 0-5), 1 whole 4 ms window (frames 0-3).
  auto c = t.per_length({2000, 4000}, 6000);
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(c[0].tp, 2u);
  EXPECT_EQ(c[0].total(), 5u);
  EXPECT_EQ(c[1].tp, 1u);
  EXPECT_EQ(c[1].fn, 1u);
  EXPECT_EQ(c[1].fp, 1u);
  EXPECT_EQ(c[1].tn, 1u);
  // Ending at 4.5 ms: the 2 ms windows' third one is partial and dropped.
  EXPECT_EQ(t.per_length({2000}, 4500)[0].total(), 4u);
  EXPECT_THROW(t.add(-1, true, true), Error);
}

// A 4x2 sensor, events 3 ms apart at distinct pixels (no refractory interplay): events at
// 0 .. 12 ms in the whole windows, one at 20 ms in the partial last one (data ends at 20.001).
LabelledSequence hand_sequence() {
  LabelledSequence s;
  s.name = "hand";
  s.events.sensor = SensorSize{4, 2};
  s.events.push_back(0, 0, 0, 1, 1);      // ON, moving
  s.events.push_back(3000, 1, 0, 0, 1);   // OFF, moving
  s.events.push_back(6000, 2, 1, 1, 0);   // ON, background
  s.events.push_back(9000, 3, 1, 0, 0);   // OFF, background
  s.events.push_back(12000, 0, 1, 1, 1);  // ON, moving
  s.events.push_back(20000, 1, 1, 1, 1);  // ON, moving: in the partial window, not counted
  return s;
}

TEST(SequenceScorer, EventPrecisionAndRecallFromTheRuntimesLabels) {
  // Only the ON channel passes (weight [out 1][in 1] = 1): the runtime labels the ON events
  // moving. Counted: tp = events 0 and 4, fn = 1, fp = 2, tn = 3.
  const ModelSpec on_only = test::pointwise_model({0.f, 0.f, 0.f, 1.f}, "on-only");
  const SequenceScore s = score_sequence(on_only, hand_sequence(), {5000, 20000});
  ASSERT_EQ(s.events_pr.size(), 2u);
  for (const EventCounts& c : s.events_pr) {
    EXPECT_EQ(c.tp, 2u);
    EXPECT_EQ(c.fn, 1u);
    EXPECT_EQ(c.fp, 1u);
    EXPECT_EQ(c.tn, 1u);
  }
  // Nothing passes: no event predicted moving, recall 0, precision undefined.
  const SequenceScore none =
      score_sequence(test::pointwise_model({0.f, 0.f, 0.f, 0.f}), hand_sequence(), {5000});
  EXPECT_EQ(none.events_pr[0].tp, 0u);
  EXPECT_EQ(none.events_pr[0].fn, 3u);
  EXPECT_FALSE(none.events_pr[0].has_precision());
  // The all-events baseline predicts every event moving: recall 1, precision 3 of 5.
  const SequenceScore all = score_all_events(hand_sequence(), {5000});
  EXPECT_EQ(all.events_pr[0].tp, 3u);
  EXPECT_EQ(all.events_pr[0].fp, 2u);
  EXPECT_DOUBLE_EQ(all.events_pr[0].recall(), 1.0);

  // Pooled per dataset and written: percent in JSON, counts beside.
  DatasetResult d = dataset_result("hand", "", {s, s});
  EXPECT_EQ(d.windows[0].events.tp, 4u);
  EvalResults r;
  r.windows_us = {5000, 20000};
  ModelResult m;
  m.path = "on.safetensors";
  m.datasets = {d};
  r.models = {m};
  const auto j = nlohmann::json::parse(results_json(r).dump());
  const auto& row = j["models"][0]["datasets"][0]["windows"][0];
  EXPECT_DOUBLE_EQ(row["event_precision"].get<double>(), 100.0 * 2 / 3);
  EXPECT_DOUBLE_EQ(row["event_recall"].get<double>(), 100.0 * 2 / 3);
  EXPECT_EQ(row["event_counts"]["fn"], 2);
  EXPECT_TRUE(row["filter"].is_null());
  // 6 of the 10 events labelled moving (tp + fp).
  EXPECT_DOUBLE_EQ(row["moving_share"].get<double>(), 60.0);
  const std::string csv = results_csv(r);
  EXPECT_NE(csv.find(",66.6667,66.6667,4,2,2,2,60.0000,1,0,0\n"), std::string::npos) << csv;
}

}  // namespace
}  // namespace spikems
