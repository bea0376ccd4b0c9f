// `spikems eval` as a user runs it: on a tiny simulated dataset with a hand-built model, the
// result files and their schema; each kind of bad input stops with exit 1 and a clear message.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "common/test_paths.h"
#include "common/tiny_models.h"
#include "core/dataset/sequence.h"
#include "core/eval/evaluation.h"
#include "core/model/model_file.h"
#include "core/model/time_step.h"

namespace spikems {
namespace {

namespace fs = std::filesystem;
using test::run_command;
using test::spikems_binary;

std::string slurp(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

// One tiny dataset (3 sequences of 0.2 s, 64x48: one each in train, val, test) and a model
// for the whole test program.
class EvalCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = (fs::temp_directory_path() / ("spikems_test_EvalCli_" + std::to_string(::getpid())))
               .string();
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    test::scratch_registry.dirs.push_back(dir_);
    std::string out;
    setup_rc_ = run_command(spikems_binary() +
                                " simulate --preset tiny --sequences 3 --duration 0.2s --out " +
                                dir_ + "/tiny --no-progress",
                            &out);
    setup_out_ = out;
    // A 1x1 convolution passing both polarities to the output: every pixel with events is
    // predicted (one step later), so the moving object's pixels are found among the rest.
    save_model(dir_ + "/pass_all.safetensors",
               test::pointwise_model({1.f, 0.f, 0.f, 1.f}, "pass-all"));
  }
  void SetUp() override { ASSERT_EQ(setup_rc_, 0) << setup_out_; }
  static std::string data() { return dir_ + "/tiny"; }
  static std::string model() { return dir_ + "/pass_all.safetensors"; }
  static std::string eval(const std::string& args) {
    return spikems_binary() + " eval --quiet --model " + model() + " " + args;
  }
  static inline std::string dir_, setup_out_;
  static inline int setup_rc_ = -1;
};

// (last - first + 1 us) / window: the complete windows of a sequence, scored or skipped.
int64_t complete_windows(const std::string& file, int64_t window_us, int64_t max_us = 0) {
  const LabelledSequence s = load_sequence(file);
  int64_t span = s.events.t_last() + 1 - s.events.t_first();
  if (max_us > 0 && s.events.t_last() >= s.events.t_first() + max_us) span = max_us;
  return span / window_us;
}

TEST_F(EvalCli, WritesResultsWithEveryWindowLength) {
  const std::string o = dir_ + "/out_all";
  std::string out;
  ASSERT_EQ(
      run_command(eval("--data " + data() + " --split all --windows 20,100 --out " + o), &out), 0)
      << out;
  const auto j = nlohmann::json::parse(slurp(o + "/results.json"));
  for (const char* k : {"format", "version", "command", "date", "working_directory", "windows_ms",
                        "max_seconds", "interrupted", "protocol", "models"})
    EXPECT_TRUE(j.contains(k)) << k;
  EXPECT_EQ(j["format"], "spikems-eval-results");
  EXPECT_NE(j["command"].get<std::string>().find("--windows 20,100"), std::string::npos);
  EXPECT_EQ(j["windows_ms"], nlohmann::json({20.0, 100.0}));
  ASSERT_EQ(j["models"].size(), 1u);
  const auto& m = j["models"][0];
  EXPECT_EQ(m["model"], model());
  EXPECT_EQ(m["name"], "pass-all");
  EXPECT_EQ(m["time_step_ms"], 1.0);
  ASSERT_EQ(m["datasets"].size(), 1u);
  const auto& d = m["datasets"][0];
  EXPECT_EQ(d["data"], data());
  EXPECT_EQ(d["split"], "all");
  EXPECT_EQ(d["sequences"], 3);
  ASSERT_EQ(d["windows"].size(), 2u);
  ASSERT_EQ(d["per_sequence"].size(), 3u);
  const int64_t lengths[] = {20000, 100000};
  for (size_t i = 0; i < 2; ++i) {
    const auto& w = d["windows"][i];
    EXPECT_EQ(w["window_ms"], double(lengths[i]) / 1000);
    for (const char* k :
         {"iou_mean", "iou_std", "detection_rate", "windows", "skipped_windows", "sequences"})
      EXPECT_TRUE(w.contains(k)) << k;
    EXPECT_EQ(w["sequences"], 3);
    // Every complete window of every sequence is counted once; the partial last one is not.
    int64_t want = 0, got = 0;
    for (const auto& s : d["per_sequence"]) {
      const auto& sw = s["windows"][i];
      EXPECT_EQ(sw["window_ms"], w["window_ms"]);
      const int64_t n = complete_windows(s["sequence"], lengths[i]);
      EXPECT_EQ(sw["windows"].get<int64_t>() + sw["skipped_windows"].get<int64_t>(), n)
          << s["sequence"];
      want += n;
      got += sw["windows"].get<int64_t>();
    }
    EXPECT_EQ(w["windows"].get<int64_t>() + w["skipped_windows"].get<int64_t>(), want);
    EXPECT_EQ(w["windows"].get<int64_t>(), got);
    ASSERT_GT(got, 0);
    // Every event pixel is predicted: the moving object is found, with the background too.
    EXPECT_GT(w["iou_mean"].get<double>(), 1.0);
    EXPECT_LT(w["iou_mean"].get<double>(), 100.0);
    EXPECT_GE(w["detection_rate"].get<double>(), 0.0);
    EXPECT_LE(w["detection_rate"].get<double>(), 100.0);
  }
  // CSV: header, 2 dataset rows and 3 x 2 sequence rows.
  const std::string csv = slurp(o + "/results.csv");
  EXPECT_EQ(csv.rfind("level,model,data,split,sequence,window_ms,", 0), 0u);
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 9);
  const std::string md = slurp(o + "/results.md");
  EXPECT_NE(md.find("| model "), std::string::npos) << md;
  EXPECT_NE(md.find("## Per sequence"), std::string::npos) << md;
  // The table on stdout too.
  EXPECT_NE(out.find("IoU % (mean ± std)"), std::string::npos) << out;
  EXPECT_NE(out.find("| pass_all.safetensors |"), std::string::npos) << out;
}

