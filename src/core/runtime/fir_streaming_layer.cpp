#include "core/runtime/fir_streaming_layer.h"

#include <algorithm>
#include <bit>
#include <cstring>
#include <limits>

namespace spikems {

namespace {
int ring_size(size_t n) {
  int w = 1;
  while (size_t(w) < n) w <<= 1;
  return w;
}
}  // namespace

FirStreamingLayer::FirStreamingLayer(const LayerSpec& l, int hin, int win, int need_h, int need_w)
    : StreamingLayer(l, hin, win, need_h, need_w), eps_(l.srm_kernel), nu_(l.ref_kernel) {
  if (eps_.empty()) eps_.push_back(0.f);
  if (nu_.empty()) nu_.push_back(0.f);
  W_ = ring_size(std::max(eps_.size(), nu_.size()));
  mask_ = W_ - 1;
  const size_t npos = size_t(hout_) * wout_;
  ring_.assign(npos * W_ * cout_, 0.f);
  horizon_.assign(npos, std::numeric_limits<int64_t>::min() / 2);
  next_.assign(npos, -1);
  drive_.assign(npos * cout_ + 16);  // + the slack of scatter()'s blocks of 16
  wheel_.resize(W_);
}

void FirStreamingLayer::step(int64_t t, const uint32_t* s, size_t n, std::vector<uint32_t>& next) {
  step_all(t, s, n, next);
}

SPIKEMS_MULTIVERSION void FirStreamingLayer::step_all(int64_t t, const uint32_t* s, size_t n,
                                                      std::vector<uint32_t>& next) {
  with_channels(cout_, [&](auto ct) SPIKEMS_INLINE_LAMBDA {
    drive_c<ct()>(t, s, n);
    const size_t n0 = next.size();
    fire_c<ct()>(t + 1, next);
    ahead_ = next.size() - n0;
  });
}

template <int CT>
SPIKEMS_INLINE void FirStreamingLayer::fire_c(int64_t t, std::vector<uint32_t>& out) {
  auto& bucket = wheel_[size_t(t & mask_)];
  const int C = CT ? CT : cout_;
  const int R = int(nu_.size());
  for (size_t i = 0; i < bucket.size(); ++i) {
    const uint32_t pos = bucket[i];
    if (next_[pos] != t) continue;  // rescheduled since
    ++visits_;
    const float* u = slot(pos, t);
    for (int c = 0; c < C; ++c) {
      if (!(u[c] >= theta_)) continue;
      out.push_back(pos * uint32_t(C) + uint32_t(c));
      ++spikes_;
      if (R > 1) {
        extend(pos, t, t + R - 1);
        for (int j = 1; j < R; ++j) slot(pos, t + j)[c] += nu_[size_t(j)];
      }
    }
    next_[pos] = -1;
    schedule(pos, next_crossing<CT>(pos, t + 1));
  }
  bucket.clear();
}

template <int CT>
SPIKEMS_INLINE void FirStreamingLayer::drive_c(int64_t t, const uint32_t* spikes, size_t n) {
  const int C = CT ? CT : cout_, K = int(eps_.size());
  mark_reached(spikes, n, 0);
  float* drive = drive_.data();
  add_drive<CT>(spikes, [&](uint32_t op) SPIKEMS_INLINE_LAMBDA { return drive + size_t(op) * C; });
  for (size_t w = 0; w < touched_bits_.size(); ++w) {
    visits_ += uint64_t(std::popcount(touched_bits_[w]));
    for (uint64_t m = touched_bits_[w]; m != 0; m &= m - 1) {
      const uint32_t pos = uint32_t(w * 64 + size_t(std::countr_zero(m)));
      float* __restrict d = &drive_[size_t(pos) * C];
      int64_t cross = -1;
      if (K > 1) {
        extend(pos, t, t + K - 1);
        // Scatter into the ring and look for the first slot reaching theta in the same pass.
        int k = 1;
        for (; k < K; ++k) {
          float* __restrict u = slot(pos, t + k);
          const float e = eps_[size_t(k)];
          int reach = 0;
          for (int c = 0; c < C; ++c) {
            u[c] += d[c] * e;
            reach |= u[c] >= theta_;
          }
          if (reach) {
            cross = t + k;
            break;
          }
        }
        for (++k; k < K; ++k) {  // finish the scatter past the crossing
          float* __restrict u = slot(pos, t + k);
          const float e = eps_[size_t(k)];
          for (int c = 0; c < C; ++c) u[c] += d[c] * e;
        }
        if (cross < 0) cross = next_crossing<CT>(pos, t + K);  // slots past the kernel
      } else {
        cross = next_crossing<CT>(pos, t + 1);
      }
      schedule(pos, cross);
      for (int c = 0; c < C; ++c) d[c] = 0.f;  // drive_ stays zero outside marked positions
    }
    touched_bits_[w] = 0;
  }
}

float FirStreamingLayer::potential(int64_t t, uint32_t neuron) const {
  const uint32_t pos = neuron / uint32_t(cout_);
  if (t > horizon_[pos]) return 0.f;
  return ring_[(size_t(pos) * W_ + size_t(t & mask_)) * cout_ + neuron % uint32_t(cout_)];
}

size_t FirStreamingLayer::busy_positions() const {
  size_t n = 0;
  for (const auto& b : wheel_) n += b.size();
  return n;
}

// Makes the slots of steps (t, upto] valid: the ones past the horizon hold stale values.
void FirStreamingLayer::extend(uint32_t pos, int64_t t, int64_t upto) {
  int64_t& h = horizon_[pos];
  if (upto <= h) return;
  for (int64_t s = std::max(h, t) + 1; s <= upto; ++s)
    std::memset(slot(pos, s), 0, sizeof(float) * size_t(cout_));
  h = upto;
}

template <int CT>
SPIKEMS_INLINE int64_t FirStreamingLayer::next_crossing(uint32_t pos, int64_t from) const {
  const int C = CT ? CT : cout_;
  for (int64_t s = from; s <= horizon_[pos]; ++s) {
    const float* u = slot(pos, s);
    int reach = 0;
    for (int c = 0; c < C; ++c) reach |= u[c] >= theta_;
    if (reach) return s;
  }
  return -1;
}

void FirStreamingLayer::schedule(uint32_t pos, int64_t s) {
  if (s == next_[pos]) return;
  next_[pos] = s;
  if (s >= 0) wheel_[size_t(s & mask_)].push_back(pos);
}

}  // namespace spikems
