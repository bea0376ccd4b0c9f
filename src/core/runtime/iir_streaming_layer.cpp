#include "core/runtime/iir_streaming_layer.h"

#include <algorithm>
#include <bit>
#include <cstdint>
#include <limits>

#if defined(__SSE__)
#include <immintrin.h>
#endif

namespace spikems {

// State "as of step t" of one neuron: a1 = sum_{j<t} I_j (t-j) a^(t-j), so u_psp[t] = cs*a1,
// and b0 = sum_{j<=t} I_j a^(t-j) (this step's drive included). Without new drive, d steps
// on: a1 <- a^d (a1 + d b0), b0 <- a^d b0. The refractory state is the same recursion fed
// with the neuron's own spikes (SLAYER's alpha form: r1, r0), or for the SpikeMS form
// r0 = sum_{j<t} s_j ar^(t-1-j) plus 1/ar for a spike at t, so that r0 <- ar^d r0.
//
// Bound: with no new drive, u_psp[t+n] = cs a^n (a1 + n b0) <= cs (a max(a1,0) + M max(b0,0))
// for every n >= 1, where M = max_{n>=1} n a^n. Below theta means no spike until new drive.

IirStreamingLayer::IirStreamingLayer(const LayerSpec& l, double ts, int hin, int win)
    : StreamingLayer(l, hin, win),
      a_(std::exp(-ts / double(l.neuron.tau_s))),
      ar_(std::exp(-ts / double(l.neuron.tau_r))),
      slayer_ref_(l.neuron.refractory == RefractoryShape::Slayer) {
  cs_ = std::exp(1.0) * ts / double(l.neuron.tau_s);
  const double mult = -double(l.neuron.scale_ref) * double(l.neuron.theta);
  cref_ = slayer_ref_ ? mult * std::exp(1.0) * ts / double(l.neuron.tau_r) : mult;
  cs_f_ = float(cs_);
  cref_f_ = float(cref_);
  spike_inc_ = slayer_ref_ ? 1.f : float(1.0 / ar_);
  double m = 0;
  for (int n = 1; n < 1 << 20; ++n) {
    const double v = n * std::pow(a_, n);
    if (v < m) break;  // n a^n rises to its peak, then falls
    m = v;
  }
  bound_a1_ = float(cs_ * a_);
  bound_b0_ = float(cs_ * m);
  // A hair low: float rounding of the state and of the bound must err on "may reach".
  bound_theta_ = theta_ - 1e-4f * std::fabs(theta_);
  // a^d for every gap until it drops below the smallest normal float (a neuron untouched that
  // long has decayed to 0 within float precision; flushing also avoids slow denormals).
  auto table = [](double a, std::vector<float>& tab) {
    tab.clear();
    for (double v = 1.0; v >= double(std::numeric_limits<float>::min()) && tab.size() < 65536;
         v *= a)
      tab.push_back(float(v));
  };
  table(a_, pow_a_);
  table(ar_, pow_ar_);
  // Units: 16/C positions when C divides 16, so that a unit is one vector of 16 lanes.
  const int C = cout_;
  const int per_unit = (C < 16 && 16 % C == 0) ? 16 / C : 1;
  unit_shift_ = std::countr_zero(unsigned(per_unit));
  lanes_ = per_unit * C;
  const size_t npos = size_t(hout_) * wout_;
  const size_t units = ((npos + size_t(per_unit) - 1) / size_t(per_unit) + 63) / 64 * 64;
  const size_t n = units * size_t(lanes_);
  a1_.assign(n);
  b0_.assign(n + 16);  // + the slack of scatter()'s blocks of 16
  r0_.assign(n);
  if (slayer_ref_) r1_.assign(n);
  last_.assign(units);
  for (size_t i = 0; i < units; ++i)
    last_[i] = std::numeric_limits<int64_t>::min() / 4;  // state is 0: any gap works
  active_bits_.assign(units / 64, 0);
  scratch_.assign(2 * size_t(lanes_), 0.f);
}

void IirStreamingLayer::record_potentials(bool on) {
  record_ = on;
  if (on && u_eval_.empty()) {
    u_eval_.assign(out_neurons(), 0.f);
    eval_step_.assign(last_.size(), -1);
  }
}

void IirStreamingLayer::record(uint32_t unit, const float* u, int64_t t) {
  const size_t first = size_t(unit) * size_t(lanes_);
  const size_t end = std::min(first + size_t(lanes_), out_neurons());
  std::copy(u, u + (end - first), &u_eval_[first]);
  eval_step_[unit] = t;
}

void IirStreamingLayer::step(int64_t t, const uint32_t* s, size_t n, std::vector<uint32_t>& next) {
  step_all(t, s, n, next);
}

SPIKEMS_MULTIVERSION void IirStreamingLayer::step_all(int64_t t, const uint32_t* s, size_t n,
                                                      std::vector<uint32_t>& next) {
  with_channels(cout_, [&](auto ct) SPIKEMS_INLINE_LAMBDA { step_c<ct()>(t, s, n, next); });
}

namespace {
// Bit c set where v[c] >= th, for the first n <= 64 values (the comparison is false for NaN).
SPIKEMS_INLINE uint64_t at_least(const float* v, float th, int n) {
  uint64_t m = 0;
  int c = 0;
#if defined(__SSE__)
  const __m128 t4 = _mm_set1_ps(th);
  for (; c + 4 <= n; c += 4)
    m |= uint64_t(unsigned(_mm_movemask_ps(_mm_cmpge_ps(_mm_loadu_ps(v + c), t4)))) << c;
#endif
  for (; c < n; ++c) m |= uint64_t(v[c] >= th) << c;
  return m;
}
}  // namespace

// Brings a unit's state from its last step to step t (nothing to do when it is there, as
// active units are).
template <int CT>
SPIKEMS_INLINE void IirStreamingLayer::catch_up(uint32_t unit, int64_t t) {
  int64_t& last = last_[unit];
  const int64_t d = t - last;
  if (d == 0) return;
  last = t;
  constexpr int LT = CT == 0 ? 0 : (CT < 16 && 16 % CT == 0 ? 16 : CT);
  const int L = LT ? LT : lanes_;
  const size_t o = size_t(unit) * size_t(L);
  const float g = decay(d), gr = ref_decay(d), fd = float(d);
  float* __restrict a1 = &a1_[o];
  float* __restrict b0 = &b0_[o];
  float* __restrict r0 = &r0_[o];
  for (int c = 0; c < L; ++c) {
    a1[c] = g * (a1[c] + fd * b0[c]);
    b0[c] = g * b0[c];
  }
  if (slayer_ref_) {
    float* __restrict r1 = &r1_[o];
    for (int c = 0; c < L; ++c) r1[c] = gr * (r1[c] + fd * r0[c]);
  }
  for (int c = 0; c < L; ++c) r0[c] = gr * r0[c];
}

// One unit from step t to t+1: appends its spikes of t+1; returns whether it stays active.
template <int CT>
SPIKEMS_INLINE bool IirStreamingLayer::update(uint32_t unit, int64_t t,
                                              std::vector<uint32_t>& next) {
  constexpr int LT = CT == 0 ? 0 : (CT < 16 && 16 % CT == 0 ? 16 : CT);
  const int L = LT ? LT : lanes_;
  const size_t o = size_t(unit) * size_t(L);
  const float g1 = decay(1), gr1 = ref_decay(1);
  const float cs = cs_f_, cref = cref_f_, ba = bound_a1_, bb = bound_b0_;
  float u_local[LT ? LT : 1], bnd_local[LT ? LT : 1];
  float* __restrict u = LT ? u_local : scratch_.data();
  float* __restrict bnd = LT ? bnd_local : scratch_.data() + L;
  float* __restrict a1 = &a1_[o];
  float* __restrict b0 = &b0_[o];
  float* __restrict r0 = &r0_[o];
  if (slayer_ref_) {
    float* __restrict r1 = &r1_[o];
    for (int c = 0; c < L; ++c) {
      r1[c] = gr1 * (r1[c] + r0[c]);
      r0[c] = gr1 * r0[c];
    }
  } else {
    for (int c = 0; c < L; ++c) r0[c] = gr1 * r0[c];
  }
  const float* __restrict r = slayer_ref_ ? &r1_[o] : r0;
  for (int c = 0; c < L; ++c) {
    const float x = g1 * (a1[c] + b0[c]), y = g1 * b0[c];
    a1[c] = x;
    b0[c] = y;
    u[c] = cs * x + cref * r[c];
    bnd[c] = ba * std::max(x, 0.f) + bb * std::max(y, 0.f);
  }
  last_[unit] = t + 1;
  if (record_) record(unit, u, t + 1);
  bool reach = false;
  // Lanes past the last position (a partial last unit) hold zeros and never reach theta > 0.
  for (int c0 = 0; c0 < L; c0 += 64) {
    const int len = std::min(64, L - c0);
    for (uint64_t f = at_least(u + c0, theta_, len); f != 0; f &= f - 1) {
      const int c = c0 + std::countr_zero(f);
      next.push_back(uint32_t(o) + uint32_t(c));
      r0[c] += spike_inc_;  // the spike's refractory response starts at t+2
    }
    reach |= at_least(bnd + c0, bound_theta_, len) != 0;
  }
  return reach;
}

template <int CT>
SPIKEMS_INLINE void IirStreamingLayer::step_c(int64_t t, const uint32_t* spikes, size_t n,
                                              std::vector<uint32_t>& next) {
  // The drive of t goes straight into b0, each unit first brought up to step t.
  const int C = CT ? CT : cout_;
  scatter<CT>(
      spikes, n, b0_.data(), unit_shift_,
      [&](uint32_t unit) SPIKEMS_INLINE_LAMBDA { catch_up<CT>(unit, t); },
      [&](uint32_t pos, int len) SPIKEMS_INLINE_LAMBDA {
        __builtin_prefetch(&last_[pos >> unit_shift_], 1);
        for (int j = 0; j < len * C; j += 16) {
          __builtin_prefetch(&a1_[size_t(pos) * C + size_t(j)], 1);
          __builtin_prefetch(&r0_[size_t(pos) * C + size_t(j)], 1);
        }
      });

  // Every unit reached or active is now at step t: one pass in address order.
  const size_t n0 = next.size();
  for (size_t w = 0; w < active_bits_.size(); ++w) {
    const uint64_t aw = active_bits_[w], m = touched_bits_[w] | aw;
    if (m == 0) continue;
    touched_bits_[w] = 0;
    visits_ += uint64_t(std::popcount(m)) << unit_shift_;
    uint64_t keep = 0;
    for (uint64_t mm = m; mm != 0; mm &= mm - 1) {
      const int b = std::countr_zero(mm);
      if (update<CT>(uint32_t(w * 64 + size_t(b)), t, next)) keep |= uint64_t(1) << b;
    }
    active_count_ += size_t(std::popcount(keep));
    active_count_ -= size_t(std::popcount(aw));
    active_bits_[w] = keep;
  }
  ahead_ = next.size() - n0;
  spikes_ += ahead_;
}

float IirStreamingLayer::potential(int64_t t, uint32_t neuron) const {
  const uint32_t unit = neuron / uint32_t(lanes_);
  if (record_ && eval_step_[unit] == t) return u_eval_[neuron];
  const int64_t d = t - last_[unit];
  const double a1 = a1_[neuron], b0 = b0_[neuron], r0 = r0_[neuron];
  const double g = std::pow(a_, double(d)), gr = std::pow(ar_, double(d));
  const double psp = cs_ * g * (a1 + double(d) * b0);
  const double ref =
      slayer_ref_ ? cref_ * gr * (double(r1_[neuron]) + double(d) * r0) : cref_ * gr * r0;
  return float(psp + ref);
}

}  // namespace spikems
