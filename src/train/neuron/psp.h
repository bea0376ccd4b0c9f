// Post-synaptic potential: a = Ts * (eps * s) along time for every neuron of a time-major
// tensor [T, ...]. A custom autograd function around the fused kernel of the device (CPU; CUDA
// where built; the backward is the same filter run backwards in time), else plain tensor
// operations (other devices, or NeuronKernels::Ops).
#pragma once

#include <torch/torch.h>

#include "train/neuron/temporal_kernel.h"

namespace spikems::train {

torch::Tensor psp(const torch::Tensor& x, const TemporalKernel& eps, double ts);

// Packs a kernel into an autograd context (saved_data) and back.
void save_kernel(torch::autograd::AutogradContext* ctx, const std::string& prefix,
                 const TemporalKernel& k);
TemporalKernel load_kernel(torch::autograd::AutogradContext* ctx, const std::string& prefix);

}  // namespace spikems::train
