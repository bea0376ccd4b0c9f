// Sparse CPU path of a spiking layer's synaptic potential.
//
// The dense path computes u = W (*) (eps * s): the psp filter on every input neuron, then a dense
// conv / transposed conv of the (dense) filtered input. Both maps are linear and act on different
// axes (time vs space/channels), so u = eps * (W (*) s). Spikes s are sparse (a few % nonzero), so
// the convolution of s is a scatter of weight columns, one per nonzero input, and the filter then
// runs on the outputs. Backward:
//   g     = eps^T * dL/du                 (the filter run backwards on the output gradient)
//   dL/dW = sum over nonzero inputs v * g (a gather-sum at the positions the scatter touched)
//   dL/ds = W^T (*) g                     (dense: every input position gets a gradient; a dense
//                                          LibTorch call, skipped when s needs no gradient)
// The result equals the dense path up to float rounding (the order of the additions differs);
// nothing is dropped. Only the nonzero positions and values of s are saved for the backward pass
// (8 bytes per nonzero instead of the dense path's 4 bytes per input neuron of eps * s).
#pragma once

#include <torch/torch.h>

#include <string>

#include "train/neuron/temporal_kernel.h"
#include "train/synapse/conv.h"

namespace spikems::train {

// Which synapse implementation a spiking layer uses (`run.kernels`, `spikems train --kernels`).
enum class KernelPath { Auto, Sparse, Dense };
KernelPath parse_kernel_path(const std::string& name);  // "auto" | "sparse" | "dense"; throws
const char* kernel_path_name(KernelPath k);

// Auto's rule, measured per layer on the 2-core machine (bench/bench_train_sparse.cpp --layers;
// docs/performance.md, "Sparse synapse kernels"): the largest input density at which
// the sparse path of a layer is still faster than the dense one. Convolutions: none (LibTorch's
// strided conv2d, forward and backward, beat the scatter at every density down to 1 %; the
// sparse path still needs the dense adjoint for the input gradient). Transposed convolutions:
// by output channels, below each measured crossover (2: ~6 %, 16: ~15 %, 32: ~20 %, 64: 35-50 %):
// the scatter writes C_out floats per tap, so few output channels leave it paying mostly for
// index work.
double sparse_density_threshold(const SynapseGeometry& g, int64_t out_channels);

// u = eps * (W (*) s) for s [T, B, C_in, H, W] float or double on the CPU (any values; fast when
// most are zero). Differentiable w.r.t. s and weight. Equals synapse_forward(psp(s)) within float
// rounding.
torch::Tensor sparse_synapse_psp(const torch::Tensor& s, const torch::Tensor& weight,
                                 const SynapseGeometry& g, const TemporalKernel& eps, double ts);

// Fraction of nonzero entries of x (parallel count).
double nonzero_density(const torch::Tensor& x);

// Whether `path` runs the sparse kernels for input s of a layer of geometry g with out_channels
// outputs (Auto: CPU, float/double, density at most sparse_density_threshold).
bool use_sparse_path(KernelPath path, const torch::Tensor& s, const SynapseGeometry& g,
                     int64_t out_channels);

}  // namespace spikems::train
