// LibTorch front of the fused CUDA neuron kernels (neuron_cuda.h): takes contiguous CUDA tensors
// [T, N] (float or double), launches on the tensor's device and its current stream. No
// autograd: psp.cpp and spike.cpp wrap these in their autograd functions. Builds without CUDA
// compile these too; there they throw (call only where cuda_kernels_built()).
#pragma once

#include <torch/torch.h>

#include <string>
#include <utility>

#include "train/neuron/spike.h"
#include "train/neuron/temporal_kernel.h"

namespace spikems::train {

// The current CUDA device's name ("" without CUDA), for model metadata.
std::string cuda_device_name();

// Whether the CUDA kernels take this temporal kernel (FIR taps fit their parameter block).
bool cuda_kernel_fits(const TemporalKernel& k);

torch::Tensor cuda_temporal_filter(const torch::Tensor& x, const TemporalKernel& k, double scale,
                                   bool reverse);
// Returns {spikes, u~} as spike_forward does.
std::pair<torch::Tensor, torch::Tensor> cuda_spike_forward(const torch::Tensor& u,
                                                           const SpikeParams& p);
torch::Tensor cuda_spike_backward(const torch::Tensor& gs, const torch::Tensor& ur,
                                  const SpikeParams& p);

}  // namespace spikems::train
