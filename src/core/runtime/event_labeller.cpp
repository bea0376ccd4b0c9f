#include "core/runtime/event_labeller.h"

#include <algorithm>
#include <cstddef>

#include "core/util/error.h"

namespace spikems {

EventLabeller::EventLabeller(SensorSize sensor, int oh, int ow, int oc, int window, int shift)
    : sensor_(sensor), oh_(oh), ow_(ow), oc_(oc), window_(window), shift_(shift) {
  if (oh <= 0 || ow <= 0 || oc <= 0 || window < 0 || shift < 0 || shift > 15)
    fail("event labeller", "", "invalid output geometry or window");
  last_spike_.assign(size_t(oh) * ow, -1);
}

void EventLabeller::push(const Event& e, int64_t step) {
  if (step_counts_.empty() || step_counts_.back().first != step) step_counts_.push_back({step, 0});
  ++step_counts_.back().second;
  queue_.push_back({e, out_pixel(e.x >> shift_, e.y >> shift_)});
}

void EventLabeller::on_step(int64_t step, const std::vector<uint32_t>& spikes, EventStream& out) {
  for (uint32_t n : spikes) last_spike_[n / uint32_t(oc_)] = step;
  // The events decided now sit at random pixels of a table larger than the cache: their
  // entries are requested a few events ahead so that the misses overlap.
  constexpr size_t kAhead = 32;
  const Pending* q = queue_.data();
  size_t end = head_;
  for (auto it = step_counts_.begin(); it != step_counts_.end() && it->first + window_ <= step;
       ++it)
    end += it->second;
  for (size_t i = head_; i < std::min(end, head_ + kAhead); ++i)
    __builtin_prefetch(&last_spike_[q[i].pixel]);
  // The decided events are written in place (one resize, not a push_back per event).
  const size_t o = out.size();
  out.resize_labelled(o + (end - head_));
  int64_t* __restrict ot = out.t.data() + o;
  uint16_t* __restrict ox = out.x.data() + o;
  uint16_t* __restrict oy = out.y.data() + o;
  uint8_t* __restrict op = out.p.data() + o;
  uint16_t* __restrict ol = out.label.data() + o;
  size_t i = head_;
  while (!step_counts_.empty() && step_counts_.front().first + window_ <= step) {
    const int64_t s = step_counts_.front().first;
    for (const size_t e = i + step_counts_.front().second; i < e; ++i) {
      if (i + kAhead < end) __builtin_prefetch(&last_spike_[q[i + kAhead].pixel]);
      const bool fg = last_spike_[q[i].pixel] >= s;
      fg_ += fg;
      const Event& ev = q[i].e;
      ot[i - head_] = ev.t;
      ox[i - head_] = ev.x;
      oy[i - head_] = ev.y;
      op[i - head_] = ev.p;
      ol[i - head_] = uint16_t(fg);
    }
    step_counts_.pop_front();
  }
  head_ = i;
  if (head_ == queue_.size()) {
    queue_.clear();
    head_ = 0;
  } else if (head_ > queue_.size() / 2) {
    queue_.erase(queue_.begin(), queue_.begin() + std::ptrdiff_t(head_));
    head_ = 0;
  }
}

}  // namespace spikems
