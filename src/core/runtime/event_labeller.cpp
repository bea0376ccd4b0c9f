#include "core/runtime/event_labeller.h"

#include <algorithm>
#include <cstddef>
#include <cstring>

#include "core/util/error.h"

namespace spikems {

EventLabeller::EventLabeller(SensorSize sensor, int oh, int ow, int oc, int window, int shift)
    : sensor_(sensor), oh_(oh), ow_(ow), oc_(oc), window_(window), shift_(shift) {
  if (oh <= 0 || ow <= 0 || oc <= 0 || window < 0 || shift < 0 || shift > 15)
    fail("event labeller", "", "invalid output geometry or window");
  last_spike_.assign(size_t(oh) * ow, -1);
}

void EventLabeller::grow(size_t n) {
  // The spent front first (the columns keep their order), then more room if that was not
  // enough: doubling, so that reserve() grows rarely.
  compact();
  if (tail_ + n <= qt_.size()) return;
  const size_t cap = std::max(tail_ + n, 2 * qt_.size());
  qt_.resize(cap);
  qx_.resize(cap);
  qy_.resize(cap);
  qp_.resize(cap);
  qpix_.resize(cap);
}

void EventLabeller::compact() {
  if (head_ == 0) return;
  const size_t n = tail_ - head_;
  auto move_front = [&](auto& v) { std::memmove(v.data(), v.data() + head_, n * sizeof(v[0])); };
  move_front(qt_);
  move_front(qx_);
  move_front(qy_);
  move_front(qp_);
  move_front(qpix_);
  head_ = 0;
  tail_ = n;
}

void EventLabeller::on_step(int64_t step, const std::vector<uint32_t>& spikes, EventStream& out) {
  for (uint32_t n : spikes) last_spike_[n / uint32_t(oc_)] = step;
  size_t end = head_;
  for (auto it = step_counts_.begin(); it != step_counts_.end() && it->first + window_ <= step;
       ++it)
    end += it->second;
  const size_t k = end - head_;
  if (k > 0) {
    // The decided events leave as column copies; only their labels are computed.
    const size_t o = out.size();
    out.resize_labelled(o + k);
    std::memcpy(out.t.data() + o, qt_.data() + head_, k * sizeof(int64_t));
    std::memcpy(out.x.data() + o, qx_.data() + head_, k * sizeof(uint16_t));
    std::memcpy(out.y.data() + o, qy_.data() + head_, k * sizeof(uint16_t));
    std::memcpy(out.p.data() + o, qp_.data() + head_, k);
    uint16_t* __restrict ol = out.label.data() + o;
    // The events decided now sit at random pixels of a table larger than the cache: their
    // entries are requested a few events ahead so that the misses overlap.
    constexpr size_t kAhead = 32;
    const uint32_t* pix = qpix_.data();
    const int64_t* last = last_spike_.data();
    for (size_t i = head_; i < std::min(end, head_ + kAhead); ++i)
      __builtin_prefetch(&last[pix[i]]);
    size_t i = head_;
    uint64_t fg = 0;
    while (!step_counts_.empty() && step_counts_.front().first + window_ <= step) {
      const int64_t s = step_counts_.front().first;
      for (const size_t e = i + step_counts_.front().second; i < e; ++i) {
        if (i + kAhead < end) __builtin_prefetch(&last[pix[i + kAhead]]);
        const bool f = last[pix[i]] >= s;
        fg += f;
        ol[i - head_] = uint16_t(f);
      }
      step_counts_.pop_front();
    }
    fg_ += fg;
    head_ = end;
  }
  if (head_ == tail_)
    head_ = tail_ = 0;
  else if (head_ > tail_ / 2)
    compact();
}

}  // namespace spikems