TEST_F(EvalCli, RangesCutsAndSeveralSources) {
  const std::string o = dir_ + "/out_range";
  const std::string file = data() + "/seq_0000.h5";
  std::string out;
  ASSERT_EQ(run_command(eval("--data " + data() + " --data " + file +
                             " --windows 1:5 --max-seconds 0.05 --threads 2 --out " + o),
                        &out),
            0)
      << out;
  const auto j = nlohmann::json::parse(slurp(o + "/results.json"));
  EXPECT_EQ(j["max_seconds"], 0.05);
  const auto& ds = j["models"][0]["datasets"];
  ASSERT_EQ(ds.size(), 2u);
  EXPECT_EQ(ds[0]["split"], "test");  // the default split
  EXPECT_EQ(ds[0]["sequences"], 1);
  EXPECT_TRUE(ds[1]["split"].is_null());  // a single recording has no splits
  EXPECT_EQ(ds[1]["per_sequence"][0]["sequence"], file);
  for (const auto& d : ds) {
    ASSERT_EQ(d["windows"].size(), 5u);
    for (int k = 1; k <= 5; ++k) {
      const auto& w = d["windows"][k - 1];
      EXPECT_EQ(w["window_ms"], double(k));
      // 50 ms of each 200 ms sequence: 50, 25, 16, 12, 10 complete windows.
      EXPECT_EQ(w["windows"].get<int64_t>() + w["skipped_windows"].get<int64_t>(), 50 / k);
    }
    EXPECT_DOUBLE_EQ(d["per_sequence"][0]["duration_s"].get<double>(), 0.05);
  }
  EXPECT_EQ(complete_windows(file, 3000, 50000), 16);
}

// Several models and the "every event moving" baseline on the same windows: one result per
// model in the order given, then the baseline; the pass-all model (every event pixel, one step
// late) scores close to the baseline that predicts every event pixel at once.
TEST_F(EvalCli, SeveralModelsAndTheAllEventsBaseline) {
  const std::string o = dir_ + "/out_several";
  // The same file name in another folder: the table then names the models by their paths.
  fs::create_directories(dir_ + "/b");
  const std::string copy = dir_ + "/b/pass_all.safetensors";
  fs::copy_file(model(), copy, fs::copy_options::overwrite_existing);
  std::string out;
  ASSERT_EQ(run_command(eval("--model " + copy + " --baseline all-events --data " + data() +
                             " --split all --windows 20,100 --out " + o),
                        &out),
            0)
      << out;
  const auto j = nlohmann::json::parse(slurp(o + "/results.json"));
  ASSERT_EQ(j["models"].size(), 3u);
  EXPECT_EQ(j["models"][0]["model"], model());
  EXPECT_EQ(j["models"][1]["model"], copy);
  EXPECT_EQ(j["models"][2]["model"], "baseline:all-events");
  EXPECT_EQ(j["models"][2]["name"], "every event moving");
  for (size_t w = 0; w < 2; ++w) {
    const auto& a = j["models"][0]["datasets"][0]["windows"][w];
    const auto& b = j["models"][1]["datasets"][0]["windows"][w];
    const auto& c = j["models"][2]["datasets"][0]["windows"][w];
    EXPECT_EQ(a["iou_mean"], b["iou_mean"]);  // the same model twice: the same numbers
    EXPECT_EQ(a["windows"], c["windows"]);    // the same windows for the baseline
    EXPECT_NEAR(a["iou_mean"].get<double>(), c["iou_mean"].get<double>(), 5.0) << "window " << w;
  }
  EXPECT_NE(slurp(o + "/results.md").find("every event moving"), std::string::npos);
  EXPECT_FALSE(j["gate_events"].get<bool>());
  // Gated by events (P ∩ E): G ⊆ E, so P ∩ G stays and the union can only shrink: a model's
  // IoU cannot fall, and the baseline (P = E) does not change.
  ASSERT_EQ(run_command(eval("--model " + copy + " --baseline all-events --data " + data() +
                             " --split all --windows 20,100 --gate-events --out " + o + "_gated"),
                        &out),
            0)
      << out;
  const auto jg = nlohmann::json::parse(slurp(o + "_gated/results.json"));
  EXPECT_TRUE(jg["gate_events"].get<bool>());
  for (size_t w = 0; w < 2; ++w) {
    const auto& plain = j["models"][1]["datasets"][0]["windows"][w];
    const auto& gated = jg["models"][1]["datasets"][0]["windows"][w];
    EXPECT_GE(gated["iou_mean"].get<double>(), plain["iou_mean"].get<double>() - 1e-9);
    EXPECT_EQ(jg["models"][2]["datasets"][0]["windows"][w]["iou_mean"],
              j["models"][2]["datasets"][0]["windows"][w]["iou_mean"]);
  }
  EXPECT_NE(slurp(o + "_gated/results.md").find("gated by events"), std::string::npos);
  EXPECT_NE(out.find("| " + copy + " "), std::string::npos) << out;
  EXPECT_NE(out.find("| " + model() + " "), std::string::npos) << out;
  EXPECT_NE(run_command(eval("--baseline none --data " + data()), &out), 0);
  EXPECT_NE(out.find("--baseline"), std::string::npos) << out;
}

// Events of the whole windows of a length (the partial last one dropped): all, and moving.
std::pair<int64_t, int64_t> events_in_windows(const std::string& file, int64_t window_us) {
  const LabelledSequence s = load_sequence(file);
  const int64_t t0 = s.events.t_first();
  const int64_t end = t0 + (s.events.t_last() + 1 - t0) / window_us * window_us;
  int64_t all = 0, moving = 0;
  for (size_t i = 0; i < s.events.size(); ++i)
    if (s.events.t[i] < end) ++all, moving += s.events.label[i] != 0;
  return {all, moving};
}

