// Fused CUDA kernels of the neuron dynamics on a time-major layout [T, N]: one thread per neuron
// walks the time axis, so the psp filter, the spike loop with its refractory and the
// reverse-time backward are each one kernel launch instead of T small tensor operations. They
// compute exactly what the CPU kernels compute (temporal_kernel.cpp, spike.cpp), in the same
// order of rounded float operations (no fused multiply-add), except exp() in the surrogate.
// Plain pointers and no CUDA types here: this header is included by LibTorch code built with
// or without CUDA; the kernels exist only where SPIKEMS_WITH_CUDA is defined.
#pragma once

#include <cstdint>

namespace spikems::train::cuda {

constexpr int kMaxTaps = 256;  // longer FIR kernels take the tensor-op path

// A temporal kernel (TemporalKernel) in launchable form.
struct KernelDesc {
  int form = 0;  // 0 FIR, 1 Alpha, 2 DelayedExp, 3 AlphaLead (TemporalKernel::Form order)
  int taps = 0;
  float tap[kMaxTaps] = {};
  double decay = 0, gain = 0;
};

// y[t] = scale * sum_i h[i] x[t -/+ i]: the psp filter (reverse = its adjoint).
void temporal_filter(const void* x, void* y, bool is_double, int64_t T, int64_t N,
                     const KernelDesc& k, double scale, bool reverse, void* stream);

struct SpikeDesc {
  double theta = 0, ts = 1;
  KernelDesc refractory;
  double pdf_scale = 0, pdf_tau = 1;  // surrogate rho(u) = pdf_scale exp(-|u - theta| / pdf_tau)
};

// ur: in = synaptic potential u, out = u~ (after the refractory); s: spikes (0 or 1/Ts).
void spike_forward(void* ur, void* s, bool is_double, int64_t T, int64_t N, const SpikeDesc& p,
                   void* stream);
// gu = dL/du from gs = dL/ds and u~; exact = differentiate the refractory path too.
void spike_backward(const void* gs, const void* ur, void* gu, bool is_double, int64_t T, int64_t N,
                    const SpikeDesc& p, bool exact, void* stream);

}  // namespace spikems::train::cuda
