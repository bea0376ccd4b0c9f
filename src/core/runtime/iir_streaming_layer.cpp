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
  const size_t npos = size_t(hout_) * wout_;
  stride_ = size_t(slayer_ref_ ? 4 : 3) * cout_;
  if (stride_ >= 16) stride_ = (stride_ + 15) / 16 * 16;
  state_.assign(npos * stride_);
  base_ = state_.data();
  last_.assign(npos);
  for (size_t i = 0; i < npos; ++i)
    last_[i] = std::numeric_limits<int64_t>::min() / 4;  // state is 0: any gap works
  active_bits_.assign((npos + 63) / 64, 0);
  scratch_.assign(size_t(cout_), 0.f);
}

void IirStreamingLayer::record_potentials(bool on) {
  record_ = on;
  if (on && u_eval_.empty()) {
    u_eval_.assign(out_neurons(), 0.f);
    eval_step_.assign(size_t(hout_) * wout_, -1);
  }
}

void IirStreamingLayer::step(int64_t t, const uint32_t* s, size_t n, std::vector<uint32_t>& next) {
  step_all(t, s, n, next);
}

SPIKEMS_MULTIVERSION void IirStreamingLayer::step_all(int64_t t, const uint32_t* s, size_t n,
                                                      std::vector<uint32_t>& next) {
  with_channels(cout_, [&](auto ct) SPIKEMS_INLINE_LAMBDA { step_c<ct()>(t, s, n, next); });
}

// d >= 1 steps on without drive.
template <int CT>
SPIKEMS_INLINE void IirStreamingLayer::advance(float* st, int64_t d) const {
  advance_by<CT>(st, decay(d), ref_decay(d), float(d));
}

// The same with g = a^d, gr = ar^d, fd = d given.
template <int CT>
SPIKEMS_INLINE void IirStreamingLayer::advance_by(float* st, float g, float gr, float fd) const {
  const int C = CT ? CT : cout_;
  float* __restrict a1 = st;
  float* __restrict b0 = st + C;
  float* __restrict r0 = st + 2 * C;
  for (int c = 0; c < C; ++c) {
    a1[c] = g * (a1[c] + fd * b0[c]);
    b0[c] = g * b0[c];
  }
  if (slayer_ref_) {
    float* __restrict r1 = st + 3 * C;
    for (int c = 0; c < C; ++c) {
      r1[c] = gr * (r1[c] + fd * r0[c]);
      r0[c] = gr * r0[c];
    }
  } else {
    for (int c = 0; c < C; ++c) r0[c] = gr * r0[c];
  }
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

template <int CT>
SPIKEMS_INLINE bool IirStreamingLayer::may_reach_theta(const float* st) const {
  const int C = CT ? CT : cout_;
  const float* __restrict a1 = st;
  const float* __restrict b0 = st + C;
  int reach = 0;
  for (int c = 0; c < C; ++c) {
    const float p1 = std::max(a1[c], 0.f), p0 = std::max(b0[c], 0.f);
    reach |= bound_a1_ * p1 + bound_b0_ * p0 >= bound_theta_;
  }
  return reach != 0;
}

template <int CT>
SPIKEMS_INLINE void IirStreamingLayer::step_c(int64_t t, const uint32_t* spikes, size_t n,
                                              std::vector<uint32_t>& next) {
  const int C = CT ? CT : cout_;
  scatter_drive<CT>(spikes, n);

  // One pass over the touched and active positions, in address order.
  float u_local[CT ? CT : 1];
  float* __restrict u = CT ? u_local : scratch_.data();
  const float th = theta_, inc = spike_inc_, cs = cs_f_, cref = cref_f_;
  const float g1 = decay(1), gr1 = ref_decay(1);
  const size_t nwords = active_bits_.size();
  const size_t n0 = next.size();
  auto prefetch_word = [&](size_t w) SPIKEMS_INLINE_LAMBDA {
    for (uint64_t m = touched_bits_[w] | active_bits_[w]; m != 0; m &= m - 1) {
      const uint32_t pos = uint32_t(w * 64 + size_t(std::countr_zero(m)));
      const float* st = state(pos);
      for (size_t off = 0; off < stride_; off += 16) __builtin_prefetch(st + off, 1);
    }
  };
  for (size_t w = 0; w < nwords; ++w) {
    const uint64_t tw = touched_bits_[w], aw = active_bits_[w];
    if ((tw | aw) == 0) continue;
    if (w + 1 < nwords) prefetch_word(w + 1);
    touched_bits_[w] = 0;
    uint64_t keep = 0;
    for (uint64_t m = tw | aw; m != 0; m &= m - 1) {
      const int b = std::countr_zero(m);
      const uint32_t pos = uint32_t(w * 64 + size_t(b));
      float* st = state(pos);
      if ((tw >> b) & 1) {
        const int64_t d = t - last_[pos];  // >= 0: no position is ahead of t here
        if (d > 0) advance<CT>(st, d);     // as of t
        float* __restrict b0 = st + C;
        float* __restrict in = &drive_[size_t(pos) * C];
        for (int c = 0; c < C; ++c) {
          b0[c] += in[c];
          in[c] = 0.f;  // drive_ stays zero outside marked positions
        }
        if (!((aw >> b) & 1) && !may_reach_theta<CT>(st)) {
          last_[pos] = t;  // stays idle, expressed as of t
          continue;
        }
      }
      advance_by<CT>(st, g1, gr1, 1.f);  // as of t+1
      last_[pos] = t + 1;
      const float* __restrict a1 = st;
      float* __restrict r0 = st + 2 * C;
      const float* __restrict r = slayer_ref_ ? st + 3 * C : r0;
      for (int c = 0; c < C; ++c) u[c] = cs * a1[c] + cref * r[c];
      if (record_) {
        std::copy(u, u + C, &u_eval_[size_t(pos) * C]);
        eval_step_[pos] = t + 1;
      }
      const uint32_t first = pos * uint32_t(C);
      if (CT != 0 || C <= 64) {
        for (uint64_t f = at_least(u, th, C); f != 0; f &= f - 1) {
          const int c = std::countr_zero(f);
          next.push_back(first + uint32_t(c));
          r0[c] += inc;  // the spike's refractory response starts at t+2
        }
      } else {
        for (int c = 0; c < C; ++c)
          if (u[c] >= th) {
            next.push_back(first + uint32_t(c));
            r0[c] += inc;
          }
      }
      if (may_reach_theta<CT>(st)) keep |= uint64_t(1) << b;
    }
    active_count_ += size_t(std::popcount(keep));
    active_count_ -= size_t(std::popcount(aw));
    active_bits_[w] = keep;
  }
  ahead_ = next.size() - n0;
  spikes_ += ahead_;
}

float IirStreamingLayer::potential(int64_t t, uint32_t neuron) const {
  const uint32_t pos = neuron / uint32_t(cout_);
  if (record_ && eval_step_[pos] == t) return u_eval_[neuron];
  const size_t C = size_t(cout_), c = neuron % uint32_t(cout_);
  const float* st = state(pos);
  const int64_t d = t - last_[pos];
  const double a1 = st[c], b0 = st[C + c], r0 = st[2 * C + c];
  const double g = std::pow(a_, double(d)), gr = std::pow(ar_, double(d));
  const double psp = cs_ * g * (a1 + double(d) * b0);
  const double ref =
      slayer_ref_ ? cref_ * gr * (double(st[3 * C + c]) + double(d) * r0) : cref_ * gr * r0;
  return float(psp + ref);
}

}  // namespace spikems
