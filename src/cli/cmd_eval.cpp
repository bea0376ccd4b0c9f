// `spikems eval`: a model's IoU and detection rate on labelled datasets, per window length, as
// the paper reports them (docs/evaluation.md). Parses the options and calls core/eval.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>

#include "cli/command.h"
#include "core/eval/evaluation.h"
#include "core/eval/window_list.h"
#include "core/model/default_model.h"
#include "core/model/output_gate.h"
#include "core/model/output_threshold.h"
#include "core/util/error.h"
#include "core/util/host_memory.h"
#include "core/util/interrupt.h"

namespace {

using namespace spikems;

struct Args {
  std::string windows = "20,100", split = "test", out, kalman, boxes, thresholds, gates,
              share_bands = "2,10";
  std::vector<std::string> models, data, baselines;
  int threads = 1, group_windows = 1;
  bool iir = false, quiet = false, gate_events = false, static_scene = false;
  double max_seconds = 0, min_moving_share = 0, keep_events = 1, time_step_ms = 0;
  cli::ScaleFlags scale;
};

// "2,10" -> {2, 10}; "none" -> {} (no band rows). Errors name the option and the item.
std::vector<double> parse_share_bands(const std::string& text) {
  if (text == "none") return {};
  std::vector<double> edges;
  size_t start = 0;
  while (start <= text.size()) {
    const size_t comma = std::min(text.find(',', start), text.size());
    const std::string item = text.substr(start, comma - start);
    size_t used = 0;
    double v = 0;
    try {
      v = std::stod(item, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (item.empty() || used != item.size())
      fail("--share-bands", item,
           "not a number: give increasing percentages between 0 and 100, e.g. 2,10 (or none)");
    edges.push_back(v);
    start = comma + 1;
  }
  check_band_edges(edges, "--share-bands");
  return edges;
}

void run(const Args& a) {
  install_interrupt_flag();
  keep_freed_memory();  // freed batches and queues reused: fewer page faults (host_memory.h)
  EvalOptions o;
  // Without --model the shipped default is scored (and any --baseline beside it).
  o.models = a.models.empty() ? std::vector<std::string>{default_model_or_fail()} : a.models;
  for (std::string& m : o.models) m = resolve_model(m);
  o.baselines = a.baselines;
  cli::check_split(a.split);
  if (a.max_seconds < 0) fail("--max-seconds", "", "must be positive");
  o.data = a.data;
  o.split = a.split;
  o.windows_us = parse_window_list_ms(a.windows);
  if (!a.kalman.empty()) o.kalman_us = parse_window_list_ms(a.kalman);
  if (!a.thresholds.empty())
    o.output_thresholds = parse_threshold_scales(a.thresholds, "--output-thresholds");
  if (!a.gates.empty()) o.output_gates_us = parse_gate_list_ms(a.gates, "--output-gates");
  o.threads = a.threads;
  o.downsample = a.scale.factor();
  std::tie(o.train_width, o.train_height) = a.scale.grid();
  o.iir = a.iir;
  if (!(std::isfinite(a.time_step_ms) && a.time_step_ms >= 0))
    fail("--time-step-ms", "", "must be a positive number of ms, e.g. 5 (0 = each model's own)");
  o.time_step_ms = a.time_step_ms;
  o.gate_events = a.gate_events;
  o.boxes = a.boxes;
  o.static_scene = a.static_scene;
  o.share_bands_pct = parse_share_bands(a.share_bands);
  o.min_moving_share_pct = a.min_moving_share;
  o.group_windows = a.group_windows;
  o.keep_events = a.keep_events;
  o.max_seconds = a.max_seconds;
  o.progress = !a.quiet;
  o.command_line = cli::invoked_command();
  // With --out, a few windows per sequence are kept from the same pass for report.html.
  EvalExamples examples;
  const EvalResults r = evaluate(o, a.out.empty() ? nullptr : &examples);
  if (!a.out.empty()) {
    write_results(r, a.out);
    write_report(r, examples, a.out);
  }
  std::fputs(results_table(r).c_str(), stdout);
  const std::string bands = band_results_table(r);
  if (!bands.empty())
    std::printf(
        "\nBy the moving share of the windows' events (docs/evaluation.md, \"Size "
        "bands\"):\n%s",
        bands.c_str());
  std::fflush(stdout);
  if (r.interrupted)
    std::fprintf(stderr, "spikems eval: interrupted; the results hold the sequences finished\n");
  if (!a.out.empty() && !a.quiet)
    std::fprintf(stderr, "results in %s/results.{json,csv,md}, report in %s/report.html\n",
                 a.out.c_str(), a.out.c_str());
}

void add(CLI::App& app) {
  static Args a;
  auto* cmd = app.add_subcommand(
      "eval", "Score a model on labelled data: IoU and detection rate per window length");
  cmd->footer(
      "Each sequence runs once through the streaming network (whole sensor, state kept from "
      "its first event) and is scored for every window length: P = pixels with output spikes "
      "at steps starting in the window, G = pixels with moving-object events; windows start at "
      "the first event, the partial last one is dropped, windows without moving objects are "
      "skipped. Event precision and recall: the events the runtime labels moving against "
      "their labels. With --boxes FILE (one recording, labels not needed), G = the pixels "
      "inside the boxes valid in the window and an event is moving when it lies in a box valid "
      "at its time. See docs/evaluation.md.\n\n"
      "Examples:\n"
      "  spikems eval --model m.safetensors --data data/mod --out eval-out\n"
      "  spikems eval --model fast --data data/mod --split all --min-moving-share 50 "
      "--group-windows 8   (the SpikeMS authors' protocol)\n"
      "  spikems eval --model a.safetensors --model b.safetensors --baseline all-events --data "
      "data/mod --windows 10,20,100 --max-seconds 0.5   (several models on the same windows)");
  cmd->add_option("--model", a.models,
                  "Model file (.safetensors, spikems format) or a shipped model's name (default "
                  "or fast); repeat to compare several (default: the shipped default model)");
  cmd->add_option("--baseline", a.baselines,
                  "Also score a baseline on the same windows: all-events (every pixel with an "
                  "event predicted moving); repeatable")
      ->check(CLI::IsMember({"all-events"}));
  cmd->add_option("--data", a.data,
                  "Labelled data: a `spikems simulate` folder (manifest.json) or a labelled "
                  "event file; repeat for several");
  cmd->add_option("--split", a.split, "Split of simulator folders: train, val, test or all")
      ->capture_default_str();
  cmd->add_option("--windows", a.windows,
                  "Window lengths in ms, comma-separated; ranges FROM:TO[:STEP] (1:25 = 1..25)")
      ->capture_default_str();
  cmd->add_option("--kalman", a.kalman,
                  "(experimental) Also score these window lengths (ms, as --windows) with each "
                  "window's prediction filtered by a constant-velocity Kalman filter per object: "
                  "the 'filtered' rows (e.g. --kalman 3)");
  cmd->add_option("--out", a.out,
                  "Folder for results.json, results.csv, results.md and report.html (with "
                  "plots/*.svg and windows/*.png)");
  cmd->add_option("--output-thresholds", a.thresholds,
                  "Score each model at these factors on its output layer's threshold (e.g. "
                  "1,1.1,1.2,1.3): a row per factor and a precision-recall plot in the report");
  cmd->add_option("--output-gates", a.gates,
                  "Score each model with these output gates (ms, 0 = none; e.g. 0,10,20): an "
                  "output spike counts only where its pixel had an input event that recently "
                  "(docs/model-format.md, \"Output gate\"); a row per gate (and factor)");
  cmd->add_option("--threads", a.threads,
                  "Threads inside the network (the layers of a step run in parallel)")
      ->check(CLI::Range(1, 256));
  cli::add_scale_flags(cmd, a.scale);
  cmd->add_option("--boxes", a.boxes,
                  "Ground truth from bounding boxes (CSV: t_start_us,t_end_us,x0,y0,x1,y1[,id]; "
                  "corners inclusive) for the one recording given with --data, which then needs "
                  "no labels");
  cmd->add_flag("--static-scene", a.static_scene,
                "Every event of --data is background (a static scene filmed by a moving "
                "camera; labels not needed, any ignored): read the share of events labelled "
                "moving, column `moving %` (a false-positive check on real recordings)");
  cmd->add_flag("--gate-events", a.gate_events,
                "Count predictions only at pixels with input events in the window (P ∩ E, as "
                "per-event labels do; ANN-2D models are gated by construction)");
  cmd->add_option("--share-bands", a.share_bands,
                  "Also report IoU and detection per band of windows split by the share of "
                  "their input events that are truly moving (percent edges; small objects or "
                  "dense texture give low shares); none = no bands")
      ->capture_default_str();
  cmd->add_option("--min-moving-share", a.min_moving_share,
                  "Score only windows in which at least PCT % of the input events are truly "
                  "moving; the others are counted as `filtered`. 50 is the SpikeMS authors' "
                  "test filter on MOD (test.py --maxBackgroundRatio 2: at most 2 events per "
                  "moving event), 33.3 on EV-IMO (2 background events per moving one); "
                  "docs/evaluation.md, \"The authors' window filter\"");
  cmd->add_option("--group-windows", a.group_windows,
                  "Score windows in groups of N consecutive ones: IoU and detection of the "
                  "unions of P and G over a group's scored windows, counted once per window. "
                  "8 with --min-moving-share 50 is the SpikeMS authors' whole test (an IoU "
                  "over each batch of 8 samples); 1 = each window alone")
      ->capture_default_str();
  cmd->add_option("--keep-events", a.keep_events,
                  "Thin every sequence first, keeping each event with probability F (a fixed "
                  "seed: the same events every run), labels and all: how a model holds up when "
                  "a sensor gives fewer events (higher contrast threshold, slower motion)")
      ->capture_default_str();
  cmd->add_option("--time-step-ms", a.time_step_ms,
                  "(experimental) Run every model at this step (ms) with its time constants "
                  "scaled by the same ratio, so each step behaves as trained with more time and "
                  "events in it: fewer steps, a faster network, outputs close to the model's own "
                  "(0 = each model's own step; docs/evaluation.md, \"Coarser time steps\")");
  cmd->add_flag("--iir", a.iir,
                "Run FIR layers with the exact recursions of the same neurons (faster; spikes "
                "close to but not identical with the FIR model)");
  cmd->add_option("--max-seconds", a.max_seconds,
                  "Score only the first S seconds of each sequence (quick checks)");
  cmd->add_flag("--quiet", a.quiet, "No progress bar or notes on stderr");
  cmd->callback([] { run(a); });
}

}  // namespace

SPIKEMS_COMMAND(eval, 45, add);
