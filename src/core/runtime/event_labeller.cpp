#include "core/runtime/event_labeller.h"

#include <algorithm>
#include <cstddef>

#include "core/util/error.h"

namespace spikems {

EventLabeller::EventLabeller(SensorSize sensor, int oh, int ow, int oc, int window)
    : sensor_(sensor), oh_(oh), ow_(ow), oc_(oc), window_(window) {
  if (oh <= 0 || ow <= 0 || oc <= 0 || window < 0)
    fail("event labeller", "", "invalid output geometry or window");
  last_spike_.assign(size_t(oh) * ow, -1);
}

void EventLabeller::push(const Event& e, int64_t step) {
  queue_.push_back({e, step});
}

void EventLabeller::on_step(int64_t step, const std::vector<uint32_t>& spikes, EventStream& out) {
  for (uint32_t n : spikes) last_spike_[n / uint32_t(oc_)] = step;
  // The events decided now sit at random pixels of a table larger than the cache: their
  // entries are requested a few events ahead so that the misses overlap.
  constexpr size_t kAhead = 8;
  size_t decided = 0;
  while (decided < queue_.size() && queue_[decided].step + window_ <= step) ++decided;
  for (size_t i = 0; i < std::min(decided, kAhead); ++i)
    __builtin_prefetch(&last_spike_[out_pixel(queue_[i].e.x, queue_[i].e.y)]);
  for (size_t i = 0; i < decided; ++i) {
    if (i + kAhead < decided) {
      const Event& a = queue_[i + kAhead].e;
      __builtin_prefetch(&last_spike_[out_pixel(a.x, a.y)]);
    }
    const Pending& p = queue_[i];
    const bool fg = last_spike_[out_pixel(p.e.x, p.e.y)] >= p.step;
    fg_ += fg;
    out.push_back(p.e.t, p.e.x, p.e.y, p.e.p, uint16_t(fg ? 1 : 0));
  }
  queue_.erase(queue_.begin(), queue_.begin() + std::ptrdiff_t(decided));
}

}  // namespace spikems
