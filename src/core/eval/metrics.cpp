#include "core/eval/metrics.h"

#include <cmath>

#include "core/util/error.h"

namespace spikems {

MaskCounts count_masks(const std::vector<uint8_t>& p, const std::vector<uint8_t>& g) {
  if (p.size() != g.size())
    throw Error("prediction and ground truth masks differ in size (" + std::to_string(p.size()) +
                " vs " + std::to_string(g.size()) + " pixels)");
  MaskCounts c;
  for (size_t i = 0; i < p.size(); ++i) {
    bool a = p[i] != 0, b = g[i] != 0;
    c.intersection += a && b;
    c.predicted += a;
    c.truth += b;
  }
  return c;
}

double iou(const MaskCounts& c) {
  uint64_t u = c.union_();
  return u == 0 ? 1.0 : double(c.intersection) / double(u);
}

bool is_detection(const MaskCounts& c) {
  uint64_t false_pos = c.predicted - c.intersection;
  return 2 * c.intersection > c.truth && c.intersection > false_pos;
}

void WindowScores::add(const MaskCounts& c, double moving_share) {
  if (c.truth == 0) {
    ++skipped_;
    return;
  }
  ious_.push_back(iou(c));
  shares_.push_back(moving_share);
  const bool d = is_detection(c);
  detected_.push_back(d);
  detections_ += d;
}

double WindowScores::mean_iou() const {
  if (ious_.empty()) return 0;
  double s = 0;
  for (double v : ious_) s += v;
  return s / double(ious_.size());
}

double WindowScores::std_iou() const {
  if (ious_.size() < 2) return 0;
  double m = mean_iou(), s = 0;
  for (double v : ious_) s += (v - m) * (v - m);
  return std::sqrt(s / double(ious_.size()));
}

double WindowScores::detection_rate() const {
  return ious_.empty() ? 0 : double(detections_) / double(ious_.size());
}

}  // namespace spikems
