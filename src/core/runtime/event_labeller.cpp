#include "core/runtime/event_labeller.h"

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
  while (!queue_.empty() && queue_.front().step + window_ <= step) {
    const Pending& p = queue_.front();
    const bool fg = last_spike_[out_pixel(p.e.x, p.e.y)] >= p.step;
    fg_ += fg;
    out.push_back(p.e.t, p.e.x, p.e.y, p.e.p, uint16_t(fg ? 1 : 0));
    queue_.pop_front();
  }
}

}  // namespace spikems
