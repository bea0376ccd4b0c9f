// Scores prediction frames against labelled events, for several window lengths at once
// (as the paper reports them), streaming in bounded memory.
//
// Window k of length W covers [origin + k*W, origin + (k+1)*W), origin = the first event's
// time. P = pixels predicted foreground in the window: the OR of the prediction frames it
// holds (frames of frame_us() = the gcd of the lengths, so every window is a whole number of
// frames; a frame holds the output spikes of the steps whose start lies in it, i.e. only what
// the network said by the window's end). G = pixels with input events labelled != 0 in the
// window, or with use_boxes() the pixels inside the boxes valid in the window (boxes.h). Each
// window goes through count_masks into one WindowScores per length (windows with
// an empty G are skipped and counted there).
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <vector>

#include "core/eval/boxes.h"
#include "core/eval/metrics.h"
#include "core/events/event_stream.h"
#include "core/runtime/mask_accumulator.h"

namespace spikems {

// A scored window kept whole for a picture (report.html): its P and G exactly as scored.
struct CapturedWindow {
  int64_t index = 0;             // window k of its length
  int64_t t0_us = 0, t1_us = 0;  // [t0, t1), absolute times
  int width = 0, height = 0;
  std::vector<uint8_t> predicted, truth;  // P and G, row-major, 0/1
  MaskCounts counts;
};

// Greatest common divisor of positive window lengths.
int64_t frame_length_us(const std::vector<int64_t>& windows_us);

// Rewrites P of each window of one length before it is scored, called for every complete
// window in time order (including windows without moving objects), so it may keep state: the
// Kalman rows (`spikems eval --kalman`, kalman_filter.h).
class WindowFilter {
 public:
  virtual ~WindowFilter() = default;
  // Window [t0_us, t1_us): p = the network's prediction (to rewrite), events = pixels with
  // any input event in the window; both row-major, sensor-sized.
  virtual void apply(int64_t t0_us, int64_t t1_us, std::vector<uint8_t>& p,
                     const std::vector<uint8_t>& events) = 0;
};

struct FilteredLength {
  int64_t window_us = 0;
  std::shared_ptr<WindowFilter> filter;
};

class WindowScorer {
 public:
  // Throws Error when a length is not positive or the sensor size is unknown. Filtered
  // lengths are scored after the plain ones (scores() holds plain, then filtered).
  WindowScorer(SensorSize sensor, std::vector<int64_t> windows_us,
               std::vector<FilteredLength> filtered = {});

  int64_t frame_us() const { return frame_us_; }  // the frame length add_frame() expects
  const std::vector<int64_t>& windows_us() const { return windows_; }

  // Labelled events in time order, continuing the previous chunks; the first event fixes the
  // origin. Add a chunk's events before the frames that pushing it through the segmenter gave
  // (a window is scored only once an event at or after its end was seen, or at finish()).
  // Throws Error for events without labels.
  void add_events(const EventStream& chunk);
  // The next prediction frame, in time order: [origin + j*frame_us(), + frame_us()) for some
  // j, sensor-sized, as Segmenter makes them with mask_window_us = frame_us(). Frames left
  // out are empty predictions. Throws Error for a misaligned, repeated or wrongly sized frame.
  void add_frame(const PredictionFrame& f);
  // End of data at end_us (exclusive): scores every window ending at or before it (P of frames
  // not given is empty) and drops later ones; with keep_partial also the window holding
  // end_us - 1. Nothing is scored without events.
  void finish(int64_t end_us, bool keep_partial = false);

  // Event gating (call before the first events): P of the plain lengths becomes P ∩ E, E = the
  // pixels with any input event in the window, i.e. a prediction counts only where events
  // fell (as per-event labels do; the ANN-2D's P is gated by construction). Off by default:
  // the paper's P is every pixel with an output spike.
  void gate_by_events(bool on);

  // Box ground truth (call before the first events; null: off): G of each window = the pixels
  // inside the boxes valid in it, instead of the pixels of labelled events; events then need
  // no labels here. The boxes must fit the sensor (BoxTruth::check_sensor).
  void use_boxes(std::shared_ptr<const BoxTruth> boxes);

  // Counts each window's input events and moving ones, for its moving share (the size bands,
  // results.h; WindowScores::moving_shares); on by default, unknown with boxes. Call before
  // the first events.
  void track_moving_share(bool on);

  // Scores only the windows whose moving share is at least `fraction` (0-1); the others with
  // a non-empty G are counted as filtered (WindowScores::filtered). This is the SpikeMS
  // authors' test filter (docs/evaluation.md, "The authors' window filter"). The shares are
  // counted for it whatever track_moving_share says; refused with boxes (no share). 0 = off.
  // Call before the first events.
  void min_moving_share(double fraction);

