// `spikems calibrate`: choose a model's output threshold on labelled validation data and write
// the model with it (core/eval/calibration.h). Parses the options and calls the core.
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "cli/command.h"
#include "core/eval/calibration.h"
#include "core/eval/window_list.h"
#include "core/model/default_model.h"
#include "core/model/output_gate.h"
#include "core/model/output_threshold.h"
#include "core/util/error.h"
#include "core/util/host_memory.h"
#include "core/util/interrupt.h"

namespace {

using namespace spikems;
namespace fs = std::filesystem;

struct Args {
  std::string model, out, split = "val", factors, gates, window = "20", criterion = "event-iou";
  std::vector<std::string> data, static_data;
  double max_seconds = 0, max_static_moving = 5, time_step_ms = 0;
  bool budget_given = false;
  int threads = 1;
  bool quiet = false;
  cli::ScaleFlags scale;
};

void run(const Args& a) {
  install_interrupt_flag();
  keep_freed_memory();  // freed batches and queues reused: fewer page faults (host_memory.h)
  CalibrationOptions o;
  o.model = resolve_model(a.model);
  o.data = a.data;
  cli::check_split(a.split);
  o.split = a.split;
  if (!a.factors.empty()) o.factors = parse_threshold_scales(a.factors, "--factors");
  if (!a.gates.empty()) o.gates_us = parse_gate_list_ms(a.gates, "--gates");
  const std::vector<int64_t> w = parse_window_list_ms(a.window);
  if (w.size() != 1) fail("--window", "", "give one window length (ms), e.g. 20");
  o.window_us = w[0];
  o.criterion = a.criterion;
  if (a.budget_given && a.static_data.empty())
    fail("--max-static-moving", "",
         "is a budget on static scenes: give them with --static (e.g. a simulated `poster` "
         "folder)");
  o.static_data = a.static_data;
  o.max_static_moving = a.max_static_moving;
  if (a.max_seconds < 0) fail("--max-seconds", "", "must be positive");
  o.max_seconds = a.max_seconds;
  o.threads = a.threads;
  o.downsample = a.scale.factor();
  std::tie(o.train_width, o.train_height) = a.scale.grid();
  if (!(std::isfinite(a.time_step_ms) && a.time_step_ms >= 0))
    fail("--time-step-ms", "", "must be a positive number of ms, e.g. 5 (0 = the model's own)");
  o.time_step_ms = a.time_step_ms;
  o.progress = !a.quiet;
  o.command_line = cli::invoked_command();
  std::error_code ec;
  if (fs::equivalent(a.model, a.out, ec))
    fail("--out " + a.out, "", "is the model itself: write the calibrated model to a new file");
  const CalibrationResult r = calibrate(o);
  save_model(a.out, calibrated_model(o, r));
  std::fputs(calibration_table(o, r).c_str(), stdout);
  std::fflush(stdout);
  if (!a.quiet) {
    const CalibrationPoint& b = r.points[r.best];
    std::fprintf(stderr, "wrote %s: output threshold x %g, output gate %g ms (%s %.1f %%",
                 a.out.c_str(), b.factor, b.gate_ms, o.criterion.c_str(), b.score);
    if (!o.static_data.empty())
      std::fprintf(stderr, "; static scenes called moving %.1f %% of at most %g %%",
                   b.static_moving, o.max_static_moving);
    std::fputs(")\n", stderr);
  }
}

void add(CLI::App& app) {
  static Args a;
  auto* cmd = app.add_subcommand(
      "calibrate", "Choose a model's output threshold on labelled validation data and save it");
  cmd->footer(
      "The model is scored (as `spikems eval` scores it) with its output layer's threshold "
      "multiplied by each factor; the factor with the best criterion is kept (ties: the one "
      "nearest 1) and the model is written with that threshold, the choice and the per-factor "
      "table in its metadata (training.calibration). Calibrate on validation data, never on "
      "the data you report. With --gates, each output gate (docs/model-format.md, \"Output "
      "gate\") is tried with every factor and the best pair kept. With --static, scenes where "
      "nothing moves are scored at every point too, and only points that call at most "
      "--max-static-moving % of their events moving compete: an operating point with a budget "
      "of false calls on camera motion. See docs/evaluation.md, \"Operating points\".\n\n"
      "Examples:\n"
      "  spikems calibrate --model my-run/best.safetensors --data data/mod-val --split all "
      "--out calibrated.safetensors\n"
      "  spikems calibrate --model m.safetensors --data data/mod-val --split all --static "
      "data/static-val --max-static-moving 5 --gates 0,10 --out m-cal.safetensors");
  cmd->add_option("--model", a.model,
                  "The model file to calibrate (or a shipped model's name: default or fast)")
      ->required();
  cmd->add_option("--data", a.data,
                  "Labelled validation data: simulator folders or recordings (repeat for more)")
      ->required();
  cmd->add_option("--split", a.split, "Split of simulator folders: train, val, test or all")
      ->capture_default_str();
  cmd->add_option("--factors", a.factors,
                  "Factors on the output threshold to try, comma-separated (default "
                  "0.9,0.95,1,1.05,1.1,1.15,1.2,1.25,1.3,1.4)");
  cmd->add_option("--gates", a.gates,
                  "Output gates to try with every factor, ms (0 = none; e.g. 0,10,20,30): an "
                  "output spike counts only where its pixel had an input event that recently; the "
                  "best pair is kept (default: the model's own gate)");
  cmd->add_option("--criterion", a.criterion,
                  "event-iou: TP/(TP+FP+FN) over all events of the windows (per-event labels); "
                  "iou: the mean window IoU; detection: the paper's detection rate; "
                  "recall: the share of moving events called moving (with --static: the most "
                  "recall the static budget allows)")
      ->capture_default_str();
  cmd->add_option("--window", a.window, "Window length in ms for the scores")
      ->capture_default_str();
  cmd->add_option("--static", a.static_data,
                  "Static scenes (every event background: simulator folders, all their "
                  "sequences, or recordings; repeat for more): each point's share of their "
                  "events called moving is measured and limited by --max-static-moving");
  cmd->add_option("--max-static-moving", a.max_static_moving,
                  "With --static: the most of the static scenes' events a chosen point may call "
                  "moving, percent")
      ->capture_default_str()
      ->each([](const std::string&) { a.budget_given = true; });
  cmd->add_option("--out", a.out, "Where to write the calibrated model (a new file)")->required();
  cmd->add_option("--max-seconds", a.max_seconds,
                  "Score only the first S seconds of each sequence");
  cmd->add_option("--time-step-ms", a.time_step_ms,
                  "(experimental) Move the model to this step (ms), its time constants scaled by "
                  "the same ratio (each step behaves as trained, with more time and events in it: "
                  "a faster network), calibrate it there and write it with that step (0 = its "
                  "own)");
  cmd->add_option("--threads", a.threads, "Threads inside the network (results identical)")
      ->capture_default_str();
  cli::add_scale_flags(cmd, a.scale);
  cmd->add_flag("--quiet", a.quiet, "No progress bar or notes on stderr");
  cmd->callback([] { run(a); });
}

}  // namespace

SPIKEMS_COMMAND(calibrate, 46, add);
