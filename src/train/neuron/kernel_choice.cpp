#include "train/neuron/kernel_choice.h"

#include <atomic>

#include "core/util/error.h"

namespace spikems::train {

namespace {
std::atomic<NeuronKernels> g_kernels{NeuronKernels::Fused};
}

void set_neuron_kernels(NeuronKernels k) {
  g_kernels.store(k);
}

NeuronKernels neuron_kernels() {
  return g_kernels.load();
}

NeuronKernels parse_neuron_kernels(const std::string& name) {
  if (name == "fused") return NeuronKernels::Fused;
  if (name == "ops") return NeuronKernels::Ops;
  throw Error("neuron kernels '" + name + "': expected fused or ops");
}

bool cuda_kernels_built() {
#ifdef SPIKEMS_WITH_CUDA
  return true;
#else
  return false;
#endif
}

}  // namespace spikems::train
