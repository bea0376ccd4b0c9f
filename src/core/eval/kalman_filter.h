// Incremental prediction (`spikems eval --kalman MS`): the network's predictions over successive
// short windows (e.g. 3 ms) go through a linear Kalman filter per object, and the filtered
// prediction of a window is the input events inside the filtered boxes. Short windows hold few
// spikes, so single windows miss parts of an object or the whole object; the filter carries each
// object's position, velocity and size across windows.
//
// Per window: the prediction P is dilated and split into 8-connected blobs (KalmanTracker);
// each blob is associated with a track (greedy nearest centroid inside a gate). A track's
// state is its centroid and velocity (x, y, vx, vy; constant velocity, white-acceleration
// process noise, centroid measurements) and its box size (width, height; a random walk seen
// directly, i.e. exponential smoothing). A confirmed track (min_hits windows) predicts a box in
// every window, seen or not, for up to max_missed windows without a blob. Filtered P = pixels
// with an input event in the window inside some box. docs/evaluation.md states the tuning.
#pragma once

#include <cstdint>
#include <vector>

#include "core/eval/window_scorer.h"
#include "core/runtime/kalman_tracker.h"

namespace spikems {

// The tracker settings `spikems eval --kalman` uses (tuned on simulated 3 ms windows,
// docs/evaluation.md): coasting on, blobs from a dilation of 2 pixels.
TrackerOptions default_kalman_options();

class KalmanWindowFilter : public WindowFilter {
 public:
  KalmanWindowFilter(int width, int height, TrackerOptions opt = default_kalman_options());
  void apply(int64_t t0_us, int64_t t1_us, std::vector<uint8_t>& p,
             const std::vector<uint8_t>& events) override;
  // The boxes of the last window (for plots and tests).
  const std::vector<TrackedBox>& boxes() const { return boxes_; }

 private:
  int width_, height_;
  KalmanTracker tracker_;
  std::vector<TrackedBox> boxes_;
};

}  // namespace spikems
