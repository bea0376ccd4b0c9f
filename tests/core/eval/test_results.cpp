// Pooling per dataset and the three result files' content.
#include <gtest/gtest.h>

#include <cmath>

#include "core/eval/results.h"

namespace spikems {
namespace {

SequenceScore sequence(const std::string& name, std::vector<MaskCounts> w20,
                       std::vector<MaskCounts> w100) {
  SequenceScore s;
  s.name = name;
  s.events = 1000;
  s.span_us = 200000;
  s.windows_us = {20000, 100000};
  s.scores.resize(2);
  for (const auto& c : w20) s.scores[0].add(c);
  for (const auto& c : w100) s.scores[1].add(c);
  return s;
}

TEST(EvalResults, DatasetRowsPoolEveryWindowOfEverySequence) {
  // Sequence a, 20 ms: IoU 1 (detection), 0.5 (3 of 6 with |P\G| = 2: 2*3 > 4, 3 > 2 ->
  // detection), one skipped. Sequence b, 20 ms: IoU 0 (no detection).
  // Pooled: IoUs {1, 0.5, 0}: mean 50 %, std sqrt(((0.5)^2 + 0 + (0.5)^2) / 3) = 40.82 %,
  // detections 2 of 3 = 66.67 %, 3 windows, 1 skipped, 2 sequences.
  // 100 ms: a has none scored (1 skipped), b none at all: the row has 0 windows.
  auto a = sequence("a.h5", {{4, 4, 4}, {3, 5, 4}, {0, 3, 0}}, {{0, 2, 0}});
  auto b = sequence("b.h5", {{0, 2, 3}}, {});
  DatasetResult d = dataset_result("data/x", "test", {a, b});
  ASSERT_EQ(d.windows.size(), 2u);
  const WindowSummary& w = d.windows[0];
  EXPECT_EQ(w.window_us, 20000);
  EXPECT_EQ(w.windows, 3u);
  EXPECT_EQ(w.skipped, 1u);
  EXPECT_EQ(w.sequences, 2u);
  EXPECT_NEAR(w.iou_mean, 50.0, 1e-9);
  EXPECT_NEAR(w.iou_std, 100 * std::sqrt(0.5 / 3), 1e-9);
  EXPECT_NEAR(w.detection_rate, 200.0 / 3, 1e-9);
  EXPECT_EQ(d.windows[1].windows, 0u);
  EXPECT_EQ(d.windows[1].skipped, 1u);
  ASSERT_EQ(d.sequences.size(), 2u);
  EXPECT_NEAR(d.sequences[0].windows[0].iou_mean, 75.0, 1e-9);
  EXPECT_EQ(d.events, 2000u);
  EXPECT_DOUBLE_EQ(d.sequences[1].duration_s, 0.2);

  EvalResults r;
  r.command_line = "spikems eval --model m.safetensors --data data/x";
  r.date = "2024-01-01T00:00:00Z";
  r.windows_us = {20000, 100000};
  ModelResult m;
  m.path = "models/m.safetensors";
  m.name = "spikems";
  m.datasets = {d};
  r.models = {m};

  const auto j = nlohmann::json::parse(results_json(r).dump());
  EXPECT_EQ(j["format"], "spikems-eval-results");
  EXPECT_EQ(j["version"], 1);
  EXPECT_EQ(j["command"], r.command_line);
  EXPECT_EQ(j["windows_ms"], nlohmann::json({20.0, 100.0}));
  const auto& jd = j["models"][0]["datasets"][0];
  EXPECT_EQ(j["models"][0]["model"], "models/m.safetensors");
  EXPECT_EQ(jd["split"], "test");
  EXPECT_EQ(jd["sequences"], 2);
  EXPECT_DOUBLE_EQ(jd["windows"][0]["iou_mean"].get<double>(), 50.0);
  EXPECT_EQ(jd["windows"][0]["skipped_windows"], 1);
  EXPECT_TRUE(jd["windows"][1]["iou_mean"].is_null());  // nothing scored: no number
  EXPECT_EQ(jd["per_sequence"][1]["sequence"], "b.h5");

  // CSV: a header, 2 dataset rows, 2 x 2 sequence rows; empty cells where nothing was scored.
  const std::string csv = results_csv(r);
  EXPECT_EQ(csv.rfind("level,model,data,split,sequence,window_ms,iou_mean,", 0), 0u);
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 7);
  EXPECT_NE(csv.find("dataset,models/m.safetensors,data/"
                     "x,test,,20,50.0000,40.8248,66.6667,3,1,2,,,,,,,,,1,0,0\n"),
            std::string::npos)
      << csv;
  EXPECT_NE(csv.find("dataset,models/m.safetensors,data/x,test,,100,,,,0,1,2,,,,,,,,,1,0,0\n"),
            std::string::npos)
      << csv;
  EXPECT_NE(csv.find("sequence,models/m.safetensors,data/x,test,a.h5,20,75.0000"),
            std::string::npos)
      << csv;

  const std::string md = results_markdown(r);
  EXPECT_NE(md.find("| m.safetensors | data/x | test  | 20    | 50.0 ± 40.8"), std::string::npos)
      << md;
  EXPECT_NE(md.find("## Per sequence"), std::string::npos);
}

}  // namespace
}  // namespace spikems
