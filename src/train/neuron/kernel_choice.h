// Which implementation runs the neuron dynamics (psp filter, spike function, their gradients):
// the fused kernels (the CPU kernels; the CUDA kernels where the build has them) or plain
// LibTorch tensor operations, step by step (the reference, on any device). Process-wide: the
// trainer sets it from `run.neuron_kernels`; benchmarks switch it to compare the two.
#pragma once

#include <string>

namespace spikems::train {

enum class NeuronKernels { Fused, Ops };

void set_neuron_kernels(NeuronKernels k);
NeuronKernels neuron_kernels();
NeuronKernels parse_neuron_kernels(const std::string& name);  // "fused" | "ops"

// Whether this build has the fused CUDA kernels (CMake option SPIKEMS_CUDA).
bool cuda_kernels_built();

}  // namespace spikems::train
