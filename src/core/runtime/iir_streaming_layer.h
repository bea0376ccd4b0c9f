// IIR neurons (the exact recursions of the continuous kernels), event-driven.
//
// Per neuron: the alpha psp as two state variables (a1, b0), the refractory response as one
// (SpikeMS form, r0) or two (SLAYER's alpha form, r1 and r0), advanced lazily in closed form
// over skipped steps. The variables of a unit (below) are kept together in one record.
//
// The state is kept per *unit*: one position, or 16/C consecutive positions when C divides 16
// and k*C <= 16 (the output layer's two channels: 8 positions), so that a unit is a whole
// vector of lanes. A unit's record holds its lanes of a1, then of b0, r0 (and r1): a visit
// touches one run of consecutive lines (one line in each of three or four arrays before:
// 4-15 % slower in the whole pipeline).
//
// A step has two parts. (1) drive: the weights of each input spike summed into a dense
// buffer (one float per neuron, zero between steps), marking the units reached in a bitmap
// on the way. (2) one pass in address order over every unit reached or still "active" (a
// cheap upper bound on its future psp reaches theta; refractory terms are never positive):
// a unit goes from its last step to t+1 in closed form, taking its drive at t (a block of
// zeros when not reached: no branch the predictor would miss), and the neurons whose
// potential reaches theta spike at t+1. Each state line is read and written once per step,
// requested a few dozen units ahead (a second cursor over the same bitmaps) so that the
// cache misses overlap. Idle and decaying neurons cost nothing, and the spikes come out
// sorted. The pass is compiled per instruction set (AVX-512, AVX2, baseline: compares into
// bit masks, spikes written with a compress on AVX-512).
//
// FIR layers whose kernels are the sampled ones (the authors' model) run here too, as the same
// recursions with *expiry*: the FIR kernels are the IIR ones cut after K (psp) and R
// (refractory) taps, and a drive I entering at step j contributes exactly a^K I to b0 and
// K a^K I to a1 at step j+K, a spike at s exactly cref ar^(R-1) to r0 at s+R. So each step's
// drive is logged per reached unit, and K-1 passes later those units are visited again and the
// two terms subtracted (likewise the spikes of R steps before): every expiry is applied at its
// exact step, so the state always holds the FIR potential and the activity bound holds
// between expiries. (A ring of K future potentials per neuron, fir_streaming_layer.h, costs
// 5-10x more.)
#pragma once

#include <cmath>

#include "core/runtime/streaming_layer.h"
#include "core/util/huge_buffer.h"

namespace spikems {

class IirStreamingLayer final : public StreamingLayer {
 public:
  // An IIR layer, or a FIR layer that runs_fir() accepts.
  IirStreamingLayer(const LayerSpec& l, double time_step_ms, int hin, int win, int need_h = -1,
                    int need_w = -1);
  // Whether a FIR layer can run here (with expiry): kernels sampled from its neuron
  // parameters, the SpikeMS refractory form, and 2, 16, 32 or 64 channels (whole vectors).
  static bool runs_fir(const LayerSpec& l, double time_step_ms);
  void step(int64_t t, const uint32_t* spikes, size_t n, std::vector<uint32_t>& next) override;
  void record_potentials(bool on) override;
  float potential(int64_t t, uint32_t neuron) const override;
  size_t busy_positions() const override { return active_count_ << unit_shift_; }
  // Runs the step compiled for `isa` (tests compare them: spikes must not depend on the CPU).
  // Returns false, changing nothing, when this CPU cannot run it.
  bool set_isa(simd::Isa isa) {
    if (int(isa) > int(simd::best_isa())) return false;
    isa_ = isa;
    return true;
  }

