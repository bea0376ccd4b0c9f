// Segmentation metrics as the SpikeMS paper reports them (docs/evaluation.md).
// P = pixels predicted foreground in a window (any output spike), G = pixels with foreground
// input events in the window. Masks are row-major H*W bytes, non-zero = set.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

namespace spikems {

struct MaskCounts {
  uint64_t intersection = 0;  // |P ∩ G|
  uint64_t predicted = 0;     // |P|
  uint64_t truth = 0;         // |G|
  uint64_t union_() const { return predicted + truth - intersection; }
};

MaskCounts count_masks(const std::vector<uint8_t>& predicted, const std::vector<uint8_t>& truth);

// IoU = |P∩G| / |P∪G|; a window where both are empty scores 1 (nothing to find, nothing
// claimed) and is reported as such; callers may skip such windows (see WindowScores).
double iou(const MaskCounts& c);

// Detection in the 0-MMS protocol: |P∩G| > 0.5|G| and |P∩G| > |P \ G|.
bool is_detection(const MaskCounts& c);

// Accumulates per-window scores of one sequence: mean ± std of IoU, detection rate.
class WindowScores {
 public:
  // Windows with an empty G are skipped (no moving object to score), as in the paper.
  // moving_share: the fraction (0-1) of the window's input events that are truly moving, the
  // key of the size bands (results.h); NaN where unknown (boxes as truth).
  void add(const MaskCounts& c, double moving_share = kUnknownShare);
  // A window left out by a moving-share filter (WindowScorer::min_moving_share): counted only.
  void add_filtered() { ++filtered_; }
  // A group of `windows` windows scored together (WindowScorer::group_windows): c counts
  // the unions of their P and G; the group's IoU and detection count once per window.
  void add_group(const MaskCounts& c, double moving_share, size_t windows) {
    for (size_t i = 0; i < windows; ++i) add(c, moving_share);
  }
  size_t windows() const { return ious_.size(); }
  size_t skipped() const { return skipped_; }
  size_t filtered() const { return filtered_; }
  double mean_iou() const;
  double std_iou() const;
  double detection_rate() const;  // fraction of scored windows that are detections
  const std::vector<double>& ious() const { return ious_; }
  // Per scored window, aligned with ious(): its moving share (NaN: unknown) and detection.
  const std::vector<double>& moving_shares() const { return shares_; }
  const std::vector<uint8_t>& detections() const { return detected_; }

  static constexpr double kUnknownShare = std::numeric_limits<double>::quiet_NaN();

 private:
  std::vector<double> ious_, shares_;
  std::vector<uint8_t> detected_;
  size_t detections_ = 0, skipped_ = 0, filtered_ = 0;
};

// Per-event confusion counts: an event is predicted moving when the runtime labels it so
// (EventLabeller: an output spike at its pixel within the label window) and truly moving when
// its label is not 0.
struct EventCounts {
  uint64_t tp = 0, fp = 0, fn = 0, tn = 0;
  void add(bool truth, bool predicted) {
    (truth ? (predicted ? tp : fn) : (predicted ? fp : tn)) += 1;
  }
  EventCounts& operator+=(const EventCounts& o) {
    tp += o.tp, fp += o.fp, fn += o.fn, tn += o.tn;
    return *this;
  }
  uint64_t total() const { return tp + fp + fn + tn; }
  bool has_precision() const { return tp + fp > 0; }  // some event predicted moving
  bool has_recall() const { return tp + fn > 0; }     // some event truly moving
  double precision() const { return has_precision() ? double(tp) / double(tp + fp) : 0; }
  double recall() const { return has_recall() ? double(tp) / double(tp + fn) : 0; }
  // The share of events predicted moving (on a static scene: the false-positive rate).
  double moving_share() const { return total() ? double(tp + fp) / double(total()) : 0; }
};

// Energy per operation as the paper counts it (Lee et al. 2020, 45 nm, 32-bit float).
inline constexpr double kPicojoulePerAccumulate = 0.9;
inline constexpr double kPicojoulePerMac = 4.6;
inline double snn_energy_pj(double synops) {
  return synops * kPicojoulePerAccumulate;
}
inline double ann_energy_pj(double macs) {
  return macs * kPicojoulePerMac;
}

}  // namespace spikems
