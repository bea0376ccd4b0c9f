// `spikems eval --boxes` as a user runs it: an unlabelled text recording written here, a
// boxes file, a pass-through model and the all-events baseline, scored to numbers counted by
// hand; bad boxes files and a second --data stop with exit 1 and a clear message.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "common/test_paths.h"
#include "common/tiny_models.h"
#include "core/model/model_file.h"

namespace spikems {
namespace {

namespace fs = std::filesystem;
using test::run_command;
using test::spikems_binary;

// Sensor 32x32, unlabelled events (t x y p, microseconds), windows of 10 ms from t = 0:
//   window 0: 60 events on x 10..15, y 10..19 (inside box A) and 10 on x 0..9, y 0, all in
//             its first 0.7 ms: the model's P = those 70 pixels (a spike one step after each).
//   window 1: one event at (0, 31), t = 12 ms: P = that pixel.
//   window 2: one event at (5, 5), t = 25 ms, and the last at (5, 5), t = 29.999 ms (the data
//             ends at 30 ms: 3 complete windows).
// Boxes: A over [0, 20 ms) on x 10..19, y 10..19 (100 pixels); none after 20 ms.
//   window 0: |P∩G| = 60, |P∪G| = 110: IoU 54.5454 %, a detection (60 > 50, 60 > 10);
//   window 1: |P∩G| = 0: IoU 0, no detection;  window 2: no box, skipped.
//   mean 27.2727 %, population std 27.2727 %, detection rate 50 %, 2 windows, 1 skipped.
// Events: the 60 in A are moving, the other 13 not; pass-through labels every event moving:
//   TP 60, FP 13, FN 0, TN 0; precision 60/73 = 82.1918 %, recall 100 %.
class EvalBoxesCli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::scratch_dir();
    std::ofstream ev(dir_ + "/ball.txt");
    ev << "# sensor 32 32\n# time_unit us\n";
    int64_t t = -10;  // the first event at t = 0: windows start there
    for (int y = 10; y <= 19; ++y)
      for (int x = 10; x <= 15; ++x) ev << (t += 10) << ' ' << x << ' ' << y << " 1\n";
    for (int x = 0; x <= 9; ++x) ev << (t += 10) << ' ' << x << " 0 0\n";
    ev << "12000 0 31 1\n25000 5 5 1\n29999 5 5 0\n";
    ev.close();
    std::ofstream(dir_ + "/boxes.csv") << "t_start_us,t_end_us,x0,y0,x1,y1,id\n"
                                          "0,20000,10,10,19,19,1\n";
    save_model(dir_ + "/pass.safetensors", test::pointwise_model({1.f, 0.f, 0.f, 1.f}, "pass"));
  }
  std::string eval(const std::string& args) const {
    return spikems_binary() + " eval --quiet --model " + dir_ + "/pass.safetensors --data " + dir_ +
           "/ball.txt --windows 10 " + args;
  }
  static std::string slurp(const std::string& path) {
    std::ifstream f(path);
    std::stringstream s;
    s << f.rdbuf();
    return s.str();
  }
  std::string dir_;
};