TEST_F(EvalCli, EventPrecisionRecallAndKalmanRows) {
  const std::string o = dir_ + "/out_events";
  std::string out;
  // 26 window lengths (1..25 holds 20) from one run per sequence, plus the filtered 3 ms rows.
  ASSERT_EQ(run_command(eval("--data " + data() +
                             " --windows 1:25,20,100 --kalman 3 "
                             "--baseline all-events --out " +
                             o),
                        &out),
            0)
      << out;
  const auto j = nlohmann::json::parse(slurp(o + "/results.json"));
  EXPECT_EQ(j["kalman_ms"], nlohmann::json({3.0}));
  ASSERT_EQ(j["models"].size(), 2u);
  for (const auto& m : j["models"]) {
    const auto& d = m["datasets"][0];
    ASSERT_EQ(d["windows"].size(), 26u + 1u);
    const auto& k = d["windows"][26];
    EXPECT_EQ(k["window_ms"], 3.0);
    EXPECT_EQ(k["filter"], "kalman");
    EXPECT_TRUE(k["event_precision"].is_null());
    EXPECT_FALSE(k["iou_mean"].is_null());
    EXPECT_TRUE(d["windows"][2]["filter"].is_null());
    // The counts cover exactly the events of each length's whole windows.
    const std::string seq = d["per_sequence"][0]["sequence"];
    for (size_t i : {size_t(0), size_t(9), size_t(25)}) {
      const auto& w = d["per_sequence"][0]["windows"][i];
      const int64_t len = std::llround(w["window_ms"].get<double>() * 1000);
      const auto [all, moving] = events_in_windows(seq, len);
      const auto& c = w["event_counts"];
      EXPECT_EQ(c["tp"].get<int64_t>() + c["fp"].get<int64_t>() + c["fn"].get<int64_t>() +
                    c["tn"].get<int64_t>(),
                all);
      EXPECT_EQ(c["tp"].get<int64_t>() + c["fn"].get<int64_t>(), moving);
      if (m["model"] == "baseline:all-events") {
        // Every event predicted moving: recall 100 %, precision = the moving share.
        EXPECT_EQ(c["tn"], 0);
        EXPECT_DOUBLE_EQ(w["event_recall"].get<double>(), 100.0);
        EXPECT_NEAR(w["event_precision"].get<double>(), 100.0 * double(moving) / double(all), 1e-9);
        EXPECT_DOUBLE_EQ(w["moving_share"].get<double>(), 100.0);
      } else {
        // Pass-all labels nearly every event moving (refractoriness may hide a few).
        EXPECT_GT(w["event_recall"].get<double>(), 90.0);
      }
    }
  }
  const std::string csv = slurp(o + "/results.csv");
  EXPECT_NE(csv.find(",filter,event_precision,event_recall,events_tp,"), std::string::npos);
  EXPECT_NE(csv.find(",kalman,"), std::string::npos);
  EXPECT_NE(out.find("| 3 filtered "), std::string::npos) << out;
  EXPECT_NE(out.find("event P %"), std::string::npos) << out;
  // A Kalman length must be whole steps too.
  EXPECT_EQ(run_command(eval("--data " + data() + " --kalman 2.5 --out " + o + "x"), &out), 1);
  EXPECT_NE(out.find("--kalman"), std::string::npos) << out;
}

// --share-bands: every window row also comes split by the share of its events that move; the
// bands partition the row's scored windows and their IoU averages back to the row's.
TEST_F(EvalCli, ShareBandsPartitionTheScoredWindows) {
  const std::string o = dir_ + "/out_bands";
  std::string out;
  ASSERT_EQ(run_command(eval("--data " + data() +
                             " --split all --windows 10,50 --share-bands "
                             "5,20 --out " +
                             o),
                        &out),
            0)
      << out;
  const auto j = nlohmann::json::parse(slurp(o + "/results.json"));
  EXPECT_EQ(j["share_bands_pct"], nlohmann::json::array({5.0, 20.0}));
  const auto& d = j["models"][0]["datasets"][0];
  std::vector<nlohmann::json> rows(d["windows"].begin(), d["windows"].end());
  for (const auto& s : d["per_sequence"])
    for (const auto& w : s["windows"]) rows.push_back(w);
  size_t with_windows = 0;
  for (const auto& w : rows) {
    ASSERT_EQ(w["share_bands"].size(), 3u) << w.dump();
    EXPECT_EQ(w["share_bands"][0]["share_max_pct"], 5.0);
    EXPECT_EQ(w["share_bands"][2]["share_min_pct"], 20.0);
    size_t n = 0;
    double sum = 0;
    for (const auto& b : w["share_bands"]) {
      const size_t bn = b["windows"].get<size_t>();
      n += bn;
      if (bn > 0)
        sum += b["iou_mean"].get<double>() * double(bn);
      else
        EXPECT_TRUE(b["iou_mean"].is_null());
    }
    EXPECT_EQ(n, w["windows"].get<size_t>());
    if (n == 0) continue;
    ++with_windows;
    EXPECT_NEAR(sum / double(n), w["iou_mean"].get<double>(), 1e-9);
  }
  EXPECT_GT(with_windows, 0u);
  EXPECT_NE(slurp(o + "/results.md").find("| 5-20 %: IoU % (detection %, windows) |"),
            std::string::npos);
  EXPECT_NE(out.find("| ≥ 20 %: IoU % (detection %, windows) |"), std::string::npos) << out;
  EXPECT_NE(slurp(o + "/report.html").find("5-20 %"), std::string::npos);
  EXPECT_NE(slurp(o + "/report.html").find("plots/iou_by_share_1.svg"), std::string::npos);
  EXPECT_TRUE(fs::exists(o + "/plots/iou_by_share_1.svg"));
  // none: no bands; bad edges stop before any work with the option named.
  ASSERT_EQ(run_command(eval("--data " + data() + " --share-bands none --out " + o + "n"), &out), 0)
      << out;
  const auto n = nlohmann::json::parse(slurp(o + "n/results.json"));
  EXPECT_TRUE(n["models"][0]["datasets"][0]["windows"][0]["share_bands"].is_null());
  EXPECT_EQ(slurp(o + "n/results.md").find("By the moving share"), std::string::npos);
  for (const char* bad : {"10,2", "0,5", "5,100", "x", "5,,10", "nan"}) {
    EXPECT_EQ(run_command(eval("--data " + data() + " --share-bands " + bad), &out), 1) << bad;
    EXPECT_NE(out.find("--share-bands"), std::string::npos) << bad << ": " << out;
  }
}

