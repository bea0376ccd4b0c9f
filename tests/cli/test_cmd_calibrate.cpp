// `spikems calibrate` on an analytic case: OFF events (moving) and ON events (background), one
// per pixel, through a 1x1 model whose OFF path has weight 1 and ON path 0.5. A lone input
// spike's potential peaks at w (the kernel's peak is 1) against θ = 0.22: OFF events are
// labelled up to a factor 4.5, ON events up to 2.3. So factors 1 and 2 label both (event IoU
// 50 %), 3 and 4 the OFF ones only (100 %), 5 none (0 %): the calibration keeps 3 (the tie
// with 4 goes to the factor nearer 1).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "common/test_paths.h"
#include "common/tiny_models.h"
#include "core/model/model_file.h"

namespace spikems {
namespace {

namespace fs = std::filesystem;
using test::run_command;
using test::scratch_dir;
using test::spikems_binary;

std::string write_lines(const std::string& dir, bool labelled_moving = true) {
  const std::string p = dir + "/lines.txt";
  std::ofstream f(p);
  f << "# sensor 48 16\n";
  for (int t = 0; t < 40; ++t) {
    f << t * 1000 + 100 << " " << t << " 2 0 " << (labelled_moving ? 1 : 0) << "\n";
    f << t * 1000 + 200 << " " << t << " 10 1 0\n";
  }
  return p;
}

TEST(CalibrateCli, KeepsTheFactorWithTheBestEventIoUAndRecordsIt) {
  const std::string d = scratch_dir();
  const std::string model = d + "/m.safetensors", data = write_lines(d);
  save_model(model, test::pointwise_model({1.f, 0.f, 0.f, 0.5f}, "lines"));
  std::string out;
  const std::string cal = d + "/cal.safetensors";
  ASSERT_EQ(run_command(spikems_binary() + " calibrate --quiet --model " + model + " --data " +
                            data + " --factors 1,2,3,4,5 --window 10 --out " + cal,
                        &out),
            0)
      << out;
  // The event columns (event IoU, P, R, moving) of each factor's row; the window IoU column
  // is left out (the output lags a step or two, so some spikes count in the next window).
  auto row = [&](const std::string& factor) {
    const size_t at = out.find("\n| " + factor + " | ");
    if (at == std::string::npos) return std::string("no row");
    const std::string line = out.substr(at + 1, out.find('\n', at + 1) - at - 1);
    return line.substr(line.find(" | ", line.find(" | ") + 3));  // from the event IoU on
  };
  EXPECT_EQ(row("1"), " | 50.0 | 50.0 | 100.0 | 100.0 |  |") << out;
  EXPECT_EQ(row("2"), " | 50.0 | 50.0 | 100.0 | 100.0 |  |") << out;
  EXPECT_EQ(row("3"), " | 100.0 | 100.0 | 100.0 | 50.0 | chosen (event-iou) |") << out;
  EXPECT_EQ(row("4"), " | 100.0 | 100.0 | 100.0 | 50.0 |  |") << out;
  EXPECT_EQ(row("5"), " | 0.0 | 0.0 | 0.0 | 0.0 |  |") << out;
  // By the mean window IoU the same factor wins here (84.5 % against 71.1 % at 4: at 4 the
  // OFF events' spikes come a step later, more of them past their window's end).
  ASSERT_EQ(run_command(spikems_binary() + " calibrate --quiet --model " + model + " --data " +
                            data + " --factors 1,3,4 --window 10 --criterion iou --out " + d +
                            "/by_iou.safetensors",
                        &out),
            0)
      << out;
  EXPECT_NE(out.find("| 3 | 84.5 | 100.0 | 100.0 | 100.0 | 50.0 | chosen (iou) |"),
            std::string::npos)
      << out;
  const ModelSpec m = load_model(cal), base = load_model(model);
  EXPECT_FLOAT_EQ(m.layers[0].neuron.theta, 3 * base.layers[0].neuron.theta);
  EXPECT_EQ(m.layers[0].weight, base.layers[0].weight);
  const auto& c = m.training.at("calibration");
  EXPECT_EQ(c.at("factor").get<double>(), 3.0);
  EXPECT_EQ(c.at("output_threshold_scale").get<double>(), 3.0);
  EXPECT_EQ(c.at("criterion"), "event-iou");
  EXPECT_EQ(c.at("points").size(), 5u);
  EXPECT_EQ(c.at("source_model"), model);
  // Calibrated again: factors 1 and 1.5 (θ 0.66 -> 0.99, still below the OFF peak) tie, so the
  // model stays as it is and the recorded scale is still 3 in all.
  const std::string again = d + "/again.safetensors";
  ASSERT_EQ(run_command(spikems_binary() + " calibrate --quiet --model " + cal + " --data " + data +
                            " --factors 1.5,1 --window 10 --out " + again,
                        &out),
            0)
      << out;
  const ModelSpec m2 = load_model(again);
  EXPECT_FLOAT_EQ(m2.layers[0].neuron.theta, m.layers[0].neuron.theta);
  EXPECT_EQ(m2.training.at("calibration").at("output_threshold_scale").get<double>(), 3.0);
}

TEST(CalibrateCli, BadInputStopsWithAClearMessageAndWritesNothing) {
  const std::string d = scratch_dir();
  const std::string model = d + "/m.safetensors", data = write_lines(d);
  save_model(model, test::pointwise_model({1.f, 0.f, 0.f, 0.5f}, "lines"));
  const std::string o = d + "/never.safetensors";
  auto fails = [&](const std::string& args, const std::string& says) {
    std::string out;
    EXPECT_NE(run_command(spikems_binary() + " calibrate --quiet " + args, &out), 0) << args;
    EXPECT_NE(out.find(says), std::string::npos) << args << "\n" << out;
    EXPECT_FALSE(fs::exists(o)) << args;
  };
  const std::string m = "--model " + model + " --data " + data;
  fails(m + " --out " + model, "is the model itself");
  fails(m + " --criterion f1 --out " + o, "'f1' is not a criterion");
  fails(m + " --factors 1,0 --out " + o, "--factors");
  fails(m + " --window 10,20 --out " + o, "one window length");
  fails(m + " --split dev --out " + o, "'dev' is not a split");
  fails("--model " + d + "/none.safetensors --data " + data + " --out " + o, "none.safetensors");
  // Nothing moves in these data: no window to score.
  const std::string still = d + "/still";
  fs::create_directories(still);
  fails("--model " + model + " --data " + write_lines(still, false) + " --out " + o,
        "no window of the data has moving objects");
  std::string out;
  EXPECT_EQ(run_command(spikems_binary() + " calibrate --help", &out), 0);
  EXPECT_NE(out.find("--criterion"), std::string::npos) << out;
}

}  // namespace
}  // namespace spikems
