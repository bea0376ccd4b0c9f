// Object boxes from mask frames: connected components of the foreground (8-connected, after
// a small dilation that joins the sparse spikes of one object), each tracked by a linear
// constant-velocity Kalman filter on its centre (state x, y, vx, vy; measurement x, y), with
// greedy nearest-neighbour association inside a gate. Box sizes are smoothed exponentially.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace spikems {

struct Component {
  int x0, y0, x1, y1;  // inclusive bounds
  int area;            // foreground pixels
  double cx, cy;       // centroid
};

// Connected components (8-connectivity) of mask[y*width + x] != 0 with at least min_area
// pixels.
std::vector<Component> connected_components(const std::vector<uint8_t>& mask, int width, int height,
                                            int min_area);
// Binary dilation by a (2r+1)^2 square.
std::vector<uint8_t> dilate(const std::vector<uint8_t>& mask, int width, int height, int r);

struct TrackedBox {
  int64_t t_us;
  int id;
  double x0, y0, x1, y1;  // box, pixels
  double vx, vy;          // centre velocity, pixels per second
};

struct TrackerOptions {
  int dilate_radius = 2;
  int min_area = 20;             // pixels after dilation
  double gate_px = 40;           // association distance
  int max_missed = 3;            // frames a track survives unseen
  int min_hits = 2;              // frames before a track is reported
  double process_noise = 500;    // acceleration noise (pixels / s^2), std
  double measurement_noise = 3;  // centroid noise (pixels), std
  // Also report confirmed tracks unseen in this frame, at their predicted box (coasting for
  // up to max_missed frames): incremental prediction fills a frame where the detector missed.
  bool report_coasting = false;
};

class KalmanTracker {
 public:
  explicit KalmanTracker(TrackerOptions opt = {}) : opt_(opt) {}
  // One frame at time t_us (its end); returns the confirmed tracks seen in it.
  std::vector<TrackedBox> update(int64_t t_us, const std::vector<uint8_t>& mask, int width,
                                 int height);
  size_t live_tracks() const { return tracks_.size(); }
  const TrackerOptions& options() const { return opt_; }

 private:
  struct Track {
    int id;
    std::array<double, 4> x;   // cx, cy, vx, vy
    std::array<double, 16> P;  // covariance, row-major
    double w, h;               // box size
    int hits = 0, missed = 0;
  };
  void predict(Track& tr, double dt) const;
  void correct(Track& tr, double mx, double my) const;
  TrackerOptions opt_;
  std::vector<Track> tracks_;
  int next_id_ = 1;
  int64_t last_t_ = 0;
  bool started_ = false;
};

}  // namespace spikems
