// IIR neurons (the exact recursions of the continuous kernels), event-driven.
//
// Per neuron: the alpha psp as two state variables (a1, b0), the refractory response as one
// (SpikeMS form, r0) or two (SLAYER's alpha form, r1 and r0), advanced lazily in closed form
// over skipped steps. Each variable is an array of its own, channels-last, so the variable of
// consecutive positions is contiguous.
//
// The state is kept per *unit*: one position, or 16/C consecutive positions when C divides 16
// (the output layer's two channels: 8 positions), so that a unit is a whole vector of lanes
// and the state of consecutive positions is contiguous in each array, indexed by neuron.
//
// A step has two passes. The scatter adds the input spikes' weights straight into b0 (the
// drive of step t), after bringing a unit's state up to step t the first time the step
// reaches it. The update then visits, in address order, every unit reached this step or
// still "active" (a cheap upper bound on its future psp reaches theta; refractory terms are
// never positive): all of them are at step t, so one uniform recursion step takes them to
// t+1, with no branch per neuron; the spikes of t+1 are the neurons whose potential reaches
// theta. Idle and decaying neurons cost nothing, and the spikes come out sorted.
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
  size_t busy_positions() const override { return active_count_ << unit_shift_; }

 private:
  SPIKEMS_MULTIVERSION void step_all(int64_t t, const uint32_t* spikes, size_t n,
                                     std::vector<uint32_t>& next);
  template <int CT>
  void step_c(int64_t t, const uint32_t* spikes, size_t n, std::vector<uint32_t>& next);
  template <int CT>
  void catch_up(uint32_t unit, int64_t t);
  template <int CT>
  bool update(uint32_t unit, int64_t t, std::vector<uint32_t>& next);
  void record(uint32_t unit, const float* u, int64_t t);
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
  int unit_shift_ = 0;  // a unit is 2^unit_shift_ positions
  int lanes_ = 0;       // neurons per unit
  // [neuron] each (a unit's lanes contiguous), units rounded up to a whole bitmap word,
  // 64-byte aligned; b0_ has the scatter's 16 spare floats. r1_ only for SLAYER's form.
  HugeBuffer<float> a1_, b0_, r0_, r1_;
  HugeBuffer<int64_t> last_;           // per unit: the step its state is expressed at
  std::vector<uint64_t> active_bits_;  // one bit per unit
  size_t active_count_ = 0;
  std::vector<float> scratch_;  // 2 x lanes when they are not a compile-time constant
  bool record_ = false;
  std::vector<float> u_eval_;
  std::vector<int64_t> eval_step_;
};

}  // namespace spikems