 private:
  SPIKEMS_TARGET_AVX512 void step_avx512(int64_t t, const uint32_t* spikes, size_t n,
                                         std::vector<uint32_t>& next);
  SPIKEMS_TARGET_AVX2 void step_avx2(int64_t t, const uint32_t* spikes, size_t n,
                                     std::vector<uint32_t>& next);
  void step_default(int64_t t, const uint32_t* spikes, size_t n, std::vector<uint32_t>& next);
  template <int CT, simd::Isa I>
  void step_ct(int64_t t, const uint32_t* spikes, size_t n, std::vector<uint32_t>& next);
  template <int CT, simd::Isa I, bool kFir>
  void step_c(int64_t t, const uint32_t* spikes, size_t n, std::vector<uint32_t>& next);
  template <int CT>
  void catch_up(uint32_t unit, int64_t t);
  template <int CT>
  bool update(uint32_t unit, int64_t t, uint32_t*& out);
  // Constants of a step's pass, in registers.
  // Members are copied here, into locals the compiler can keep in registers: the pass's
  // vector stores may alias anything, which otherwise forces a reload per unit.
  struct PassConsts {
    simd::F16 g1, ba, bb, inc;
    float theta, btheta;
    bool slayer, record;
    float* state;
    int64_t* last;
    size_t record_floats;         // nvars_ * lanes
    const float *pow_a, *pow_ar;  // decay tables and their lengths
    int64_t n_a, n_ar;
    simd::F16 xa1, xb0, xref;  // FIR expiry: K a^K, a^K, cref ar^(R-1)
    simd::I16 lane_bit;        // 1 << lane
  };
  // With kFir, expire holds the drive of K-1 steps before (zeros if none); with kRef,
  // ref_lanes has the lanes that spiked R steps before.
  template <int L, simd::Isa I, bool kFir = false, bool kRef = false>
  bool advance_unit(size_t unit, int64_t t, const float* drive, float* sink, const PassConsts& k,
                    uint32_t*& out, const float* expire = nullptr, uint64_t ref_lanes = 0);
  // Keeps u[t] of lanes c0 .. c0+n of a unit (for potential()).
  void record(uint32_t unit, const float* u, int64_t t, int c0, int n);
  // a^d and ar^d: tables until they drop below the smallest normal float, 0 beyond (pow()
  // only for kernels so slow that the table would exceed 65536 entries).
  SPIKEMS_INLINE float decay(int64_t d) const {
    if (d < int64_t(pow_a_.size())) return pow_a_[size_t(d)];
    return pow_a_.size() < 65536 ? 0.f : float(std::pow(a_, double(d)));
  }
  SPIKEMS_INLINE float ref_decay(int64_t d) const {
    if (d < int64_t(pow_ar_.size())) return pow_ar_[size_t(d)];
    return pow_ar_.size() < 65536 ? 0.f : float(std::pow(ar_, double(d)));
  }

  double a_, ar_, cs_, cref_;
  bool slayer_ref_;
  float spike_inc_, bound_a1_, bound_b0_, bound_theta_;  // spike_inc_ is cref * increment
  std::vector<float> pow_a_, pow_ar_;
  simd::Isa isa_ = simd::best_isa();
  int unit_shift_ = 0;  // a unit is 2^unit_shift_ positions
  int lanes_ = 0;       // neurons per unit
  // One record per unit: its lanes of a1, then of b0, r0 and (SLAYER's form only) r1, so
  // that a visit touches one run of lines rather than one line in each of three or four
  // arrays. Units rounded up to a whole bitmap word, 64-byte aligned.
  HugeBuffer<float> state_;
  int nvars_ = 3;
  SPIKEMS_INLINE float* record_of(size_t unit, size_t lanes) {
    return state_.data() + unit * size_t(nvars_) * lanes;
  }
  SPIKEMS_INLINE const float* record_of(size_t unit, size_t lanes) const {
    return state_.data() + unit * size_t(nvars_) * lanes;
  }
  HugeBuffer<int64_t> last_;           // per unit: the step its state is expressed at
  std::vector<uint64_t> active_bits_;  // one bit per unit
  size_t active_count_ = 0;
  HugeBuffer<uint32_t> spike_buf_;  // the spikes of one pass
  HugeBuffer<float> drive_;         // a step's drive, one float per neuron, zero between steps
  HugeBuffer<float> zero_drive_;    // the drive of a unit not reached (2 x lanes_, see pass)
  std::vector<float> scratch_;      // 2 x lanes when they are not a compile-time constant
  bool record_ = false;
  std::vector<float> u_eval_;
  std::vector<int64_t> eval_step_;
  // FIR expiry (fir_k_ > 0): per step, the units reached and the drive each took (K slots, by
  // step mod K), the spikes each pass emitted (R + 1 slots), and the units with an expiry at
  // the current step.
  int fir_k_ = 0, fir_r_ = 0;
  float expire_a1_ = 0, expire_b0_ = 0, expire_ref_ = 0;
  struct DriveLog {
    size_t n = 0;  // entries (the vectors only grow)
    std::vector<uint32_t> units;
    std::vector<float> drive;  // lanes_ floats per unit
  };
  std::vector<DriveLog> drive_log_;
  std::vector<std::vector<uint32_t>> spike_log_;
  std::vector<uint64_t> expire_bits_;
  std::vector<uint32_t> ref_units_;  // a pass's units whose spikes of R steps before expire
  std::vector<uint64_t> ref_lanes_;  // and their lanes
};

}  // namespace spikems
