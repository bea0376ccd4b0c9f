// One spiking block (psp -> conv / transposed conv -> spike) advanced one time step at a time,
// touching only the neurons that matter. Since psp and the synaptic op are linear, an input
// spike of neuron j at step t scatters its weights into the drive I_i[t] of its fan-out, and
// the psp shape applies to the output neuron: u_i[t] = sum_k eps[k] I_i[t-k] + refractory.
//
// Neurons are indexed channels-last, (y*W + x)*C + c, so the C neurons of one pixel ("a
// position") are contiguous and every state update is a short vector loop.
//
// FirStreamingLayer keeps, per position, a ring of the FUTURE potential (W >= kernel length
// slots): a drive at t adds I*eps[k] to slot t+k, a spike adds nu[j] to slot t+j. The
// potential at a step is then final when the step comes, so a position is visited only at the
// steps where some channel reaches theta (found when its ring changes, kept in a timing wheel).
//
// IirStreamingLayer keeps the exact recursions of the continuous kernels (two state variables
// for the alpha psp, one or two for the refractory kernel) and advances them lazily (closed
// form over skipped steps). A position is visited every step only while the exact maximum of
// its future psp (refractory terms are never positive) can still reach theta.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "core/model/model_file.h"

namespace spikems {

class StreamingLayer {
 public:
  StreamingLayer(const LayerSpec& spec, int in_height, int in_width);
  virtual ~StreamingLayer() = default;

  // Appends to `out` the output neurons that spike at step t. Call once per step, t
  // increasing by one, before drive(t).
  virtual void fire(int64_t t, std::vector<uint32_t>& out) = 0;
  // Input spikes of step t (input neuron indices, channels-last); they reach u from t+1 on.
  void drive(int64_t t, const uint32_t* spikes, size_t n);
  // u[t] of an output neuron at the current step t (after fire(t)): the value compared with
  // theta. For tests and tools.
  virtual float potential(int64_t t, uint32_t neuron) const = 0;
  // Positions currently holding non-zero state that may still need work.
  virtual size_t busy_positions() const = 0;

  int in_channels() const { return cin_; }
  int in_height() const { return hin_; }
  int in_width() const { return win_; }
  int out_channels() const { return cout_; }
  int out_height() const { return hout_; }
  int out_width() const { return wout_; }
  size_t out_neurons() const { return size_t(hout_) * wout_ * cout_; }
  // Synaptic operations so far: every (input spike, output neuron) pair a weight was added for.
  uint64_t synops() const { return synops_; }
  uint64_t spikes() const { return spikes_; }

  static std::unique_ptr<StreamingLayer> create(const LayerSpec& spec, double time_step_ms,
                                                int in_height, int in_width);

 protected:
  // Turns the drive accumulated for the touched positions into state (drive_ zeroed after).
  virtual void integrate(int64_t t) = 0;

  int cin_, hin_, win_, cout_, hout_, wout_, k_;
  float theta_;
  std::vector<float> wlocal_;  // [ci][ky][kx][co]: the fan-out weights of one tap, contiguous
  // Taps per input row / column: (output row, ky) pairs.
  std::vector<int32_t> row_begin_, col_begin_;
  std::vector<std::pair<int32_t, int32_t>> row_taps_, col_taps_;
  std::vector<float> drive_;           // [pos][co], valid for touched positions
  std::vector<int64_t> touched_step_;  // last step a position received drive
  std::vector<uint32_t> touched_;      // positions touched this step
  uint64_t synops_ = 0, spikes_ = 0;
};

}  // namespace spikems
