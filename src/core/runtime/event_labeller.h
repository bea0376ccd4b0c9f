// Per-event foreground/background labels from the network's output spikes.
//
// Rule (docs/runtime.md): an input event at sensor pixel (x, y) that fell in step t is
// foreground when the output layer spikes (either channel) at the matching output pixel in
// steps t .. t + window, window = latency (one step per layer) + tolerance. Output pixel
// (y, x) matches sensor pixel (y, x) (top-left aligned); sensor pixels beyond a smaller output
// (the authors' unpadded network) take the nearest output pixel (coordinates clamped).
// An event's label is decided exactly `window` steps after its own step, so labels trail the
// input by window steps and the queue of undecided events stays bounded.
#pragma once

#include <cstdint>
#include <deque>
#include <vector>

#include "core/events/event_stream.h"
#include "core/util/simd.h"

namespace spikems {

class EventLabeller {
 public:
  // shift > 0: the network sees the events downsampled, pixel (x >> shift, y >> shift), and
  // `sensor` is that grid (Segmenter's downsample); the events keep their own coordinates.
  EventLabeller(SensorSize sensor, int out_height, int out_width, int out_channels,
                int window_steps, int shift = 0);
  // Makes room for n more events, so that push_reserved() needs no check per event.
  void reserve(size_t n) {
    if (tail_ + n > qt_.size()) grow(n);
  }
  // Queues an event of step `step` (steps never decrease) after reserve().
  SPIKEMS_INLINE void push_reserved(int64_t t, uint16_t x, uint16_t y, uint8_t p, int64_t step) {
    if (step_counts_.empty() || step_counts_.back().first != step)
      step_counts_.push_back({step, 0});
    ++step_counts_.back().second;
    qt_[tail_] = t;
    qx_[tail_] = x;
    qy_[tail_] = y;
    qp_[tail_] = p;
    qpix_[tail_] = out_pixel(x >> shift_, y >> shift_);
    ++tail_;
  }
  void push(const Event& e, int64_t step) {
    reserve(1);
    push_reserved(e.t, e.x, e.y, e.p, step);
  }
  // Records the output spikes of step `step`, then appends to `out` (with labels 1 =
  // foreground, 0 = background) every queued event whose window ended at `step`.
  void on_step(int64_t step, const std::vector<uint32_t>& out_spikes, EventStream& out);
  size_t pending() const { return tail_ - head_; }
  int window_steps() const { return window_; }
  // Output pixel index of a pixel of the network's grid (the sensor's unless downsampled).
  uint32_t out_pixel(int x, int y) const {
    int ox = x < ow_ ? x : ow_ - 1, oy = y < oh_ ? y : oh_ - 1;
    return uint32_t(oy) * uint32_t(ow_) + uint32_t(ox);
  }
  uint64_t foreground_count() const { return fg_; }

 private:
  void grow(size_t n);
  void compact();  // moves [head_, tail_) to the front
  SensorSize sensor_;
  int oh_, ow_, oc_, window_, shift_;
  std::vector<int64_t> last_spike_;  // per output pixel
  // Queued events in arrival order in [head_, tail_), one array per field (and the output
  // pixel of each) so that decided events leave as whole column copies and the label loop
  // reads 4 bytes per event; compacted to the front when half is spent. How many events each
  // step brought, oldest first: no per-event step is kept or scanned.
  std::vector<int64_t> qt_;
  std::vector<uint16_t> qx_, qy_;
  std::vector<uint8_t> qp_;
  std::vector<uint32_t> qpix_;
  size_t head_ = 0, tail_ = 0;
  std::deque<std::pair<int64_t, size_t>> step_counts_;
  uint64_t fg_ = 0;
};

}  // namespace spikems
