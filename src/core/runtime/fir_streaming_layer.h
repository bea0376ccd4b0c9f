// FIR neurons (the kernels of the model file, eps[0..K), nu[0..R)), event-driven, for the
// layers IirStreamingLayer cannot run with expiry (kernels that are not the sampled ones,
// SLAYER's refractory form, other channel counts): see StreamingLayer::create().
//
// Per position, a ring of the FUTURE potential (W >= max(K, R) slots of C floats): a drive at
// t adds I*eps[k] to slot t+k, a spike adds nu[j] to slot t+j. The potential of a step is
// then final when the step comes, so a position is visited only at the steps where some
// channel reaches theta (found when its ring changes, kept in a timing wheel).
#pragma once

#include "core/runtime/streaming_layer.h"

namespace spikems {

class FirStreamingLayer final : public StreamingLayer {
 public:
  FirStreamingLayer(const LayerSpec& l, int hin, int win, int need_h = -1, int need_w = -1);
  void step(int64_t t, const uint32_t* spikes, size_t n, std::vector<uint32_t>& next) override;
  float potential(int64_t t, uint32_t neuron) const override;
  size_t busy_positions() const override;

 private:
  SPIKEMS_MULTIVERSION void step_all(int64_t t, const uint32_t* spikes, size_t n,
                                     std::vector<uint32_t>& next);
  template <int CT>
  void fire_c(int64_t t, std::vector<uint32_t>& out);
  template <int CT>
  void drive_c(int64_t t, const uint32_t* spikes, size_t n);
  template <int CT>
  int64_t next_crossing(uint32_t pos, int64_t from) const;
  float* slot(uint32_t pos, int64_t step) {
    return &ring_[(size_t(pos) * W_ + size_t(step & mask_)) * cout_];
  }
  const float* slot(uint32_t pos, int64_t step) const {
    return &ring_[(size_t(pos) * W_ + size_t(step & mask_)) * cout_];
  }
  void extend(uint32_t pos, int64_t t, int64_t upto);
  void schedule(uint32_t pos, int64_t s);

  std::vector<float> eps_, nu_;
  HugeBuffer<float> drive_;  // [position][C] (+16 spare), zero except at touched positions
  int W_ = 1;
  int64_t mask_ = 0;
  std::vector<float> ring_;                   // [pos][slot][c]: future potential
  std::vector<int64_t> horizon_;              // last step whose slot is valid
  std::vector<int64_t> next_;                 // step at which the position reaches theta (-1: none)
  std::vector<std::vector<uint32_t>> wheel_;  // positions to visit, by step mod W
};

}  // namespace spikems