// --min-moving-share: the windows kept are exactly the band at or above the share of a run
// without the filter (same IoU, detection and count); the rest with moving events are counted
// as filtered; combinations without labels are refused.
TEST_F(EvalCli, MinMovingShareScoresTheTopBandOnly) {
  const std::string o = dir_ + "/out_minshare";
  std::string out;
  ASSERT_EQ(run_command(eval("--data " + data() + " --split all --windows 10,50 --share-bands 20 " +
                             "--out " + o + "a"),
                        &out),
            0)
      << out;
  ASSERT_EQ(run_command(eval("--data " + data() + " --split all --windows 10,50 --share-bands 20 " +
                             "--min-moving-share 20 --out " + o + "f"),
                        &out),
            0)
      << out;
  EXPECT_NE(out.find("| filtered |"), std::string::npos) << out;
  const auto a = nlohmann::json::parse(slurp(o + "a/results.json"));
  const auto f = nlohmann::json::parse(slurp(o + "f/results.json"));
  EXPECT_TRUE(a["min_moving_share_pct"].is_null());
  EXPECT_EQ(f["min_moving_share_pct"], 20.0);
  const auto& aw = a["models"][0]["datasets"][0]["windows"];
  const auto& fw = f["models"][0]["datasets"][0]["windows"];
  ASSERT_EQ(aw.size(), 2u);
  size_t kept_somewhere = 0, filtered_somewhere = 0;
  for (size_t i = 0; i < aw.size(); ++i) {
    const auto& top = aw[i]["share_bands"][1];  // >= 20 %
    const auto& low = aw[i]["share_bands"][0];
    EXPECT_EQ(aw[i]["filtered_windows"], 0u);
    EXPECT_EQ(fw[i]["windows"], top["windows"]) << i;
    EXPECT_EQ(fw[i]["filtered_windows"], low["windows"]) << i;
    EXPECT_EQ(fw[i]["skipped_windows"], aw[i]["skipped_windows"]) << i;
    // The events are counted over every window either way.
    EXPECT_EQ(fw[i]["event_counts"], aw[i]["event_counts"]) << i;
    if (top["windows"].get<size_t>() > 0) {
      ++kept_somewhere;
      EXPECT_NEAR(fw[i]["iou_mean"].get<double>(), top["iou_mean"].get<double>(), 1e-9);
      EXPECT_NEAR(fw[i]["detection_rate"].get<double>(), top["detection_rate"].get<double>(), 1e-9);
    }
    filtered_somewhere += low["windows"].get<size_t>() > 0;
  }
  EXPECT_GT(kept_somewhere, 0u);  // the tiny preset has windows on both sides of 20 %
  EXPECT_GT(filtered_somewhere, 0u);
  EXPECT_NE(slurp(o + "f/results.csv").find(",filtered_windows\n"), std::string::npos);
  EXPECT_NE(slurp(o + "f/results.md").find("at least 20 %"), std::string::npos);
  // Refused: out of range (exit 1), not a number (the parser's non-zero exit), and with inputs
  // that have no labelled moving events.
  for (const char* bad : {"100", "-1"}) {
    EXPECT_EQ(run_command(eval("--data " + data() + " --min-moving-share " + bad), &out), 1) << bad;
    EXPECT_NE(out.find("--min-moving-share"), std::string::npos) << bad << ": " << out;
    EXPECT_NE(out.find("[0, 100)"), std::string::npos) << bad << ": " << out;
  }
  EXPECT_NE(run_command(eval("--data " + data() + " --min-moving-share abc"), &out), 0);
  EXPECT_NE(out.find("--min-moving-share"), std::string::npos) << out;
  EXPECT_EQ(
      run_command(eval("--data " + data() + " --split all --static-scene --min-moving-share 50"),
                  &out),
      1);
  EXPECT_NE(out.find("--static-scene"), std::string::npos) << out;
}

// --group-windows: the same windows are scored (counts unchanged), 1 is the plain score, and
// the files say the group size; bad sizes and static scenes are refused.
TEST_F(EvalCli, GroupWindowsKeepsTheWindowCountsAndOneIsThePlainScore) {
  const std::string o = dir_ + "/out_groups";
  std::string out;
  for (const char* g : {"1", "4"})
    ASSERT_EQ(run_command(eval("--data " + data() + " --split all --windows 10,50 " +
                               "--group-windows " + g + " --out " + o + g),
                          &out),
              0)
        << out;
  ASSERT_EQ(run_command(eval("--data " + data() + " --split all --windows 10,50 --out " + o), &out),
            0)
      << out;
  const auto plain = nlohmann::json::parse(slurp(o + "/results.json"));
  const auto one = nlohmann::json::parse(slurp(o + "1/results.json"));
  const auto four = nlohmann::json::parse(slurp(o + "4/results.json"));
  EXPECT_EQ(plain["group_windows"], 1);
  EXPECT_EQ(four["group_windows"], 4);
  const auto& pw = plain["models"][0]["datasets"][0]["windows"];
  const auto& ow = one["models"][0]["datasets"][0]["windows"];
  const auto& fw = four["models"][0]["datasets"][0]["windows"];
  ASSERT_EQ(fw.size(), 2u);
  for (size_t i = 0; i < pw.size(); ++i) {
    EXPECT_EQ(ow[i]["iou_mean"], pw[i]["iou_mean"]) << i;
    EXPECT_EQ(fw[i]["windows"], pw[i]["windows"]) << i;
    EXPECT_EQ(fw[i]["skipped_windows"], pw[i]["skipped_windows"]) << i;
    EXPECT_EQ(fw[i]["event_counts"], pw[i]["event_counts"]) << i;
  }
  EXPECT_NE(slurp(o + "4/results.md").find("groups of 4 consecutive"), std::string::npos);
  for (const char* bad : {"0", "10001"}) {
    EXPECT_EQ(run_command(eval("--data " + data() + " --group-windows " + bad), &out), 1) << bad;
    EXPECT_NE(out.find("--group-windows"), std::string::npos) << bad << ": " << out;
  }
  EXPECT_NE(run_command(eval("--data " + data() + " --group-windows x"), &out), 0);
  EXPECT_EQ(
      run_command(eval("--data " + data() + " --split all --static-scene --group-windows 8"), &out),
      1);
  EXPECT_NE(out.find("--static-scene"), std::string::npos) << out;
}

