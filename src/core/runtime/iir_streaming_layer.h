// IIR neurons (the exact recursions of the continuous kernels), event-driven.
//
// Per neuron: the alpha psp as two state variables, the refractory response as one (SpikeMS
// form) or two (SLAYER's alpha form), advanced lazily in closed form over skipped steps.
//
// A step is one pass over the positions that matter, in address order: those that receive
// input this step and those still "active" (a cheap upper bound on their future psp can reach
// theta; refractory terms are never positive). The input spikes first scatter their weights
// into a drive buffer (fixed loops, no state touched); then each such position's state is
// read and written once: advanced to t, given its drive, and, if it may reach theta, advanced
// to t+1 and compared with theta. Idle and decaying neurons cost nothing, and the spikes come
// out sorted, so the next layer's pass also walks its state forward.
#pragma once

#include <cmath>

#include "core/runtime/streaming_layer.h"
#include "core/util/huge_buffer.h"

namespace spikems {

class IirStreamingLayer final : public StreamingLayer {
 public:
  IirStreamingLayer(const LayerSpec& l, double time_step_ms, int hin, int win);
  void step(int64_t t, const uint32_t* spikes, size_t n, std::vector<uint32_t>& next) override;
  void record_potentials(bool on) override;
  float potential(int64_t t, uint32_t neuron) const override;
  size_t busy_positions() const override { return active_count_; }

 private:
  SPIKEMS_MULTIVERSION void step_all(int64_t t, const uint32_t* spikes, size_t n,
                                     std::vector<uint32_t>& next);
  template <int CT>
  void step_c(int64_t t, const uint32_t* spikes, size_t n, std::vector<uint32_t>& next);
  template <int CT>
  void advance(float* st, int64_t d) const;
  template <int CT>
  void advance_by(float* st, float g, float gr, float fd) const;
  template <int CT>
  bool may_reach_theta(const float* st) const;
  float* state(uint32_t pos) { return base_ + size_t(pos) * stride_; }
  const float* state(uint32_t pos) const { return base_ + size_t(pos) * stride_; }
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
  float cs_f_, cref_f_, spike_inc_, bound_a1_, bound_b0_, bound_theta_;
  std::vector<float> pow_a_, pow_ar_;
  // Per position [a1 | b0 | r0 | r1] x C, padded to whole cache lines when C >= 16 so that a
  // position's state is a few lines it owns alone.
  size_t stride_;
  HugeBuffer<float> state_;            // 64-byte aligned
  float* base_ = nullptr;              // state_.data()
  HugeBuffer<int64_t> last_;           // step each position's state is expressed at
  std::vector<uint64_t> active_bits_;  // one bit per position
  size_t active_count_ = 0;
  std::vector<float> scratch_;  // C floats when C is not a compile-time constant
  bool record_ = false;
  std::vector<float> u_eval_;
  std::vector<int64_t> eval_step_;
};

}  // namespace spikems
