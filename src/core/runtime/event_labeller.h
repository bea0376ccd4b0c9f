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

namespace spikems {

class EventLabeller {
 public:
  // shift > 0: the network sees the events downsampled, pixel (x >> shift, y >> shift), and
  // `sensor` is that grid (Segmenter's downsample); the events keep their own coordinates.
  EventLabeller(SensorSize sensor, int out_height, int out_width, int out_channels,
                int window_steps, int shift = 0);
  // Queues an event of step `step` (steps never decrease).
  void push(const Event& e, int64_t step);
  // Records the output spikes of step `step`, then appends to `out` (with labels 1 =
  // foreground, 0 = background) every queued event whose window ended at `step`.
  void on_step(int64_t step, const std::vector<uint32_t>& out_spikes, EventStream& out);
  size_t pending() const { return queue_.size() - head_; }
  int window_steps() const { return window_; }
  // Output pixel index of a pixel of the network's grid (the sensor's unless downsampled).
  uint32_t out_pixel(int x, int y) const {
    int ox = x < ow_ ? x : ow_ - 1, oy = y < oh_ ? y : oh_ - 1;
    return uint32_t(oy) * uint32_t(ow_) + uint32_t(ox);
  }
  uint64_t foreground_count() const { return fg_; }

 private:
  struct Pending {
    Event e;
    uint32_t pixel;  // out_pixel() of the event
  };
  SensorSize sensor_;
  int oh_, ow_, oc_, window_, shift_;
  std::vector<int64_t> last_spike_;  // per output pixel
  // Queued events in arrival order from head_ (the vector is compacted when half is spent),
  // and how many of them each step brought, oldest first: no per-event step is kept or
  // scanned to find the events a step decides.
  std::vector<Pending> queue_;
  size_t head_ = 0;
  std::deque<std::pair<int64_t, size_t>> step_counts_;
  uint64_t fg_ = 0;
};

}  // namespace spikems