// --keep-events: every sequence is thinned before it is scored (about the share asked for,
// the same events on every run), and the files say so; bad shares are refused.
TEST_F(EvalCli, KeepEventsThinsTheDataRepeatably) {
  const std::string o = dir_ + "/out_keep";
  std::string out;
  const std::string base = "--data " + data() + " --split all --windows 10 --baseline all-events ";
  ASSERT_EQ(run_command(eval(base + "--out " + o + "all"), &out), 0) << out;
  for (const char* r : {"a", "b"})
    ASSERT_EQ(run_command(eval(base + "--keep-events 0.5 --out " + o + r), &out), 0) << out;
  const auto all = nlohmann::json::parse(slurp(o + "all/results.json"));
  const auto a = nlohmann::json::parse(slurp(o + "a/results.json"));
  const auto b = nlohmann::json::parse(slurp(o + "b/results.json"));
  EXPECT_EQ(all["keep_events"], 1.0);
  EXPECT_EQ(a["keep_events"], 0.5);
  auto total = [](const nlohmann::json& j) {  // the baseline's events: every one it was given
    const auto& c = j["models"][1]["datasets"][0]["windows"][0]["event_counts"];
    return c["tp"].get<double>() + c["fp"].get<double>() + c["fn"].get<double>() +
           c["tn"].get<double>();
  };
  const double n = total(all), k = total(a);
  ASSERT_GT(n, 2000);
  EXPECT_NEAR(k, n / 2, 5 * std::sqrt(n / 4)) << k << " of " << n;  // binomial, 5 sd
  EXPECT_EQ(a["models"], b["models"]);  // the same events, the same scores
  EXPECT_NE(slurp(o + "a/results.md").find("kept with probability 0.5"), std::string::npos);
  for (const char* bad : {"0", "1.5", "-1"}) {
    EXPECT_EQ(run_command(eval("--data " + data() + " --keep-events " + bad), &out), 1) << bad;
    EXPECT_NE(out.find("--keep-events"), std::string::npos) << bad << ": " << out;
  }
}

// --static-scene: an unlabelled recording of a static scene; every event is background and the
// score is the share of events each model labels moving.
TEST_F(EvalCli, StaticSceneScoresTheShareOfEventsCalledMoving) {
  const std::string rec = dir_ + "/static.txt";
  {
    std::ofstream f(rec);
    f << "# sensor 64 48\n# time_unit us\n";
    uint32_t h = 7;
    // Scattered events, no labels: 4000 in ten whole 10 ms windows, the last one starts an 11th.
    for (int i = 0; i <= 4000; ++i) {
      h = h * 1664525u + 1013904223u;
      f << i * 25 << " " << (h >> 8) % 64 << " " << (h >> 16) % 48 << " " << (h >> 30) % 2 << "\n";
    }
  }
  save_model(dir_ + "/silent.safetensors", test::pointwise_model({0.f, 0.f, 0.f, 0.f}, "silent"));
  const std::string o = dir_ + "/out_static";
  std::string out;
  ASSERT_EQ(
      run_command(eval("--model " + dir_ + "/silent.safetensors --baseline all-events --data " +
                       rec + " --static-scene --windows 10 --out " + o),
                  &out),
      0)
      << out;
  const auto j = nlohmann::json::parse(slurp(o + "/results.json"));
  EXPECT_EQ(j["static_scene"], true);
  ASSERT_EQ(j["models"].size(), 3u);  // pass-all, silent, the baseline
  double share[3];
  for (size_t i = 0; i < 3; ++i) {
    const auto& w = j["models"][i]["datasets"][0]["windows"][0];
    EXPECT_EQ(w["windows"], 0);  // nothing moves: no window has a G to score
    EXPECT_EQ(w["skipped_windows"], 10);
    const auto& c = w["event_counts"];
    EXPECT_EQ(c["tp"], 0);
    EXPECT_EQ(c["fn"], 0);
    const double fp = c["fp"].get<double>(), tn = c["tn"].get<double>();
    EXPECT_EQ(fp + tn, 4000.0);
    EXPECT_TRUE(w["share_bands"].is_null());  // no window scored, so no shares
    share[i] = w["moving_share"].get<double>();
    EXPECT_DOUBLE_EQ(share[i], 100.0 * fp / (fp + tn));
  }
  EXPECT_GT(share[0], 90.0);          // pass-all: (nearly) every event
  EXPECT_DOUBLE_EQ(share[1], 0.0);    // silent: none
  EXPECT_DOUBLE_EQ(share[2], 100.0);  // every event moving
  EXPECT_NE(out.find("moving %"), std::string::npos) << out;
  EXPECT_NE(slurp(o + "/results.md").find("static scene"), std::string::npos);
  EXPECT_NE(slurp(o + "/results.csv")
                .find(",moving_share,output_threshold_scale,output_gate_ms,filtered_windows\n"),
            std::string::npos);
  // Without the flag the same file is refused for its missing labels; with boxes it is refused.
  EXPECT_EQ(run_command(eval("--data " + rec + " --out " + o + "x"), &out), 1);
  EXPECT_NE(out.find("no labels"), std::string::npos) << out;
  std::ofstream(dir_ + "/b.csv") << "0,1000000,1,1,5,5\n";
  EXPECT_EQ(run_command(eval("--data " + rec + " --static-scene --boxes " + dir_ + "/b.csv"), &out),
            1);
  EXPECT_NE(out.find("--static-scene"), std::string::npos) << out;
}

