// Spike generation of the SRM neuron with its refractory response (SLAYER's getSpikes):
//   for t = 0..T-1:  spike[t] = (u~[t] >= theta);  if spike: u~[t+j] += nu[j] for t+j < T
// where u~ starts as the synaptic potential u. Spikes take the value 1/Ts. The refractory is
// either the sampled FIR kernel nu (added in place in spike order, bit-exact to the reference)
// or its exact recursion (IIR). The surrogate gradient is
//   rho(u~) = scale_rho / D * exp(-|u~ - theta| / (tau_rho theta)),  D = tau_rho*theta (SLAYER)
//   or D = theta (SpikeMS code),
// evaluated at the potential after the refractory contributions (SLAYER saves the in-place
// updated potential). Backward modes (docs/model.md):
//   Slayer: dL/du[t] = rho(u~[t]) dL/ds[t]                     (refractory not differentiated)
//   Exact:  dL/du~[t] = rho(u~[t]) (dL/ds[t] + Ts sum_{j>=1} nu[j] dL/du~[t+j]), dL/du = dL/du~
//           (the refractory path differentiated backwards in time, as EXODUS does for resets).
#pragma once

#include <torch/torch.h>

#include "train/neuron/temporal_kernel.h"

namespace spikems::train {

enum class SpikeGradient { Slayer, Exact };

struct SpikeParams {
  float theta = 0.22f;
  double ts = 1.0;
  TemporalKernel refractory;
  SurrogateForm surrogate = SurrogateForm::SpikeMS;
  double tau_rho = 0.3, scale_rho = 0.2;
  SpikeGradient gradient = SpikeGradient::Slayer;

  static SpikeParams from_layer(const LayerSpec& l, double ts, SpikeGradient g);
  // The surrogate is rho(u~) = pdf_scale() exp(-|u~ - theta| / pdf_tau()).
  double pdf_scale() const;
  double pdf_tau() const;
};

// u: [T, ...] synaptic potential. Returns spikes (same shape, values 0 and 1/Ts).
torch::Tensor spike(const torch::Tensor& u, const SpikeParams& p);

// The same, also returning the potential after the refractory (u~). No autograd.
// `use_fused` = true takes the fused kernel of the tensor's device (CPU; CUDA where built),
// false (or a device without one) the per-step tensor-op path.
std::pair<torch::Tensor, torch::Tensor> spike_forward(const torch::Tensor& u2d,
                                                      const SpikeParams& p, bool use_fused);
// dL/du from dL/ds and the saved u~ (both [T, N]). No autograd.
torch::Tensor spike_backward(const torch::Tensor& grad_s, const torch::Tensor& u_ref,
                             const SpikeParams& p, bool use_fused);
// The surrogate rho(u~) elementwise.
torch::Tensor surrogate_pdf(const torch::Tensor& u_ref, const SpikeParams& p);

}  // namespace spikems::train
