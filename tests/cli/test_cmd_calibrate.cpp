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

// The row of a printed calibration table that starts with `key` ("3", or "3 | 5" with
// gates), from its `skip`-th cell separator on ("no row" when absent).
std::string row_from(const std::string& out, const std::string& key, int skip) {
  const size_t at = out.find("\n| " + key + " | ");
  if (at == std::string::npos) return "no row";
  const std::string line = out.substr(at + 1, out.find('\n', at + 1) - at - 1);
  size_t p = 0;
  for (int i = 0; i < skip; ++i) p = line.find(" | ", p) + 3;
  return line.substr(p - 3);
}

// The analytic case in a scratch folder: the model (OFF weight 1, ON 0.5) and the lines.
struct LinesCase {
  std::string dir = scratch_dir(), model = dir + "/m.safetensors", data = write_lines(dir);
  LinesCase() { save_model(model, test::pointwise_model({1.f, 0.f, 0.f, 0.5f}, "lines")); }
  // `spikems calibrate --quiet` on it with `args`; its output in `out`.
  int calibrate(const std::string& args, std::string& out) const {
    return run_command(
        spikems_binary() + " calibrate --quiet --model " + model + " --data " + data + " " + args,
        &out);
  }
};

TEST(CalibrateCli, KeepsTheFactorWithTheBestEventIoUAndRecordsIt) {
  const LinesCase lc;
  const std::string &d = lc.dir, &model = lc.model, &data = lc.data;
  std::string out;
  const std::string cal = d + "/cal.safetensors";
  ASSERT_EQ(lc.calibrate("--factors 1,2,3,4,5 --window 10 --out " + cal, out), 0) << out;
  // The event columns (event IoU, P, R, moving) of each factor's row; the window IoU and
  // detection columns are left out (the output lags a step or two, so some spikes count in the
  // next window).
  auto row = [&](const std::string& factor) { return row_from(out, factor, 3); };
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
  EXPECT_NE(out.find("| 3 | 84.5 | 100.0 | 100.0 | 100.0 | 100.0 | 50.0 | chosen (iou) |"),
            std::string::npos)
      << out;
  // Detection (over half of the moving pixels, and more of them than false ones): factor 1 calls
  // as many background pixels as moving ones, none detected; 3 and 4
  // detect every window and tie, 3 is nearer 1. Recall: 1, 3 and 4 all call every moving event
  // moving, so the factor nearest 1 wins, background calls and all.
  auto chosen_by = [&](const std::string& criterion) {
    const std::string o = d + "/by_" + criterion + ".safetensors";
    EXPECT_EQ(
        run_command(spikems_binary() + " calibrate --quiet --model " + model + " --data " + data +
                        " --factors 1,3,4 --window 10 --criterion " + criterion + " --out " + o,
                    &out),
        0)
        << out;
    return load_model(o).training.at("calibration").at("factor").get<double>();
  };
  EXPECT_EQ(chosen_by("detection"), 3.0) << out;
  EXPECT_NE(out.find("| 1 | 38.0 | 0.0 | 50.0 |"), std::string::npos) << out;
  EXPECT_EQ(chosen_by("recall"), 1.0) << out;
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
  // The first calibration's record is kept inside the second's.
  EXPECT_EQ(m2.training.at("calibration").at("previous").at("factor").get<double>(), 3.0);
  EXPECT_EQ(m2.training.at("calibration").at("previous").at("points").size(), 5u);
}