// --output-thresholds scores each model once per factor on its output threshold: a row each,
// the factor in every file, and the operating points plotted in the report. The pass-all
// model's potential peaks at 1.0 for a lone input spike (weight 1, kernel peak 1) against
// θ = 0.22, so at a factor 4 its events stay labelled; with an input spike at every step it
// reaches the kernel's sum, ~5.4, so at 50 nothing is.
TEST_F(EvalCli, OutputThresholdsGiveARowPerFactorAndAnOperatingPointPlot) {
  const std::string o = dir_ + "/out_thresholds";
  std::string out;
  ASSERT_EQ(
      run_command(
          eval("--data " + data() +
               " --split all --windows 20 --output-thresholds 1,4,50 --baseline all-events --out " +
               o),
          &out),
      0)
      << out;
  const auto j = nlohmann::json::parse(slurp(o + "/results.json"));
  ASSERT_EQ(j["models"].size(), 4u);  // three factors, then the baseline
  EXPECT_EQ(j["models"][3]["output_threshold_scale"].get<double>(), 1.0);
  const double factors[3] = {1, 4, 50};
  double moving[3];
  for (size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(j["models"][i]["model"], model());
    EXPECT_EQ(j["models"][i]["output_threshold_scale"].get<double>(), factors[i]);
    moving[i] = j["models"][i]["datasets"][0]["windows"][0]["moving_share"].get<double>();
  }
  EXPECT_GT(moving[0], 90.0);
  EXPECT_GT(moving[1], 80.0);  // below a lone spike's peak: (nearly) the same labels
  EXPECT_LE(moving[1], moving[0] + 1.0);
  EXPECT_EQ(moving[2], 0.0);  // above any reachable potential: nothing
  EXPECT_NE(out.find("pass_all.safetensors θ×4 "), std::string::npos) << out;
  EXPECT_NE(slurp(o + "/results.md").find("output θ × 50"), std::string::npos);
  EXPECT_NE(slurp(o + "/results.csv").find(",50,0,0\n"), std::string::npos);
  // The plot: the model's curve (factors 1 and 4; nothing is labelled at 50, so no precision)
  // and the baseline's point, named once each.
  const std::string svg = slurp(o + "/plots/operating_points_1.svg");
  EXPECT_NE(svg.find(">pass_all.safetensors<"), std::string::npos) << svg;
  EXPECT_NE(svg.find(">every event moving<"), std::string::npos) << svg;
  EXPECT_NE(slurp(o + "/report.html").find("operating_points_1.svg"), std::string::npos);
  for (const char* bad : {"0", "1,x", "1,1", "1,,2"}) {
    EXPECT_EQ(
        run_command(eval(std::string("--data ") + data() + " --output-thresholds " + bad), &out), 1)
        << bad;
    EXPECT_NE(out.find("--output-thresholds"), std::string::npos) << out;
  }
}

// --output-gates scores each model once per output gate: a row each, the gate in every file. The
// pass-all model answers an event one step (1 ms) later at its pixel, so a 1 ms gate (the
// output's own step only) keeps only outputs at pixels that had another event in that step,
// fewer than without a gate; a gate of 100 ms is longer than any of its answers (a lone spike's
// potential is below θ again within a few steps), so it keeps every output: the ungated scores.
TEST_F(EvalCli, OutputGatesGiveARowPerGate) {
  const std::string o = dir_ + "/out_gates";
  std::string out;
  ASSERT_EQ(run_command(eval("--data " + data() +
                             " --split all --windows 20 --output-gates 0,1,100 --out " + o),
                        &out),
            0)
      << out;
  const auto j = nlohmann::json::parse(slurp(o + "/results.json"));
  ASSERT_EQ(j["models"].size(), 3u);
  const double gates[3] = {0, 1, 100};
  double moving[3], iou[3];
  for (size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(j["models"][i]["output_gate_ms"].get<double>(), gates[i]);
    moving[i] = j["models"][i]["datasets"][0]["windows"][0]["moving_share"].get<double>();
    iou[i] = j["models"][i]["datasets"][0]["windows"][0]["iou_mean"].get<double>();
  }
  EXPECT_GT(moving[0], 90.0);
  EXPECT_LT(moving[1], moving[0] - 10.0);
  EXPECT_DOUBLE_EQ(moving[2], moving[0]);
  EXPECT_DOUBLE_EQ(iou[2], iou[0]);
  EXPECT_NE(out.find("pass_all.safetensors gate 1 ms "), std::string::npos) << out;
  EXPECT_NE(slurp(o + "/results.md").find("output gate 100 ms"), std::string::npos);
  EXPECT_NE(slurp(o + "/results.csv").find(",1,100,0\n"), std::string::npos);
  for (const char* bad : {"-1", "1,x", "1,1", "1,,2", "0.5", "0.0001"}) {
    EXPECT_EQ(run_command(eval(std::string("--data ") + data() + " --output-gates " + bad), &out),
              1)
        << bad;
    EXPECT_TRUE(out.find("--output-gates") != std::string::npos ||
                out.find("whole number") != std::string::npos)
        << bad << ": " << out;
  }
}

// --time-step-ms runs every model at another step with its time constants scaled (time_step.h):
// the same scores as the model file moved by with_time_step and scored at its own step, the
// step in every file; its own step changes nothing; a coarser one changes the scores.
TEST_F(EvalCli, TimeStepMsScoresTheModelMovedToThatStep) {
  const std::string moved = dir_ + "/pass_all_2ms.safetensors";
  save_model(moved, with_time_step(load_model(model()), 2, TimeConstants::Steps, "test"));
  auto scores = [&](const std::string& cmd, const std::string& o) {
    std::string out;
    EXPECT_EQ(run_command(cmd + " --data " + data() + " --split all --windows 20 --out " + o, &out),
              0)
        << out;
    const auto j = nlohmann::json::parse(slurp(o + "/results.json"));
    const auto& m = j["models"][0];
    const auto& w = m["datasets"][0]["windows"][0];
    return std::vector<double>{m["time_step_ms"].get<double>(), w["iou_mean"].get<double>(),
                               w["moving_share"].get<double>(), w["detection_rate"].get<double>(),
                               double(m["time_step_scaled"].get<bool>())};
  };
  const auto own = scores(eval(""), dir_ + "/ts_own");
  const auto same = scores(eval("--time-step-ms 1"), dir_ + "/ts_same");
  const auto flag = scores(eval("--time-step-ms 2"), dir_ + "/ts_flag");
  const auto file = scores(spikems_binary() + " eval --quiet --model " + moved, dir_ + "/ts_file");
  EXPECT_EQ(same, own);
  EXPECT_DOUBLE_EQ(flag[0], 2);
  EXPECT_DOUBLE_EQ(flag[4], 1);
  for (size_t i = 0; i < 4; ++i) EXPECT_DOUBLE_EQ(flag[i], file[i]) << i;
  EXPECT_NE(flag[1], own[1]) << "2 ms steps left the IoU as it was";
  EXPECT_NE(slurp(dir_ + "/ts_flag/results.md").find("pass_all.safetensors at 2 ms steps"),
            std::string::npos);
  std::string out;
  for (const char* bad : {"-1", "nan"}) {
    EXPECT_EQ(run_command(eval(std::string("--data ") + data() + " --time-step-ms " + bad), &out),
              1)
        << bad;
    EXPECT_NE(out.find("--time-step-ms"), std::string::npos) << bad << ": " << out;
  }
  EXPECT_EQ(run_command(eval("--data " + data() + " --time-step-ms 3 --windows 20"), &out), 1);
  EXPECT_NE(out.find("not a multiple"), std::string::npos) << out;
}

