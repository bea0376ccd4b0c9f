// A causal temporal filter applied to every neuron of a time-major tensor [T, N]:
//   y[t] = scale * sum_{i>=0} h[i] x[t-i]   (forward)
//   y[t] = scale * sum_{i>=0} h[i] x[t+i]   (adjoint: the same filter run backwards in time)
// h is either a sampled, truncated FIR kernel (as SLAYER stores it) or one of the two exact
// recursions of the continuous SRM kernels (IIR, O(1) state per neuron, no truncation):
//   Alpha:        h[n] = gain * n * a^n                 (2nd order, double pole a = e^{-Ts/tau})
//   AlphaLead:    h[n] = gain * (n+1) * a^(n+1)         (the same, one step earlier: h[0] > 0)
//   DelayedExp:   h[0] = 0, h[n] = gain * a^(n-1), n>=1 (1st order, delayed one step)
#pragma once

#include <torch/torch.h>

#include <vector>

#include "core/model/model_file.h"

namespace spikems::train {

struct TemporalKernel {
  enum class Form { FIR, Alpha, DelayedExp, AlphaLead };  // neuron_cuda.h keeps this order
  Form form = Form::FIR;
  std::vector<float> taps;  // FIR: h[0..K-1]
  double decay = 0;         // IIR: a
  double gain = 0;          // IIR: see above

  static TemporalKernel fir(std::vector<float> taps);
  static TemporalKernel alpha(double tau, double ts, double gain_factor);
  // alpha() sampled one step later: an input reaches the output in its own step.
  static TemporalKernel alpha_lead(double tau, double ts, double gain_factor);
  static TemporalKernel delayed_exp(double tau, double ts, double gain);

  // The spike-response kernel eps[n] = (nTs/tau) e^{1-nTs/tau} of a layer (FIR: the layer's
  // stored taps; IIR: the exact recursion, AlphaLead for SrmOnset::SameStep).
  static TemporalKernel srm(const LayerSpec& l, double ts);
  // The refractory kernel nu of a layer (FIR: stored taps; IIR: DelayedExp for the SpikeMS
  // shape, Alpha for SLAYER's).
  static TemporalKernel refractory(const LayerSpec& l, double ts);

  // h[n] for n < count (the impulse response; for tests and for the naive baseline).
  std::vector<double> impulse_response(int count) const;
};

// Reference implementation on any device with plain tensor operations (autograd-friendly):
// x is [T, ...]; returns y of the same shape. reverse = adjoint (sum over x[t+i]).
torch::Tensor apply_temporal_kernel_ops(const torch::Tensor& x, const TemporalKernel& k,
                                        double scale, bool reverse);
// Fast CPU kernel: x is a contiguous [T, N] float or double CPU tensor. No autograd.
torch::Tensor apply_temporal_kernel_cpu(const torch::Tensor& x, const TemporalKernel& k,
                                        double scale, bool reverse);
// Whether a fused kernel (CPU, or CUDA where built) filters x, given the process-wide choice
// (kernel_choice.h); and that kernel, on [T, N] tensors. No autograd.
bool fused_temporal_kernel_for(const torch::Tensor& x, const TemporalKernel& k);
// Whether a fused kernel exists for x's device and k at all (CPU: always; CUDA: where built and
// k's taps fit), whatever the process-wide choice.
bool fused_kernel_exists(const torch::Tensor& x, const TemporalKernel& k);
torch::Tensor apply_temporal_kernel_fused(const torch::Tensor& x, const TemporalKernel& k,
                                          double scale, bool reverse);

}  // namespace spikems::train
