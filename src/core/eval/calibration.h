// `spikems calibrate`: a trained model's operating point chosen on labelled validation data.
// The model is scored at each candidate factor on its output layer's threshold
// (output_threshold.h, through evaluate()), the best factor by a criterion is kept, and the
// model is written with that θ baked in, the choice recorded in its metadata.
#pragma once

#include <string>
#include <vector>

#include "core/eval/evaluation.h"
#include "core/model/model_file.h"

namespace spikems {

struct CalibrationOptions {
  std::string model;
  std::vector<std::string> data;  // labelled sources (simulator folders or recordings)
  std::string split = "val";
  std::vector<double> factors = {0.9, 0.95, 1, 1.05, 1.1, 1.15, 1.2, 1.25, 1.3, 1.4};
  // Output gates to try with every factor (output_gate.h), µs, 0 = off; empty = the model's own.
  std::vector<int64_t> gates_us;
  int64_t window_us = 20000;
  // "event-iou": TP / (TP + FP + FN) over the events of all whole windows (the per-event view
  // `spikems segment` gives; monotone in the event F1); "iou": the paper's mean window IoU;
  // "detection": the paper's detection rate (metrics.h, is_detection); "recall": the share of
  // moving events called moving, which only a static budget keeps from the lowest factor.
  std::string criterion = "event-iou";
  // Static scenes (every event background; simulator folders scored whole, or recordings): each
  // point's share of their events called moving is measured, and only points at or below
  // max_static_moving (percent) may be chosen. Empty = no budget.
  std::vector<std::string> static_data;
  double max_static_moving = 5;
  double max_seconds = 0;
  // > 0: the model is moved to this step (ms), time constants scaled (EvalOptions::time_step_ms),
  // scored there and written with it. 0: its own step.
  double time_step_ms = 0;
  int threads = 1;
  int downsample = 0;  // EvalOptions::downsample (0 = auto)
  // EvalOptions::train_width/height: a training grid for a model that records none; the
  // calibrated model is written with it.
  int train_width = 0, train_height = 0;
  bool progress = false;
  std::string command_line;
};

struct CalibrationPoint {
  double factor = 1;
  int gate_steps = 0;  // the output gate it ran with (the model's own when none was swept)
  double gate_ms = 0;
  double score = 0;  // the criterion, percent (0-100)
  double iou = 0, event_iou = 0, precision = 0, recall = 0, moving = 0, detection = 0;  // percent
  size_t windows = 0;
  double static_moving = -1;  // percent of the static scenes' events called moving; -1 = none
};

struct CalibrationResult {
  std::vector<CalibrationPoint> points;  // by gate, then factor
  size_t best = 0;                       // index into points
  EvalResults eval;                      // the scoring behind them
};

// Scores the model at every factor (and gate) and picks the best by the criterion; ties (within
// 1e-9) go to the factor nearest 1 (in ratio), then to the shorter gate, so a flat curve leaves
// the model as it is. With static scenes, only the points calling at most max_static_moving %
// of their events moving compete. Throws
// Error for an unknown criterion, an empty factor list, data without labels or without a
// scored window (errors of evaluate() included), a budget outside 0-100 or that no point
// meets (naming the lowest share and what to try), or an interrupted run.
CalibrationResult calibrate(const CalibrationOptions& opt);

// The model with the chosen factor (and gate, when gates were swept) applied and
// `training.calibration` recorded: factor, output_gate_ms, criterion, score, data, split, window,
// the per-factor table, command and date. A model calibrated before has its factors multiplied
// (`output_threshold_scale` keeps the product) and the earlier record kept under `previous`.
ModelSpec calibrated_model(const CalibrationOptions& opt, const CalibrationResult& r);

// A table for people: one row per factor, the chosen one marked.
std::string calibration_table(const CalibrationOptions& opt, const CalibrationResult& r);

}  // namespace spikems