  // Scores the windows of each length in groups of n consecutive ones (group j = windows
  // j n .. j n + n - 1 from the origin): the kept windows of a group (G not empty, not
  // filtered) are scored together, P and G the unions of theirs, and the group's IoU and
  // detection count once per kept window, so the mean is weighted by them. This is the SpikeMS
  // authors' test (an IoU over the sum of a batch of 8 consecutive samples, averaged with the
  // batch's size as its weight; docs/evaluation.md). The group's moving share pools its kept
  // windows' events. 1 = every window alone (the default). Call before the first events.
  void group_windows(int n);

  // One per length, in the order given: the plain lengths, then the filtered ones.
  const std::vector<WindowScores>& scores() const { return scores_; }

  // Keeps P and G of windows `indices` of length `window_us` (one of the lengths) when they
  // are scored, so a report can show them without a second run; call before the first frame.
  // Throws Error for a length that is not scored.
  void capture(int64_t window_us, std::vector<int64_t> indices);
  // The captured windows, in time order (windows past the end of the data are not scored and
  // so not captured).
  const std::vector<CapturedWindow>& captured() const { return captured_; }

 private:
  struct PerLength {
    int64_t window_us = 0, frames_per_window = 0;
    int64_t next = 0;                              // the next window to score
    std::map<int64_t, std::vector<uint8_t>> p, g;  // windows with some P / G pixel
    std::shared_ptr<WindowFilter> filter;          // filtered lengths only
    std::map<int64_t, std::vector<uint8_t>> e;     // filtered lengths: pixels with any event
    int64_t g_index = -1;                          // cache: the window g_mask belongs to
    std::vector<uint8_t>* g_mask = nullptr;
    // Input events per window: {all, truly moving}, for the window's moving share (labels
    // only; with boxes the share is unknown).
    std::map<int64_t, std::array<uint64_t, 2>> n;
    int64_t n_index = -1, n_end = 0;  // cache: the window n_counts belongs to, its end (µs)
    std::array<uint64_t, 2>* n_counts = nullptr;
    // group_windows: the unions of the open group's kept windows' P and G, how many were kept
    // and their input events {all, truly moving}.
    std::vector<uint8_t> group_p, group_g;
    size_t group_kept = 0;
    std::array<uint64_t, 2> group_n{0, 0};
  };
  std::vector<uint8_t>& mask_of(std::map<int64_t, std::vector<uint8_t>>& m, int64_t k);
  void score_ready(size_t length);
  void score(size_t length, int64_t k);
  // Adds a kept window's P and G to its group's unions (group_windows).
  void add_to_group(size_t length, int64_t k, const std::vector<uint8_t>& p,
                    const std::vector<uint8_t>& g);
  void close_group(size_t length);  // scores the open group, if it kept any window

  SensorSize sensor_;
  std::vector<int64_t> windows_;
  int64_t frame_us_ = 0;
  std::vector<PerLength> lengths_;
  std::vector<WindowScores> scores_;
  bool have_origin_ = false, finished_ = false;
  int64_t origin_ = 0, last_t_ = 0;
  int64_t frames_done_ = 0;  // frames before this index are final
  uint64_t events_seen_ = 0;
  std::vector<uint32_t> fg_pixels_;         // scratch: a frame's predicted pixels
  std::vector<std::vector<uint8_t>> pool_;  // cleared masks for reuse
  std::vector<uint8_t> zeros_;              // P of a window without predictions
  size_t capture_length_ = SIZE_MAX;        // index into lengths_, SIZE_MAX: none
  std::vector<int64_t> capture_indices_;    // sorted
  std::vector<CapturedWindow> captured_;
  std::vector<uint8_t> filtered_p_;  // scratch: P handed to a filter
  bool any_filter_ = false;
  bool gate_ = false;                      // P ∩ E for the plain lengths
  bool shares_ = true;                     // track_moving_share
  double min_share_ = 0;                   // min_moving_share
  int group_ = 1;                          // group_windows
  std::shared_ptr<const BoxTruth> boxes_;  // G from boxes when set
  std::vector<uint8_t> gated_p_;           // scratch
};

// Per-event confusion counts (metrics.h) of one sequence, kept per frame of frame_us from the
// origin, then summed per window length over the windows scored (the partial last one
// dropped, as WindowScorer does).
class EventTally {
 public:
  EventTally(int64_t origin_us, int64_t frame_us);
  // An event at t_us (>= origin), truly moving or not, predicted moving or not.
  void add(int64_t t_us, bool truth, bool predicted);
  // Counts over [origin, origin + n W) for each length W, n = whole windows before end_us.
  std::vector<EventCounts> per_length(const std::vector<int64_t>& windows_us, int64_t end_us) const;

 private:
  int64_t origin_, frame_;
  std::vector<EventCounts> frames_;
};

// Scores recorded or hand-made frames against labelled events in one go (see WindowScorer).
std::vector<WindowScores> score_frames(const std::vector<PredictionFrame>& frames,
                                       const EventStream& events,
                                       const std::vector<int64_t>& windows_us, int64_t end_us,
                                       bool keep_partial = false);

}  // namespace spikems