TEST_F(EvalCli, BadInputStopsWithAClearMessage) {
  const std::string o = dir_ + "/out_bad";
  std::string out;
  // A recording without labels.
  const std::string plain = dir_ + "/plain.txt";
  std::ofstream(plain) << "# sensor 64 48\n1000 1 1 1\n2000 2 2 0\n";
  EXPECT_EQ(run_command(eval("--data " + plain + " --out " + o), &out), 1);
  EXPECT_NE(out.find(plain), std::string::npos) << out;
  EXPECT_NE(out.find("no labels"), std::string::npos) << out;
  // An empty split.
  fs::create_directories(dir_ + "/empty");
  std::ofstream(dir_ + "/empty/manifest.json")
      << R"({"splits": {"train": ["x.h5"], "val": [], "test": []}})";
  EXPECT_EQ(run_command(eval("--data " + dir_ + "/empty --out " + o), &out), 1);
  EXPECT_NE(out.find("manifest.json"), std::string::npos) << out;
  EXPECT_NE(out.find("lists no sequences"), std::string::npos) << out;
  EXPECT_EQ(run_command(eval("--data " + data() + " --split nope --out " + o), &out), 1);
  EXPECT_NE(out.find("nope"), std::string::npos) << out;
  // Window lists that do not parse, are not positive or not whole steps.
  EXPECT_EQ(run_command(eval("--data " + data() + " --windows 20,abc --out " + o), &out), 1);
  EXPECT_NE(out.find("'abc'"), std::string::npos) << out;
  EXPECT_EQ(run_command(eval("--data " + data() + " --windows 0 --out " + o), &out), 1);
  EXPECT_NE(out.find("positive"), std::string::npos) << out;
  EXPECT_EQ(run_command(eval("--data " + data() + " --windows 2.5 --out " + o), &out), 1);
  EXPECT_NE(out.find("not a multiple of the model's time step"), std::string::npos) << out;
  // Missing, unreadable, invalid or absent model.
  const std::string nomodel = spikems_binary() + " eval --quiet --data " + data() + " --out " + o;
  EXPECT_EQ(run_command(nomodel + " --model " + dir_ + "/missing.safetensors", &out), 1);
  EXPECT_NE(out.find(dir_ + "/missing.safetensors"), std::string::npos) << out;
  std::ofstream(dir_ + "/bad.safetensors") << "not a model";
  EXPECT_EQ(run_command(nomodel + " --model " + dir_ + "/bad.safetensors", &out), 1);
  EXPECT_NE(out.find("bad.safetensors"), std::string::npos) << out;
  // No --model and no shipped model where SPIKEMS_MODEL points: a message saying what to do.
  EXPECT_EQ(run_command("SPIKEMS_MODEL=" + dir_ + "/none.safetensors " + nomodel, &out), 1);
  EXPECT_NE(out.find("give --model FILE"), std::string::npos) << out;
  // A missing data path.
  EXPECT_EQ(run_command(eval("--data " + dir_ + "/nowhere --out " + o), &out), 1);
  EXPECT_NE(out.find(dir_ + "/nowhere"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(o + "/results.json"));  // nothing written on an error
}

// --downsample 2 scores the network on its half-resolution grid: the same rows as scoring the
// sequences converted with `spikems convert --downsample 2`; auto does so for a model whose
// training grid (--train-grid, or the one in the file) is half the sensor; 1 differs.
TEST_F(EvalCli, DownsampleScoresOnTheNetworksGrid) {
  std::string out;
  const std::string conv = dir_ + "/tiny_ds2";
  fs::create_directories(conv);
  std::vector<std::string> files = sequence_files({data(), "all"});
  ASSERT_EQ(files.size(), 3u);
  std::string full_args, conv_args;
  for (size_t i = 0; i < files.size(); ++i) {
    const std::string c = conv + "/s" + std::to_string(i) + ".h5";
    ASSERT_EQ(run_command(
                  spikems_binary() + " convert " + files[i] + " " + c + " --downsample 2 -q", &out),
              0)
        << out;
    full_args += " --data " + files[i];
    conv_args += " --data " + c;
  }
  auto rows = [&](const std::string& args, const std::string& o, int factor) {
    EXPECT_EQ(run_command(eval(args + " --windows 20,100 --out " + o), &out), 0) << out;
    const auto j = nlohmann::json::parse(slurp(o + "/results.json"));
    EXPECT_EQ(j["models"][0]["downsample"], factor) << args;
    EXPECT_EQ(slurp(o + "/results.md").find("at 1/2 resolution") != std::string::npos, factor == 2)
        << args;
    std::vector<double> v;
    for (const auto& d : j["models"][0]["datasets"])
      for (const auto& w : d["windows"]) {
        v.push_back(w["iou_mean"].get<double>());
        v.push_back(w["detection_rate"].get<double>());
        v.push_back(w["windows"].get<double>());
      }
    return v;
  };
  const auto converted = rows(conv_args, dir_ + "/ds_conv", 1);
  const auto ds2 = rows(full_args + " --downsample 2", dir_ + "/ds_2", 2);
  const auto grid = rows(full_args + " --train-grid 32x24", dir_ + "/ds_auto", 2);
  const auto ds1 = rows(full_args + " --train-grid 32x24 --downsample 1", dir_ + "/ds_1", 1);
  // A 64x48 and a 32x24 sequence with auto: 2 on one, 1 on the other.
  const auto mixed = rows(" --data " + files[0] + " --data " + conv + "/s1.h5 --train-grid 32x24",
                          dir_ + "/ds_mixed", 0);
  EXPECT_FALSE(mixed.empty());
  ASSERT_EQ(converted.size(), 3u * 2 * 3);
  EXPECT_EQ(ds2, converted);
  EXPECT_EQ(grid, converted);
  EXPECT_NE(ds1, converted);
  for (const std::string bad : {" --downsample 3", " --downsample auto2", " --train-grid 32",
                                " --train-grid 0x24", " --train-grid 32x24x2"}) {
    EXPECT_EQ(run_command(eval(full_args + bad + " --out " + dir_ + "/ds_bad"), &out), 1) << bad;
    EXPECT_NE(out.find(bad.substr(1, bad.find(' ', 1) - 1)), std::string::npos) << out;
  }
  EXPECT_FALSE(fs::exists(dir_ + "/ds_bad/results.json"));
  // A model that records its grid takes no other one.
  ModelSpec g = load_model(model());
  g.train_width = 32;
  g.train_height = 24;
  save_model(dir_ + "/grid.safetensors", g);
  EXPECT_EQ(run_command(spikems_binary() + " eval --quiet --model " + dir_ + "/grid.safetensors" +
                            full_args + " --train-grid 16x12 --out " + dir_ + "/ds_bad",
                        &out),
            1);
  EXPECT_NE(out.find("records its own training grid, 32x24"), std::string::npos) << out;
  // The same grid is no conflict: both models (pass-all given it, the file's own) run at 2.
  EXPECT_EQ(rows(" --model " + dir_ + "/grid.safetensors" + full_args + " --train-grid 32x24",
                 dir_ + "/ds_same", 2),
            converted);
  const auto js = nlohmann::json::parse(slurp(dir_ + "/ds_same/results.json"));
  ASSERT_EQ(js["models"].size(), 2u);
  EXPECT_EQ(js["models"][1]["downsample"], 2);
}

TEST_F(EvalCli, HelpShowsOptionsAndExamples) {
  std::string out;
  ASSERT_EQ(run_command(spikems_binary() + " eval --help", &out), 0) << out;
  for (const char* k : {"--model", "--data", "--split", "--windows", "--out", "--threads", "--iir",
                        "--max-seconds", "--quiet", "Examples", "1:25"})
    EXPECT_NE(out.find(k), std::string::npos) << k;
}

// --out also writes the report, and the windows it shows come from the scoring pass itself:
// for the baseline, P is exactly the pixels with an event in the window and G those with a
// moving-object event.
TEST_F(EvalCli, ReportShowsWindowsCapturedWhileScoring) {
  const std::string o = dir_ + "/out_report";
  std::string out;
  ASSERT_EQ(run_command(eval("--baseline all-events --data " + data() +
                             " --split all --windows 20,100 --out " + o),
                        &out),
            0)
      << out;
  for (const char* f : {"report.html", "plots/iou_by_window_1.svg", "plots/iou_per_sequence_1.svg"})
    EXPECT_TRUE(fs::is_regular_file(o + "/" + f)) << f;
  // 3 windows of 20 ms per sequence (fewer where fewer windows hold moving objects).
  size_t want_png = 0;
  for (const auto& e : fs::directory_iterator(data()))
    if (e.path().extension() == ".h5")
      want_png += example_windows(load_sequence(e.path().string()), 20000, 3).size();
  size_t png = 0;
  for (const auto& e : fs::directory_iterator(o + "/windows"))
    png += e.path().extension() == ".png";
  EXPECT_GT(want_png, 0u);
  EXPECT_EQ(png, want_png);

  EvalOptions opt;
  opt.models = {model()};
  opt.baselines = {"all-events"};
  opt.data = {data()};
  opt.split = "all";
  opt.windows_us = {10000, 100000};  // no 20 ms: the length nearest it, 10 ms, is shown
  opt.example_sequences = 2;         // of 3
  opt.example_windows = 2;
  EvalExamples ex;
  const EvalResults r = evaluate(opt, &ex);
  ASSERT_EQ(r.models.size(), 2u);
  EXPECT_EQ(ex.window_us, 10000);
  ASSERT_EQ(ex.datasets.size(), 1u);
  ASSERT_EQ(ex.datasets[0].size(), 2u);
  for (const SequenceExamples& s : ex.datasets[0]) {
    const LabelledSequence seq = load_sequence(s.name);
    const EventStream& ev = seq.events;
    const std::vector<int64_t> k = example_windows(seq, 10000, 2);
    ASSERT_EQ(s.windows.size(), k.size()) << s.name;
    for (size_t i = 0; i < k.size(); ++i) {
      const ExampleWindow& w = s.windows[i];
      EXPECT_EQ(w.t0_us, k[i] * 10000);
      EXPECT_EQ(w.t1_us, w.t0_us + 10000);
      ASSERT_EQ(w.predicted.size(), 2u);  // the model, then the baseline
      std::vector<uint8_t> p(size_t(ev.sensor.width) * size_t(ev.sensor.height), 0), g = p;
      const auto [b, e] = ev.time_range(ev.t_first() + w.t0_us, ev.t_first() + w.t1_us);
      for (size_t j = b; j < e; ++j) {
        const size_t px = size_t(ev.y[j]) * size_t(ev.sensor.width) + ev.x[j];
        p[px] = 1;
        if (ev.label[j] != 0) g[px] = 1;
      }
      EXPECT_EQ(w.truth, g);
      EXPECT_EQ(w.predicted[1], p);
      const MaskCounts c = count_masks(p, g);
      EXPECT_EQ(w.counts[1].intersection, c.intersection);
      EXPECT_EQ(w.counts[1].predicted, c.predicted);
      EXPECT_GT(c.truth, 0u);  // shown windows hold moving objects
      EXPECT_EQ(w.events.width, ev.sensor.width);
    }
  }
}

}  // namespace
}  // namespace spikems
