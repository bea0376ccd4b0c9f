#include "core/runtime/iir_streaming_layer.h"

#include <algorithm>
#include <bit>
#include <cstdint>
#include <limits>

#include "core/util/error.h"

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
//
// Stored scaled, in units of potential: cs*a1 and cs*b0 (the weights are multiplied by cs
// once, at load time) and cref*r0 (cref*r1), so that u = a1 + r (two multiplications fewer
// per neuron and step) and a spike adds cref*inc to r0.

IirStreamingLayer::IirStreamingLayer(const LayerSpec& l, double ts, int hin, int win, int need_h,
                                     int need_w)
    : StreamingLayer(l, hin, win, need_h, need_w),
      a_(std::exp(-ts / double(l.neuron.tau_s))),
      ar_(std::exp(-ts / double(l.neuron.tau_r))),
      slayer_ref_(l.neuron.refractory == RefractoryShape::Slayer) {
  cs_ = std::exp(1.0) * ts / double(l.neuron.tau_s);
  const double mult = -double(l.neuron.scale_ref) * double(l.neuron.theta);
  cref_ = slayer_ref_ ? mult * std::exp(1.0) * ts / double(l.neuron.tau_r) : mult;
  double m = 0;
  for (int n = 1; n < 1 << 20; ++n) {
    const double v = n * std::pow(a_, n);
    if (v < m) break;  // n a^n rises to its peak, then falls
    m = v;
  }
  bound_a1_ = float(a_);  // the state carries cs
  bound_b0_ = float(m);
  // A spike adds 1 (SLAYER's form) or 1/ar (SpikeMS form: it enters at t+2) to r0, in cref units.
  spike_inc_ = float((slayer_ref_ ? 1.0 : 1.0 / ar_) * cref_);
  for (float& w : wseg_) w = float(double(w) * cs_);
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
  // Units: 16/C positions when C divides 16, so that a unit is one vector of 16 lanes, and a
  // run's k*C weights fit one vector (add_drive_units() moves them into the unit with one
  // permutation); otherwise one position.
  const int C = cout_;
  const int per_unit = (C < 16 && 16 % C == 0 && k_ * C <= 16) ? 16 / C : 1;
  unit_shift_ = std::countr_zero(unsigned(per_unit));
  lanes_ = per_unit * C;
  const size_t npos = size_t(hout_) * wout_;
  const size_t units = ((npos + size_t(per_unit) - 1) / size_t(per_unit) + 63) / 64 * 64;
  const size_t n = units * size_t(lanes_);
  nvars_ = slayer_ref_ ? 4 : 3;
  state_.assign(n * size_t(nvars_));
  last_.assign(units);
  for (size_t i = 0; i < units; ++i)
    last_[i] = std::numeric_limits<int64_t>::min() / 4;  // state is 0: any gap works
  active_bits_.assign(units / 64, 0);
  scratch_.assign(2 * size_t(lanes_), 0.f);
  spike_buf_.assign(n + 16);  // every neuron at most once per step, + compress()'s spare
  if (unit_shift_ > 0) prepare_unit_weights(unit_shift_);
  // A float per neuron, + the spare floats of whole blocks past a run.
  drive_.assign(n + 16 * size_t(std::max(unit_blocks_, 1)) + 64);
  zero_drive_.assign(2 * size_t(lanes_));  // zeros to read, then a block to write to
  if (l.neuron.discretisation == Discretisation::FIR) {
    if (!runs_fir(l, ts)) fail("runtime", "", "internal: this FIR layer needs the ring form");
    fir_k_ = int(l.srm_kernel.size());
    fir_r_ = int(l.ref_kernel.size());
    // In the scaled units of the state (see the top): the drive is cs*I, r0 is cref*r.
    expire_b0_ = float(std::pow(a_, double(fir_k_)));
    expire_a1_ = float(double(fir_k_) * std::pow(a_, double(fir_k_)));
    expire_ref_ = float(cref_ * std::pow(ar_, double(fir_r_ - 1)));
    drive_log_.resize(size_t(fir_k_));
    for (DriveLog& g : drive_log_) {  // empty: a sentinel unit only
      g.units.assign(1, ~uint32_t(0));
      g.drive.assign(size_t(lanes_), 0.f);
    }
    spike_log_.resize(size_t(fir_r_) + 1);
    expire_bits_.assign(active_bits_.size(), 0);
  }
}