TEST_F(EvalBoxesCli, ScoresAnUnlabelledRecordingAgainstBoxPixels) {
  const std::string o = dir_ + "/out";
  std::string out;
  ASSERT_EQ(
      run_command(eval("--boxes " + dir_ + "/boxes.csv --baseline all-events --out " + o), &out), 0)
      << out;
  const auto j = nlohmann::json::parse(slurp(o + "/results.json"));
  EXPECT_EQ(j["boxes"], dir_ + "/boxes.csv");
  EXPECT_NE(j["protocol"]["truth"].get<std::string>().find("inside the boxes"), std::string::npos);
  // The model and the baseline predict the same pixels here (every event's, in its window).
  ASSERT_EQ(j["models"].size(), 2u);
  for (const auto& m : j["models"]) {
    const auto& w = m["datasets"][0]["windows"][0];
    EXPECT_EQ(w["window_ms"], 10.0);
    EXPECT_EQ(w["windows"], 2) << m["model"];
    EXPECT_EQ(w["skipped_windows"], 1) << m["model"];
    EXPECT_NEAR(w["iou_mean"].get<double>(), 100.0 * 3 / 11, 1e-9) << m["model"];
    EXPECT_NEAR(w["iou_std"].get<double>(), 100.0 * 3 / 11, 1e-9) << m["model"];
    EXPECT_NEAR(w["detection_rate"].get<double>(), 50.0, 1e-9) << m["model"];
    EXPECT_EQ(w["event_counts"]["tp"], 60) << m["model"];
    EXPECT_EQ(w["event_counts"]["fp"], 13) << m["model"];
    EXPECT_EQ(w["event_counts"]["fn"], 0) << m["model"];
    EXPECT_EQ(w["event_counts"]["tn"], 0) << m["model"];
    EXPECT_NEAR(w["event_precision"].get<double>(), 100.0 * 60 / 73, 1e-9) << m["model"];
    EXPECT_NEAR(w["event_recall"].get<double>(), 100.0, 1e-9) << m["model"];
  }
  EXPECT_NE(slurp(o + "/results.md").find("ground truth from boxes"), std::string::npos);
  const std::string report = slurp(o + "/report.html");
  EXPECT_NE(report.find("pixels inside the boxes valid in the window"), std::string::npos);
  EXPECT_NE(report.find("ground truth (box pixels"), std::string::npos);
}

TEST_F(EvalBoxesCli, BadBoxesOrSeveralSourcesStopWithExit1) {
  const std::string o = dir_ + "/out_bad";
  std::string out;
  // Without --boxes the unlabelled recording is refused as before.
  EXPECT_EQ(run_command(eval("--out " + o), &out), 1);
  EXPECT_NE(out.find("no labels"), std::string::npos) << out;
  // Bad rows, each named by file:line.
  struct Case {
    std::string text, want;
  };
  const Case cases[] = {
      {"", "bad.csv: at line 1: empty file"},
      {"t_us,x0,y0,x1,y1\n0,1,1,2,2\n", "bad.csv: at line 1: expected the header"},
      {"t_start_us,t_end_us,x0,y0,x1,y1\n0,20000,10,x,19,19\n",
       "bad.csv: at line 2: y0 = \"x\" is not a whole number"},
      {"t_start_us,t_end_us,x0,y0,x1,y1\n0,20000,19,10,10,19\n",
       "bad.csv: at line 2: x1 (10) is left of x0 (19)"},
      {"t_start_us,t_end_us,x0,y0,x1,y1\n5000,20000,1,1,2,2\n0,20000,1,1,2,2\n",
       "bad.csv: at line 3: times go back"},
      {"t_start_us,t_end_us,x0,y0,x1,y1\n0,20000,1,1,2,2\n0,20000,10,10,32,19\n",
       "bad.csv: at line 3: box (10, 10)-(32, 19) reaches outside the 32x32 sensor"},
  };
  for (const Case& c : cases) {
    std::ofstream(dir_ + "/bad.csv") << c.text;
    EXPECT_EQ(run_command(eval("--boxes " + dir_ + "/bad.csv --out " + o), &out), 1) << c.text;
    EXPECT_NE(out.find(c.want), std::string::npos) << out;
  }
  EXPECT_EQ(run_command(eval("--boxes " + dir_ + "/missing.csv --out " + o), &out), 1);
  EXPECT_NE(out.find("missing.csv"), std::string::npos) << out;
  // One recording per boxes file.
  EXPECT_EQ(
      run_command(eval("--data " + dir_ + "/ball.txt --boxes " + dir_ + "/boxes.csv --out " + o),
                  &out),
      1);
  EXPECT_NE(out.find("exactly one --data"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(o + "/results.json"));  // nothing written on an error
}

TEST_F(EvalBoxesCli, HelpNamesTheFlag) {
  std::string out;
  ASSERT_EQ(run_command(spikems_binary() + " eval --help", &out), 0) << out;
  EXPECT_NE(out.find("--boxes"), std::string::npos) << out;
  EXPECT_NE(out.find("t_start_us,t_end_us,x0,y0,x1,y1"), std::string::npos) << out;
}

}  // namespace
}  // namespace spikems
