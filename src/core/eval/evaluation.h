// `spikems eval` as a library call: one model over labelled datasets (simulator folders with
// their splits, or labelled recordings), each sequence run once through the streaming
// Segmenter and scored for every window length (sequence_scorer.h), pooled per dataset
// (results.h).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/eval/report.h"
#include "core/eval/results.h"

namespace spikems {

struct EvalOptions {
  std::string model_path;           // one model (kept for callers that score one)
  std::vector<std::string> models;  // several models, scored on the same sequences after it
  // Baselines scored beside the models: "all-events" (P = every pixel with an event; a
  // network that cannot tell motion apart scores this). See baseline_scorer.h.
  std::vector<std::string> baselines;
  std::vector<std::string> data;  // simulator folders (manifest.json) or labelled files
  std::string split = "test";     // simulator folders: train, val, test or all
  std::vector<int64_t> windows_us = {20000, 100000};
  // Window lengths also scored through the Kalman filter (kalman_filter.h): "filtered" rows.
  std::vector<int64_t> kalman_us;
  // Output-threshold factors (output_threshold.h): every model is scored once per factor, a
  // row each; empty = {1}, the model as trained. Two or more trace a precision-recall curve.
  std::vector<double> output_thresholds;
  // Output gates (output_gate.h), µs, 0 = off: every model is also scored once per gate (and
  // factor), a row each; empty = each model's own gate.
  std::vector<int64_t> output_gates_us;
  int threads = 1;  // threads inside the network
  // Each model sees each sequence downsampled by this factor, scored on its grid
  // (SequenceScoreOptions::downsample); 0 = auto: the factor nearest the model's training grid.
  int downsample = 0;
  // > 0: the training grid of models that record none (ModelSpec::train_width/height; a model
  // trained before spikems recorded it), for auto downsampling. 0: as the files say.
  int train_width = 0, train_height = 0;
  bool iir = false;  // run FIR layers as their exact IIR recursions
  // > 0: every model runs at this step (ms), its time constants scaled so each step behaves
  // as trained (core/model/time_step.h, "steps"): fewer steps, a faster network. 0: its own.
  double time_step_ms = 0;
  bool gate_events =
      false;  // P ∩ E: predictions count only at pixels with events (window_scorer.h)
  // A boxes file (boxes.h): G = box pixels and events moving when inside a valid box, for
  // one recording (one --data with one sequence); its events then need no labels.
  std::string boxes;
  // Every event of the data is background (a static scene filmed by a moving camera): labels
  // are not needed (any are ignored) and the score is the share of events labelled moving.
  bool static_scene = false;
  // Edges (percent, increasing, in (0, 100)) splitting the scored windows by the share of
  // their input events that are truly moving: a row of results per band (results.h); {} = none.
  std::vector<double> share_bands_pct = kDefaultShareBandsPct;
  // > 0: only windows in which at least this percent of the input events are truly moving are
  // scored (the SpikeMS authors' test filter; WindowScorer::min_moving_share); the others are
  // counted as filtered. Needs labels: refused with boxes and static scenes.
  double min_moving_share_pct = 0;
  // > 1: windows scored in groups of so many consecutive ones, P and G the unions over the
  // group's kept windows, its IoU weighted by them (the SpikeMS authors' test, with 8;
  // WindowScorer::group_windows). Refused with static scenes.
  int group_windows = 1;
  // < 1: each sequence is thinned first, every event kept with this probability
  // (thin_events, seed 0: the same events on every run), labels and all: how the scores hold
  // up when a sensor gives fewer events. 1 = every event.
  double keep_events = 1;
  double max_seconds = 0;    // > 0: only the first max_seconds of each sequence
  bool progress = false;     // progress bar on stderr
  std::string command_line;  // recorded in the results
  // Windows shown in report.html (filled only when evaluate() gets an EvalExamples): so many
  // per sequence, for the first example_sequences sequences of each dataset.
  int example_windows = 3;
  int example_sequences = 8;
};

// Loads the models and checks the windows and every data source before the first sequence
// runs; Ctrl-C (when util/interrupt.h's flag is installed) stops at the next chunk and returns
// the sequences finished so far, marked interrupted. Throws Error naming the file and what to
// do: unreadable or invalid model, a window that is not a multiple of the model's step, a
// missing path, an empty or unknown split, a sequence without labels; with boxes, an invalid
// boxes file (file:line) or more than one sequence.
// With `examples`, also keeps a few windows per sequence for the report (report.h), captured
// in the same scoring pass.
EvalResults evaluate(const EvalOptions& opt, EvalExamples* examples = nullptr);

}  // namespace spikems
