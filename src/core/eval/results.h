// Evaluation results (`spikems eval`): per model, per dataset, per window length, pooled over
// every scored window of every sequence, plus per-sequence rows; written as results.json
// (schema in docs/evaluation.md), results.csv and results.md. Percentages are 0-100.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/eval/metrics.h"
#include "core/eval/sequence_scorer.h"

namespace spikems {

// The scored windows whose moving share (the fraction of their input events that are truly
// moving: how much of what the camera sees is the objects) lies in [lo_pct, hi_pct), the last
// band including 100. Object size decides these scores more than anything else
// (docs/evaluation.md, "Size bands"), so they come per band as COCO's come per object area.
struct BandSummary {
  double lo_pct = 0, hi_pct = 100;
  size_t windows = 0;
  double iou_mean = 0, iou_std = 0, detection_rate = 0;  // percent; meaningless if windows == 0
};

// "< 2 %", "2-10 %", "≥ 10 %": a band's name in tables and plots.
std::string band_name(const BandSummary& b);

// The default band edges, percent: < 2 %, 2-10 %, >= 10 % of a window's events moving.
inline const std::vector<double> kDefaultShareBandsPct = {2, 10};

struct WindowSummary {
  int64_t window_us = 0;
  size_t windows = 0;   // scored windows (G not empty)
  size_t skipped = 0;   // windows without moving-object events
  size_t filtered = 0;  // windows with moving events left out by the moving-share filter
  size_t sequences = 0;
  // Over the scored windows, in percent; meaningless (and written as null) when windows == 0.
  double iou_mean = 0, iou_std = 0, detection_rate = 0;
  bool kalman = false;  // a `--kalman` row: predictions filtered (kalman_filter.h)
  // Events of the whole windows (scored and skipped), summed; none on Kalman rows.
  bool has_events = false;
  EventCounts events;
  // One per band of the edges given to summarize(); empty when no scored window's moving
  // share is known (boxes as truth, static scenes) or no edges were given.
  std::vector<BandSummary> bands;
};

// Pools the windows of several sequences (one WindowScores each): IoU mean and population
// standard deviation over all their scored windows, detections over all of them.
// The event counts (optional: empty or one per part) are summed. band_edges_pct: increasing
// edges in (0, 100) splitting the windows by moving share (BandSummary); {} = no bands.
WindowSummary summarize(int64_t window_us, const std::vector<const WindowScores*>& parts,
                        const std::vector<const EventCounts*>& events = {},
                        const std::vector<double>& band_edges_pct = kDefaultShareBandsPct);

// Throws Error, naming `source` (e.g. the option that gave them), unless the edges are
// strictly increasing and inside (0, 100).
void check_band_edges(const std::vector<double>& edges_pct,
                      const std::string& source = "share bands");
// The bands the edges make, empty: lo_pct / hi_pct set, no windows (edges checked).
std::vector<BandSummary> bands_of(const std::vector<double>& edges_pct);

struct SequenceResult {
  std::string name;
  uint64_t events = 0;
  double duration_s = 0;               // the span scored
  std::vector<WindowSummary> windows;  // one per window length, then one per Kalman length
};

struct DatasetResult {
  std::string data;   // the --data path as given
  std::string split;  // "" for a single recording (no splits)
  uint64_t events = 0;
  std::vector<WindowSummary> windows;  // pooled over the sequences (as SequenceResult)
  std::vector<SequenceResult> sequences;
};

DatasetResult dataset_result(std::string data, std::string split,
                             const std::vector<SequenceScore>& sequences,
                             const std::vector<double>& band_edges_pct = kDefaultShareBandsPct);

struct ModelResult {
  std::string path, name;
  double time_step_ms = 1;
  bool iir = false;  // FIR layers run as IIR recursions (--iir)
  // Run at another step than its file's, time constants scaled (EvalOptions::time_step_ms).
  bool time_step_scaled = false;
  // The factor on the output layer's θ (EvalOptions::output_thresholds); 1 = as trained.
  double output_threshold = 1;
  // The output gate it ran with (ModelSpec::output_gate_steps, its own or EvalOptions'), steps.
  int output_gate_steps = 0;
  // The resolution it ran at (EvalOptions::downsample): 1, 2, 4 or 8 on every sequence, 0 =
  // several (auto on sensors of different sizes).
  int downsample = 1;
  std::vector<DatasetResult> datasets;
};

struct EvalResults {
  std::string command_line;
  std::string date;  // UTC, ISO 8601
  std::string working_directory;
  double max_seconds = 0;    // 0: whole sequences
  bool interrupted = false;  // Ctrl-C: the sequences finished so far
  std::vector<int64_t> windows_us;
  std::vector<int64_t> kalman_us;  // --kalman lengths
  int label_tolerance_steps = 3;   // the runtime's label window beyond its latency
  bool gate_events = false;        // P ∩ E (EvalOptions::gate_events)
  std::string boxes;               // the boxes file giving G (EvalOptions::boxes); "" if none
  bool static_scene = false;       // every event background (EvalOptions::static_scene)
  std::vector<double> share_bands_pct = kDefaultShareBandsPct;  // EvalOptions::share_bands_pct
  double min_moving_share_pct = 0;  // EvalOptions::min_moving_share_pct; 0 = every window
  int group_windows = 1;            // EvalOptions::group_windows; 1 = each window alone
  double keep_events = 1;           // EvalOptions::keep_events; 1 = every event
  std::vector<ModelResult> models;
};

std::string utc_now_iso8601();

// Keys in the documented order (docs/evaluation.md), for people reading the file.
nlohmann::ordered_json results_json(const EvalResults& r);
std::string results_csv(const EvalResults& r);
// A table as text cells. results.md, the printed table and report.html all take their tables
// from summary_table and sequence_table, so a column added there shows everywhere.
struct TextTable {
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
};
// One row per model, dataset and window length.
TextTable summary_table(const EvalResults& r);
// One row per model, sequence and window length.
TextTable sequence_table(const EvalResults& r);
// One row per model, dataset and window length with bands: IoU, detection and windows per
// band (empty when no row has bands).
TextTable band_table(const EvalResults& r);
// A model's short name in tables and plots: its file name, or the path as given where two
// models share a file name (runs/a/best.safetensors against runs/b/best.safetensors); with
// " θ×F" appended where its output threshold was scaled by F != 1.
std::string model_label(const EvalResults& r, const ModelResult& m);
// The same name without the factor: the model file's short name among r's models.
std::string model_file_label(const EvalResults& r, const std::string& path);

// The summary table (one row per model, dataset and window), columns aligned.
std::string results_table(const EvalResults& r);
// band_table as aligned text, "" when no row has bands.
std::string band_results_table(const EvalResults& r);
std::string results_markdown(const EvalResults& r);
// DIR/results.json, results.csv, results.md (the folder is created), each written atomically.
void write_results(const EvalResults& r, const std::string& dir);

}  // namespace spikems