bool IirStreamingLayer::runs_fir(const LayerSpec& l, double ts) {
  const int C = l.out_channels;
  const bool whole_vectors = C == 16 || C == 32 || C == 64 || (C == 2 && l.kernel * C <= 16);
  return l.neuron.discretisation == Discretisation::FIR &&
         l.neuron.refractory == RefractoryShape::SpikeMS && whole_vectors &&
         l.srm_kernel.size() >= 2 && !l.ref_kernel.empty() && has_sampled_kernels(l, ts);
}

void IirStreamingLayer::record_potentials(bool on) {
  record_ = on;
  if (on && u_eval_.empty()) {
    u_eval_.assign(out_neurons(), 0.f);
    eval_step_.assign(last_.size(), -1);
  }
}

void IirStreamingLayer::record(uint32_t unit, const float* u, int64_t t, int c0, int n) {
  const size_t first = size_t(unit) * size_t(lanes_) + size_t(c0);
  const size_t end = std::min(first + size_t(n), out_neurons());
  if (end > first) std::copy(u, u + (end - first), &u_eval_[first]);
  eval_step_[unit] = t;
}

void IirStreamingLayer::step(int64_t t, const uint32_t* s, size_t n, std::vector<uint32_t>& next) {
  switch (isa_) {
    case simd::Isa::Avx512:
      step_avx512(t, s, n, next);
      break;
    case simd::Isa::Avx2:
      step_avx2(t, s, n, next);
      break;
    default:
      step_default(t, s, n, next);
      break;
  }
}

namespace {
// A unit's lanes for a compile-time channel count CT (0: not known): 16 when 16/CT positions
// share a unit, CT otherwise.
template <int CT>
constexpr int unit_lanes() {
  if constexpr (CT == 0)
    return 0;
  else
    return CT < 16 && 16 % CT == 0 ? 16 : CT;
}

// with_channels() and 4-channel layers where a unit holds 4 positions (quarter-width
// networks: their generic loops cost ~1.8x). 8 channels with 3x3 kernels keep one position per
// unit (3 taps x 8 do not fit one vector): a constant trip count did not help them (measured).
// Channel counts below 16 whose units are not 16 lanes (kernels too wide) take the generic loops.
template <class F>
SPIKEMS_INLINE void with_unit_channels(int c, int lanes, F&& f) {
  if (c == 4 && lanes == 16)
    f(std::integral_constant<int, 4>{});
  else if (c < 16 && lanes != 16)
    f(std::integral_constant<int, 0>{});
  else
    with_channels(c, std::forward<F>(f));
}
}  // namespace