// --time-step-ms: the model is moved to that step with its time constants scaled (time_step.h),
// scored there, and written with that step, the file's own step recorded.
TEST(CalibrateCli, TimeStepMsWritesTheModelAtThatStep) {
  const LinesCase lc;
  std::string out;
  const std::string cal = lc.dir + "/at2.safetensors";
  ASSERT_EQ(lc.calibrate("--factors 1,3 --window 10 --time-step-ms 2 --out " + cal, out), 0) << out;
  const ModelSpec m = load_model(cal), base = load_model(lc.model);
  EXPECT_DOUBLE_EQ(m.time_step_ms, 2);
  EXPECT_FLOAT_EQ(m.layers[0].neuron.tau_s, 2 * base.layers[0].neuron.tau_s);
  EXPECT_FLOAT_EQ(m.layers[0].neuron.tau_r, 2 * base.layers[0].neuron.tau_r);
  EXPECT_EQ(m.training.at("calibration").at("source_time_step_ms").get<double>(),
            base.time_step_ms);
  // Bad values stop before anything is written.
  for (const char* bad : {"-2", "inf"}) {
    const std::string o = lc.dir + "/bad.safetensors";
    EXPECT_NE(lc.calibrate(std::string("--time-step-ms ") + bad + " --out " + o, out), 0) << bad;
    EXPECT_NE(out.find("--time-step-ms"), std::string::npos) << out;
    EXPECT_FALSE(std::filesystem::exists(o));
  }
}

// --gates: each output gate with each factor. The model answers an event a step or more after
// it, at its pixel, and no pixel sees a second event, so a 1 ms gate (the output's own step)
// drops every output (event IoU 0 at any factor), while 5 ms covers the steps labels are read
// from (latency + 3) and scores as no gate does. With gates 1 and 5 the pair (3, 5 ms) wins and
// the model is written with that gate; with 0 and 5 they tie and the shorter, none, is kept.
TEST(CalibrateCli, GatesAreTriedWithEveryFactorAndTheBestPairKept) {
  const LinesCase lc;
  const std::string &d = lc.dir, &data = lc.data;
  std::string out;
  const std::string cal = d + "/cal.safetensors";
  ASSERT_EQ(lc.calibrate("--factors 1,3 --gates 5,1 --window 10 --out " + cal, out), 0) << out;
  auto row = [&](const std::string& factor_gate) {  // from the event IoU on
    return row_from(out, factor_gate, 4);
  };
  EXPECT_NE(out.find("| factor | gate ms |"), std::string::npos) << out;
  EXPECT_EQ(row("1 | 1"), " | 0.0 | 0.0 | 0.0 | 0.0 |  |") << out;
  EXPECT_EQ(row("3 | 1"), " | 0.0 | 0.0 | 0.0 | 0.0 |  |") << out;
  EXPECT_EQ(row("1 | 5"), " | 50.0 | 50.0 | 100.0 | 100.0 |  |") << out;
  EXPECT_EQ(row("3 | 5"), " | 100.0 | 100.0 | 100.0 | 50.0 | chosen (event-iou) |") << out;
  const ModelSpec m = load_model(cal);
  EXPECT_EQ(m.output_gate_steps, 5);
  const auto& c = m.training.at("calibration");
  EXPECT_EQ(c.at("factor").get<double>(), 3.0);
  EXPECT_EQ(c.at("output_gate_ms").get<double>(), 5.0);
  ASSERT_EQ(c.at("points").size(), 4u);
  EXPECT_EQ(c.at("points")[0].at("output_gate_ms").get<double>(), 1.0);  // by gate, then factor
  ASSERT_EQ(
      lc.calibrate("--factors 3 --gates 5,0 --window 10 --out " + d + "/tie.safetensors", out), 0)
      << out;
  EXPECT_EQ(row("3 | 0"), " | 100.0 | 100.0 | 100.0 | 50.0 | chosen (event-iou) |") << out;
  EXPECT_EQ(load_model(d + "/tie.safetensors").output_gate_steps, 0);
  // Calibrated again without --gates: the gate stays.
  ASSERT_EQ(run_command(spikems_binary() + " calibrate --quiet --model " + cal + " --data " + data +
                            " --factors 1 --window 10 --out " + d + "/again.safetensors",
                        &out),
            0)
      << out;
  EXPECT_EQ(load_model(d + "/again.safetensors").output_gate_steps, 5);
}

