#include "core/eval/kalman_filter.h"

#include <algorithm>
#include <cmath>

#include "core/util/error.h"

namespace spikems {

TrackerOptions default_kalman_options() {
  TrackerOptions o;
  o.report_coasting = true;
  return o;
}

KalmanWindowFilter::KalmanWindowFilter(int width, int height, TrackerOptions opt)
    : width_(width), height_(height), tracker_(opt) {
  if (width <= 0 || height <= 0) fail("kalman filter", "", "the sensor size is unknown");
}

void KalmanWindowFilter::apply(int64_t, int64_t t1_us, std::vector<uint8_t>& p,
                               const std::vector<uint8_t>& events) {
  const size_t size = size_t(width_) * size_t(height_);
  if (p.size() != size || events.size() != size)
    fail("kalman filter", "", "a mask does not have the sensor's size");
  // The filter's time is the window's end: what it says is known by then (causal).
  boxes_ = tracker_.update(t1_us, p, width_, height_);
  std::fill(p.begin(), p.end(), 0);
  for (const TrackedBox& b : boxes_) {
    const int x0 = std::max(0, int(std::floor(b.x0))), y0 = std::max(0, int(std::floor(b.y0)));
    const int x1 = std::min(width_ - 1, int(std::ceil(b.x1)));
    const int y1 = std::min(height_ - 1, int(std::ceil(b.y1)));
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        const size_t i = size_t(y) * size_t(width_) + size_t(x);
        p[i] = events[i] ? 1 : 0;
      }
  }
}

}  // namespace spikems
