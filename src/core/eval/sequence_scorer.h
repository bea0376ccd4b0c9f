// A model's scores on one labelled sequence, for several window lengths from one run: the
// streaming Segmenter goes once over the whole sensor, its state continuous from the first
// event as when deployed, and its prediction frames (of the gcd of the lengths) feed a
// WindowScorer (window_scorer.h: P, G, causality, skipped and partial windows).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/dataset/sequence.h"
#include "core/eval/metrics.h"
#include "core/eval/window_scorer.h"
#include "core/model/model_file.h"
#include "core/runtime/kalman_tracker.h"

namespace spikems {

struct SequenceScoreOptions {
  int threads = 1;       // threads inside the network (Segmenter)
  int block_steps = 16;  // steps per network block: faster, outputs identical
  // The runtime's label window beyond its latency (SegmenterOptions; `spikems segment`'s
  // default): events labelled moving by it count for the event precision and recall.
  int label_tolerance_steps = 3;
  // Kalman rows: window lengths whose predictions go through a KalmanWindowFilter
  // (kalman_filter.h) before they are scored, with these tracker settings.
  std::vector<int64_t> kalman_us;
  TrackerOptions kalman;
  int64_t max_us = 0;  // > 0: score only [first event, first event + max_us)
  // Called after each chunk with the events pushed so far; returning false stops the run
  // (the result then has complete = false and no scores).
  std::function<bool(uint64_t events_done)> progress;
  // Windows of length capture_window_us (one of the scored lengths) whose P and G are kept
  // (SequenceScore::captured), by index from the first event; see example_windows().
  int64_t capture_window_us = 0;
  // P ∩ E (WindowScorer::gate_by_events): predictions count only at pixels with events.
  bool gate_events = false;
  // Box ground truth (WindowScorer::use_boxes): G = box pixels. The sequence's labels must
  // then come from the same boxes (BoxTruth::label), for the event precision and recall.
  std::shared_ptr<const BoxTruth> boxes;
  std::vector<int64_t> capture_windows;
  // Each window's moving share for the size bands (WindowScorer::track_moving_share); off
  // when no bands are asked for (`--share-bands none`).
  bool moving_share = true;
  // > 0: only windows with at least this fraction of their input events truly moving are
  // scored, the others counted as filtered (WindowScorer::min_moving_share).
  double min_moving_share = 0;
  // > 1: windows scored in groups of so many consecutive ones, P and G united over the kept
  // windows of a group (WindowScorer::group_windows; the SpikeMS authors' test).
  int group_windows = 1;
  // The network sees the sensor downsampled by this factor (SegmenterOptions::downsample) and
  // P and G are scored on its grid; 0 = auto (model_scale.h: nearest the model's training grid).
  int downsample = 0;
};

struct SequenceScore {
  std::string name;
  uint64_t events = 0;  // events pushed through the network
  int64_t span_us = 0;  // first event to the end of the data scored (partial window included)
  bool complete = true;
  std::vector<int64_t> windows_us;
  std::vector<int64_t> kalman_us;        // the Kalman-filtered lengths
  std::vector<WindowScores> scores;      // one per window length, then one per kalman_us
  std::vector<CapturedWindow> captured;  // the windows asked for in capture_windows
  // Per window length (windows_us): the events of its whole windows, predicted moving by the
  // runtime's labels (model) or by the baseline's rule, against their labels.
  std::vector<EventCounts> events_pr;
  int downsample = 1;  // the factor the network saw the sequence at (SequenceScoreOptions)
};

// The model's simulation step in microseconds (as the Segmenter takes it).
int64_t time_step_us(const ModelSpec& model);

// Throws Error, naming `source`, when the list is empty or a length is not a positive multiple
// of the time step (a window must hold whole steps, or P and G would cover different times).
void check_windows(const std::vector<int64_t>& windows_us, int64_t step_us,
                   const std::string& source);

// The part of a labelled sequence that is scored: events [0, n), time [t0, end). A cut
// (max_us > 0) ends exactly at t0 + max_us when the sequence goes on past it; otherwise the data
// ends just after the last event. Throws Error (naming the sequence) when events lack labels.
struct ScoredSpan {
  size_t n = 0;
  int64_t t0 = 0, end = 0;
};
ScoredSpan scored_span(const LabelledSequence& seq, int64_t max_us);
// A score for `seq` with one empty WindowScores per length (complete; filled by the scorers).
SequenceScore empty_score(const LabelledSequence& seq, const std::vector<int64_t>& windows_us,
                          const std::vector<int64_t>& kalman_us = {});
// One KalmanWindowFilter per Kalman length, for a WindowScorer of that sensor.
std::vector<FilteredLength> kalman_lengths(SensorSize sensor, const SequenceScoreOptions& opt);

// Up to `count` complete windows of length window_us to show from a sequence, evenly spaced
// over the windows that hold moving-object events (a window with nothing to find says little),
// by index from the first event; all such windows when there are no more than `count`. The
// span is scored_span(seq, max_us)'s.
std::vector<int64_t> example_windows(const LabelledSequence& seq, int64_t window_us, int count,
                                     int64_t max_us = 0);

// Windows start at the first event; the last, partial window is dropped. Throws Error (naming
// the sequence) for unlabelled events, a model that does not fit the sensor, or a bad window.
SequenceScore score_sequence(const ModelSpec& model, const LabelledSequence& seq,
                             const std::vector<int64_t>& windows_us,
                             const SequenceScoreOptions& opt = {});

}  // namespace spikems