// One copy of the step per instruction set; -ffp-contract=off keeps a*b+c unfused in all,
// so that results do not depend on the CPU.
SPIKEMS_TARGET_AVX512 void IirStreamingLayer::step_avx512(int64_t t, const uint32_t* s, size_t n,
                                                          std::vector<uint32_t>& next) {
  with_unit_channels(cout_, lanes_, [&](auto ct) SPIKEMS_INLINE_LAMBDA {
    step_ct<ct(), simd::Isa::Avx512>(t, s, n, next);
  });
}
SPIKEMS_TARGET_AVX2 void IirStreamingLayer::step_avx2(int64_t t, const uint32_t* s, size_t n,
                                                      std::vector<uint32_t>& next) {
  with_unit_channels(cout_, lanes_, [&](auto ct) SPIKEMS_INLINE_LAMBDA {
    step_ct<ct(), simd::Isa::Avx2>(t, s, n, next);
  });
}
void IirStreamingLayer::step_default(int64_t t, const uint32_t* s, size_t n,
                                     std::vector<uint32_t>& next) {
  with_unit_channels(cout_, lanes_, [&](auto ct) SPIKEMS_INLINE_LAMBDA {
    step_ct<ct(), simd::Isa::Default>(t, s, n, next);
  });
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
// active units are). For units that are not whole 16-lane vectors.
template <int CT>
SPIKEMS_INLINE void IirStreamingLayer::catch_up(uint32_t unit, int64_t t) {
  int64_t& last = last_[unit];
  const int64_t d = t - last;
  if (d == 0) return;
  last = t;
  constexpr int LT = unit_lanes<CT>();
  const int L = LT ? LT : lanes_;
  const float g = decay(d), gr = ref_decay(d), fd = float(d);
  float* __restrict a1 = record_of(unit, L);
  float* __restrict b0 = a1 + L;
  float* __restrict r0 = a1 + 2 * L;
  for (int c = 0; c < L; ++c) {
    a1[c] = g * (a1[c] + fd * b0[c]);
    b0[c] = g * b0[c];
  }
  if (slayer_ref_) {
    float* __restrict r1 = a1 + 3 * L;
    for (int c = 0; c < L; ++c) r1[c] = gr * (r1[c] + fd * r0[c]);
  }
  for (int c = 0; c < L; ++c) r0[c] = gr * r0[c];
}

// One unit from step t to t+1: writes its spikes of t+1 at out; returns whether it stays
// active. For units that are not whole 16-lane vectors (advance_unit() does the others).
template <int CT>
SPIKEMS_INLINE bool IirStreamingLayer::update(uint32_t unit, int64_t t, uint32_t*& out) {
  constexpr int LT = unit_lanes<CT>();
  const int L = LT ? LT : lanes_;
  const size_t o = size_t(unit) * size_t(L);
  const float g1 = decay(1), gr1 = ref_decay(1);
  const float ba = bound_a1_, bb = bound_b0_;
  float* __restrict a1 = record_of(unit, L);
  float* __restrict b0 = a1 + L;
  float* __restrict r0 = a1 + 2 * L;
  float* __restrict u = scratch_.data();
  float* __restrict bnd = scratch_.data() + L;
  if (slayer_ref_) {
    float* __restrict r1 = a1 + 3 * L;
    for (int c = 0; c < L; ++c) {
      r1[c] = gr1 * (r1[c] + r0[c]);
      r0[c] = gr1 * r0[c];
    }
  } else {
    for (int c = 0; c < L; ++c) r0[c] = gr1 * r0[c];
  }
  const float* __restrict r = slayer_ref_ ? a1 + 3 * L : r0;
  bool reach = false;
  for (int c = 0; c < L; ++c) {
    const float x = g1 * (a1[c] + b0[c]), y = g1 * b0[c];
    a1[c] = x;
    b0[c] = y;
    u[c] = x + r[c];
    bnd[c] = ba * std::max(x, 0.f) + bb * std::max(y, 0.f);
  }
  last_[unit] = t + 1;
  if (record_) record(unit, u, t + 1, 0, L);
  // Lanes past the last position (a partial last unit) hold zeros and never reach theta > 0.
  for (int c0 = 0; c0 < L; c0 += 64) {
    const int len = std::min(64, L - c0);
    for (uint64_t f = at_least(u + c0, theta_, len); f != 0; f &= f - 1) {
      const int c = c0 + std::countr_zero(f);
      *out++ = uint32_t(o) + uint32_t(c);
      r0[c] += spike_inc_;  // the spike's refractory response starts at t+2
    }
    reach |= at_least(bnd + c0, bound_theta_, len) != 0;
  }
  return reach;
}

// One unit of the fused pass when a unit is a whole number of 16-lane blocks (L known at
// compile time): catch-up, this step's drive and the step to t+1, the same arithmetic as
// catch_up() and update() with each block kept in registers from its load to its store.
template <int L, simd::Isa I, bool kFir, bool kRef>
SPIKEMS_INLINE bool IirStreamingLayer::advance_unit(size_t unit, int64_t t, const float* drive,
                                                    float* sink, const PassConsts& k,
                                                    uint32_t*& out, const float* expire,
                                                    uint64_t ref_lanes) {
  using simd::F16;
  const size_t o = unit * size_t(L);
  float* const rec = k.state + unit * k.record_floats;
  // From the unit's last step to t+1 in one go (d + 1 steps; d = 0 for active units), with
  // this step's drive D entering at t: a1 <- G (a1 + (d+1) b0) + g1 D and b0 <- G b0 + g1 D,
  // G = a^(d+1), the closed forms of d steps, the drive, and one step; likewise the
  // refractory state (GR = ar^(d+1)). A unit not reached reads a block of zeros for D, so that
  // whether a unit was reached (data the branch predictor cannot learn) is not a branch.
  const int64_t d1 = t - k.last[unit] + 1;
  const F16 G = simd::splat<I>(d1 < k.n_a ? k.pow_a[d1] : decay(d1)),
            GR = simd::splat<I>(d1 < k.n_ar ? k.pow_ar[d1] : ref_decay(d1)),
            fd1 = simd::splat<I>(float(d1));
  bool reach = false;
  const F16 zero = {};
  for (int c0 = 0; c0 < L; c0 += 16) {
    F16& a1m = *reinterpret_cast<F16*>(rec + c0);
    F16& b0m = *reinterpret_cast<F16*>(rec + L + c0);
    F16& r0m = *reinterpret_cast<F16*>(rec + 2 * L + c0);
    F16& r1m = *reinterpret_cast<F16*>(rec + 3 * L + c0);  // SLAYER's form only
    const F16 a1 = a1m, b0 = b0m, r0 = r0m;
    const F16 gd = k.g1 * simd::load(drive + c0);
    simd::store(sink + c0, zero);  // the drive buffer stays zero between steps
    F16 rv;
    if (k.slayer) {
      rv = GR * (r1m + fd1 * r0);
      r1m = rv;
    } else {
      rv = GR * r0;
    }
    F16 x = G * (a1 + fd1 * b0) + gd, y = G * b0 + gd;
    if constexpr (kFir) {
      // The drive of K steps before leaves the psp, the spikes of R steps before the
      // refractory response (SpikeMS form: rv is r0).
      const F16 e = simd::load(expire + c0);
      x -= k.xa1 * e;
      y -= k.xb0 * e;
      if constexpr (kRef) {
        // Lane c takes bit c of the block's mask (broadcast through a float splat, see splat<I>).
        const simd::I16 bits =
            simd::I16(simd::splat<I>(std::bit_cast<float>(uint32_t(ref_lanes >> c0))));
        rv -= simd::F16(((bits & k.lane_bit) != 0) & simd::I16(k.xref));
      }
    }
    const F16 r0n = k.slayer ? GR * r0 : rv;
    a1m = x;
    b0m = y;
    const F16 uv = x + rv;
    const F16 bv = k.ba * (x < zero ? zero : x) + k.bb * (y < zero ? zero : y);
    reach |= simd::at_least<I>(bv, k.btheta) != 0;
    if (k.record) {
      alignas(64) float ul[16];
      *reinterpret_cast<F16*>(ul) = uv;
      record(uint32_t(unit), ul, t + 1, c0, 16);
    }
    r0m = uv >= k.theta ? r0n + k.inc : r0n;  // a spike's refractory response starts at t+2
    out = simd::compress<I>(out, simd::at_least<I>(uv, k.theta), uint32_t(o) + uint32_t(c0));
  }
  k.last[unit] = t + 1;
  return reach;
}

template <int CT, simd::Isa I>
SPIKEMS_INLINE void IirStreamingLayer::step_ct(int64_t t, const uint32_t* spikes, size_t n,
                                               std::vector<uint32_t>& next) {
  constexpr int LT = unit_lanes<CT>();
  if constexpr (LT != 0 && LT % 16 == 0 && LT <= 64) {
    if (fir_k_ > 0) {
      step_c<CT, I, true>(t, spikes, n, next);
      return;
    }
  }
  step_c<CT, I, false>(t, spikes, n, next);
}

template <int CT, simd::Isa I, bool kFir>
SPIKEMS_INLINE void IirStreamingLayer::step_c(int64_t t, const uint32_t* spikes, size_t n,
                                              std::vector<uint32_t>& next) {
  constexpr int LT = unit_lanes<CT>();
  constexpr bool kVector = LT != 0 && LT % 16 == 0;
  static_assert(!kFir || (kVector && LT <= 64), "FIR expiry needs whole vectors, <= 64 lanes");
  const size_t L = size_t(LT ? LT : lanes_);
  const size_t words = active_bits_.size();
  uint64_t* __restrict tb = touched_bits_.data();
  uint64_t* __restrict ab = active_bits_.data();

  // 1. The drive of step t, summed per unit into a dense buffer (a float per neuron, zero
  // between steps), marking the units it reaches on the way.
  group_spikes(spikes, n);
  float* drive = drive_.data();
  auto at = [&](uint32_t u) SPIKEMS_INLINE_LAMBDA { return drive + size_t(u) * L; };
  // The lines a run will add to, requested kDriveAhead groups early.
  auto ahead = [&](uint32_t op, uint32_t len) SPIKEMS_INLINE_LAMBDA {
    const float* d = at(op);
    for (size_t j = 0; j < size_t(len) * L; j += 16) __builtin_prefetch(d + j, 1);
  };
  constexpr int kDriveAhead = 8;
  auto dense = [&]() SPIKEMS_INLINE_LAMBDA {
    if (scattered_input_)
      add_drive<CT, true, kDriveAhead>(spikes, at, ahead);
    else
      add_drive<CT, true>(spikes, at);
  };
  if constexpr (CT == 0 || (CT < 16 && unit_lanes<CT>() == 16)) {
    if (unit_shift_ > 0)
      add_drive_units<CT, true>(spikes, at);  // L = 16 lanes per unit
    else
      dense();
  } else {
    dense();
  }
  // 2. One pass in address order over the units reached or active: each goes to step t+1,
  // taking its drive. Every state line is loaded and stored once. A layer's state is larger
  // than the caches (and the other layers evict it between steps), so the state of the unit
  // kAhead visits on is requested now, to keep many independent misses in flight: a second
  // cursor walks the same bitmaps ahead of the pass.
  constexpr int kAhead = 32;
  auto fetch = [&](size_t unit) SPIKEMS_INLINE_LAMBDA {
    __builtin_prefetch(&last_[unit], 1);
    const size_t o = unit * L;
    for (size_t j = 0; j < L; j += 16) __builtin_prefetch(&drive[o + j], 1);
    const float* rec = record_of(unit, L);
    for (size_t j = 0; j < size_t(nvars_) * L; j += 16) __builtin_prefetch(rec + j, 1);
  };
  // FIR: the units whose drive of K-1 steps before, or spikes of R steps before, expire at
  // t+1 are visited too (expire_bits_), whether reached or active or not.
  uint64_t* __restrict xb = expire_bits_.data();
  const DriveLog* xlog = nullptr;
  DriveLog* wlog = nullptr;
  if constexpr (kFir) {
    const auto ring = [&](int m) { return size_t(((t % m) + m) % m); };             // t's slot of m
    xlog = &drive_log_[ring(fir_k_) == size_t(fir_k_ - 1) ? 0 : ring(fir_k_) + 1];  // t-K+1
    wlog = &drive_log_[ring(fir_k_)];
    for (size_t i = 0; i < xlog->n; ++i)
      xb[xlog->units[i] >> 6] |= uint64_t(1) << (xlog->units[i] & 63);
    // The spikes of R steps before as (unit, lanes) pairs in unit order, and a sentinel.
    ref_units_.clear();
    ref_lanes_.clear();
    for (uint32_t nrn : spike_log_[(ring(fir_r_ + 1) + 1) % size_t(fir_r_ + 1)]) {  // t-R
      const uint32_t u = nrn / uint32_t(L);
      if (ref_units_.empty() || ref_units_.back() != u) {
        ref_units_.push_back(u);
        ref_lanes_.push_back(0);
        xb[u >> 6] |= uint64_t(1) << (u & 63);
      }
      ref_lanes_.back() |= uint64_t(1) << (nrn % uint32_t(L));
    }
    ref_units_.push_back(~uint32_t(0));
    ref_lanes_.push_back(0);
  }
  auto marks = [&](size_t w) SPIKEMS_INLINE_LAMBDA {
    if constexpr (kFir) return tb[w] | ab[w] | xb[w];
    return tb[w] | ab[w];
  };
  size_t ahead_word = 0;
  uint64_t ahead_bits = words ? marks(0) : 0;
  auto fetch_next = [&]() SPIKEMS_INLINE_LAMBDA {
    while (ahead_bits == 0) {
      if (++ahead_word >= words) return;
      ahead_bits = marks(ahead_word);
    }
    fetch(ahead_word * 64 + size_t(std::countr_zero(ahead_bits)));
    ahead_bits &= ahead_bits - 1;
  };
  for (int i = 0; i < kAhead; ++i) fetch_next();
  PassConsts k;
  if constexpr (kVector) {
    k.g1 = simd::splat<I>(decay(1));
    k.ba = simd::splat<I>(bound_a1_);
    k.bb = simd::splat<I>(bound_b0_);
    k.inc = simd::splat<I>(spike_inc_);
  }
  k.theta = theta_;
  k.btheta = bound_theta_;
  k.slayer = slayer_ref_;
  k.record = record_;
  k.state = state_.data();
  k.last = last_.data();
  k.record_floats = size_t(nvars_) * L;
  k.pow_a = pow_a_.data();
  k.pow_ar = pow_ar_.data();
  k.n_a = int64_t(pow_a_.size());
  k.n_ar = int64_t(pow_ar_.size());
  if constexpr (kFir) {
    k.xa1 = simd::splat<I>(expire_a1_);
    k.xb0 = simd::splat<I>(expire_b0_);
    k.xref = simd::splat<I>(expire_ref_);
    k.lane_bit =
        simd::I16{1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 1024, 2048, 4096, 8192, 16384, 32768};
    // Room for every unit the drive reached, the last visit's discarded entry and a sentinel
    // (grown, never shrunk: no per-unit growth checks).
    size_t reached = 2;
    for (size_t w = 0; w < words; ++w) reached += size_t(std::popcount(tb[w]));
    if (wlog->units.size() < reached) {
      wlog->units.resize(reached + reached / 2);
      wlog->drive.resize(wlog->units.size() * L);
    }
  }
  // Cursors in the expiring drive log and the spikes' units (both in unit order, each ending in
  // a sentinel unit), and the log being written (every visit writes an entry, which only a
  // unit the drive reached keeps: no branch).
  const uint32_t* xu = nullptr;
  const float* xd = nullptr;
  const uint32_t* ru = ref_units_.data();
  const uint64_t* rl = ref_lanes_.data();
  uint32_t* wu = nullptr;
  float* wd = nullptr;
  size_t xi = 0, ri = 0, wn = 0;
  if constexpr (kFir) {
    xu = xlog->units.data();
    xd = xlog->drive.data();
    wu = wlog->units.data();
    wd = wlog->drive.data();
  }
  float* const zeros = zero_drive_.data();
  uint32_t* out = spike_buf_.data();
  size_t visited = 0;
  for (size_t w = 0; w < words; ++w) {
    const uint64_t tw = tb[w], aw = ab[w], m = marks(w);
    if (m == 0) continue;
    tb[w] = 0;
    if constexpr (kFir) xb[w] = 0;
    visited += size_t(std::popcount(m));
    uint64_t keep = 0;
    for (uint64_t mm = m; mm != 0; mm &= mm - 1) {
      const int b = std::countr_zero(mm);
      const size_t unit = w * 64 + size_t(b);
      bool reach;
      fetch_next();
      if constexpr (kVector) {
        const size_t hit = size_t((tw >> b) & 1);
        float* const slot = drive + unit * L;
        float* const d = hit ? slot : zeros;
        float* const sink = hit ? slot : zeros + LT;
        if constexpr (kFir) {
          // The drive, logged for its expiry K-1 passes on.
          wu[wn] = uint32_t(unit);
          for (int c0 = 0; c0 < LT; c0 += 16)
            simd::store(wd + LT * wn + size_t(c0), simd::load(slot + c0));
          wn += hit;
          const size_t ex = xu[xi] == unit, rr = ru[ri] == unit;
          const float* expire = ex ? xd + LT * xi : zeros;
          const uint64_t ref_lanes = rr ? rl[ri] : 0;
          xi += ex;
          ri += rr;
          reach = rr ? advance_unit<LT, I, true, true>(unit, t, d, sink, k, out, expire, ref_lanes)
                     : advance_unit<LT, I, true, false>(unit, t, d, sink, k, out, expire);
        } else {
          reach = advance_unit<LT, I>(unit, t, d, sink, k, out);
        }
      } else {
        if ((tw >> b) & 1) {
          catch_up<CT>(uint32_t(unit), t);
          float* b0 = record_of(unit, L) + L;
          float* dd = drive + unit * L;
          for (size_t c = 0; c < L; ++c) {
            b0[c] += dd[c];
            dd[c] = 0.f;
          }
        }
        reach = update<CT>(uint32_t(unit), t, out);
      }
      keep |= uint64_t(reach) << b;
    }
    active_count_ += size_t(std::popcount(keep));
    active_count_ -= size_t(std::popcount(aw));
    ab[w] = keep;
  }
  visits_ += uint64_t(visited) << unit_shift_;
  const size_t nout = size_t(out - spike_buf_.data());
  next.insert(next.end(), spike_buf_.data(), out);
  if constexpr (kFir) {  // the log's end: its count and a sentinel unit
    wlog->n = wn;
    wu[wn] = ~uint32_t(0);
  }
  if constexpr (kFir)  // the spikes of t+1, whose refractory response expires at t+1+R
    spike_log_[size_t(((t % (fir_r_ + 1)) + fir_r_ + 1) % (fir_r_ + 1))].assign(spike_buf_.data(),
                                                                                out);
  ahead_ = nout;
  spikes_ += ahead_;
}

float IirStreamingLayer::potential(int64_t t, uint32_t neuron) const {
  const uint32_t unit = neuron / uint32_t(lanes_);
  if (record_ && eval_step_[unit] == t) return u_eval_[neuron];
  const int64_t d = t - last_[unit];
  const size_t L = size_t(lanes_);
  const float* rec = record_of(unit, L) + neuron % L;
  const double a1 = rec[0], b0 = rec[L], r0 = rec[2 * L];
  const double g = std::pow(a_, double(d)), gr = std::pow(ar_, double(d));
  const double psp = g * (a1 + double(d) * b0);  // the state is scaled (see the top)
  const double ref = slayer_ref_ ? gr * (double(rec[3 * L]) + double(d) * r0) : gr * r0;
  return float(psp + ref);
}

}  // namespace spikems