// --static with --max-static-moving: a budget of false calls on scenes where nothing moves.
// Here both polarities move (factors 1 and 2 label both: event IoU 100 %; 3 and 4 the OFF
// events only: 50 %; 5 none), and the static scene holds ON events alone, which factors 1 and 2
// call moving (100 %) and 3-5 do not (0 %). Without the budget factor 1 wins; with 5 % only
// 3-5 may be chosen and 3 is kept. A budget no factor meets is refused, naming the lowest.
TEST(CalibrateCli, StaticScenesBudgetLimitsTheChoice) {
  const LinesCase lc;
  const std::string& d = lc.dir;
  const std::string moving = d + "/both_moving.txt", still = d + "/still_on.txt";
  {
    std::ofstream f(moving), g(still);
    f << "# sensor 48 16\n";
    g << "# sensor 48 16\n";
    for (int t = 0; t < 40; ++t) {
      f << t * 1000 + 100 << " " << t << " 2 0 1\n";
      f << t * 1000 + 200 << " " << t << " 10 1 1\n";
      g << t * 1000 + 200 << " " << t << " 10 1 0\n";
    }
  }
  const std::string base = spikems_binary() + " calibrate --quiet --model " + lc.model +
                           " --data " + moving + " --window 10 ";
  const std::string all = "--factors 1,2,3,4,5 ";
  std::string out;
  ASSERT_EQ(run_command(base + all + "--out " + d + "/free.safetensors", &out), 0) << out;
  EXPECT_NE(out.find("| 1 | "), std::string::npos) << out;
  EXPECT_NE(out.find(" | 100.0 | 100.0 | 100.0 | 100.0 | chosen (event-iou) |"), std::string::npos)
      << out;
  EXPECT_EQ(load_model(d + "/free.safetensors").training.at("calibration").at("factor"), 1.0);

  const std::string cal = d + "/budget.safetensors";
  ASSERT_EQ(
      run_command(base + all + "--static " + still + " --max-static-moving 5 --out " + cal, &out),
      0)
      << out;
  EXPECT_NE(out.find("| event R % | moving % | static moving % | |"), std::string::npos) << out;
  auto tail = [&](const std::string& factor) {  // the moving, static and choice columns
    return row_from(out, factor, 6);
  };
  EXPECT_EQ(tail("1"), " | 100.0 | 100.0 (over) |  |") << out;
  EXPECT_EQ(tail("2"), " | 100.0 | 100.0 (over) |  |") << out;
  EXPECT_EQ(tail("3"), " | 50.0 | 0.0 | chosen (event-iou) |") << out;
  EXPECT_EQ(tail("5"), " | 0.0 | 0.0 |  |") << out;
  const ModelSpec m = load_model(cal), b = load_model(lc.model);
  EXPECT_FLOAT_EQ(m.layers[0].neuron.theta, 3 * b.layers[0].neuron.theta);
  const auto& c = m.training.at("calibration");
  EXPECT_EQ(c.at("factor").get<double>(), 3.0);
  EXPECT_EQ(c.at("max_static_moving").get<double>(), 5.0);
  EXPECT_EQ(c.at("static_moving").get<double>(), 0.0);
  EXPECT_EQ(c.at("static_data").at(0), still);
  ASSERT_EQ(c.at("points").size(), 5u);
  EXPECT_EQ(c.at("points")[0].at("static_moving").get<double>(), 100.0);

  const std::string o = d + "/never.safetensors";
  EXPECT_NE(run_command(base + "--factors 1,2 --static " + still + " --out " + o, &out), 0);
  EXPECT_NE(
      out.find("no factor calls at most 5 % of the static scenes moving (the lowest: 100.0 %"),
      std::string::npos)
      << out;
  EXPECT_NE(run_command(base + all + "--max-static-moving 5 --out " + o, &out), 0);
  EXPECT_NE(out.find("give them with --static"), std::string::npos) << out;
  EXPECT_NE(
      run_command(base + all + "--static " + still + " --max-static-moving 150 --out " + o, &out),
      0);
  EXPECT_NE(out.find("between 0 and 100"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(o));
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
  fails(m + " --criterion f1 --out " + o,
        "'f1' is not a criterion: use event-iou, iou, detection or recall");
  fails(m + " --factors 1,0 --out " + o, "--factors");
  fails(m + " --window 10,20 --out " + o, "one window length");
  fails(m + " --split dev --out " + o, "'dev' is not a split");
  fails(m + " --gates 0,-1 --out " + o, "--gates");
  fails(m + " --gates 0.5 --out " + o, "whole number");
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
