// Fused CUDA kernels of the neuron dynamics (neuron_cuda.h). One thread per neuron; thread n
// touches x[t * N + n] for every t, so a warp reads 32 consecutive floats per step (coalesced).
// Arithmetic goes through the _rn intrinsics so that nvcc cannot contract a*b+c into a fused
// multiply-add: the CPU kernels round every product and sum, and spikes are threshold decisions
// that a last-bit difference can flip.
#include <cuda_runtime.h>

#include <stdexcept>
#include <string>

#include "train/neuron/neuron_cuda.h"

namespace spikems::train::cuda {

namespace {

constexpr int kThreads = 256;
enum Form { kFIR = 0, kAlpha = 1, kDelayedExp = 2, kAlphaLead = 3 };

__device__ __forceinline__ float mul(float a, float b) {
  return __fmul_rn(a, b);
}
__device__ __forceinline__ float add(float a, float b) {
  return __fadd_rn(a, b);
}
__device__ __forceinline__ double mul(double a, double b) {
  return __dmul_rn(a, b);
}
__device__ __forceinline__ double add(double a, double b) {
  return __dadd_rn(a, b);
}

template <typename S>
__global__ void filter_kernel(const S* __restrict__ x, S* __restrict__ y, int64_t T, int64_t N,
                              KernelDesc k, double scale_d, bool reverse) {
  const int64_t n = int64_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (n >= N) return;
  if (k.form == kFIR) {
    const S scale = S(scale_d);
    for (int64_t t = 0; t < T; ++t) {
      S acc = S(0);
      // Taps in ascending order, then the scale: the CPU kernel's (and SLAYER's) order.
      for (int i = 0; i < k.taps; ++i) {
        const int64_t src = reverse ? t + i : t - i;
        if (src < 0 || src >= T) break;
        const S h = S(k.tap[i]);
        if (h == S(0)) continue;
        acc = add(acc, mul(h, x[src * N + n]));
      }
      if (scale != S(1)) acc = mul(acc, scale);
      y[t * N + n] = acc;
    }
    return;
  }
  // The gain as the CPU kernel forms it: the scale first rounded to S.
  const S a = S(k.decay), g = S(double(S(scale_d)) * k.gain);
  S q = S(0), r = S(0);
  for (int64_t s = 0; s < T; ++s) {
    const int64_t t = reverse ? T - 1 - s : s;
    const S xv = x[t * N + n];
    if (k.form == kAlpha) {
      r = mul(a, add(r, q));
      q = add(mul(a, q), xv);
      y[t * N + n] = mul(g, r);
    } else if (k.form == kAlphaLead) {
      q = add(mul(a, q), xv);
      r = mul(a, add(r, q));
      y[t * N + n] = mul(g, r);
    } else {
      y[t * N + n] = mul(g, q);
      q = add(mul(a, q), xv);
    }
  }
}

template <typename S>
__global__ void spike_forward_kernel(S* __restrict__ ur, S* __restrict__ s, int64_t T, int64_t N,
                                     SpikeDesc p) {
  const int64_t n = int64_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (n >= N) return;
  const S theta = S(float(p.theta)), inv_ts = S(1.0 / p.ts);
  const KernelDesc& k = p.refractory;
  const S a = S(k.decay), g = S(k.gain);
  S q = S(0), r = S(0);
  for (int64_t t = 0; t < T; ++t) {
    S u = ur[t * N + n];
    if (k.form == kDelayedExp) {
      u = add(u, mul(g, q));
      ur[t * N + n] = u;
    } else if (k.form == kAlpha) {
      r = mul(a, add(r, q));
      u = add(u, mul(g, r));
      ur[t * N + n] = u;
    }
    const S spk = u >= theta ? S(1) : S(0);
    s[t * N + n] = mul(spk, inv_ts);
    if (k.form == kFIR) {
      // In place into the potential of this and later steps, as the CPU kernel does (adding
      // 0 * nu leaves a value unchanged, so only spikes need the loop).
      if (spk != S(0))
        for (int j = 0; j < k.taps && t + j < T; ++j) {
          const S nu = S(k.tap[j]);
          if (nu == S(0)) continue;
          ur[(t + j) * N + n] = add(ur[(t + j) * N + n], nu);
        }
    } else {
      q = add(mul(a, q), spk);
    }
  }
}

template <typename S>
__device__ __forceinline__ S surrogate(S u, S theta, S c, S inv_tau) {
  return mul(c, S(exp(-mul(S(fabs(add(u, -theta))), inv_tau))));
}

template <typename S>
__global__ void spike_backward_kernel(const S* __restrict__ gs, const S* __restrict__ ur,
                                      S* __restrict__ gu, int64_t T, int64_t N, SpikeDesc p,
                                      bool exact) {
  const int64_t n = int64_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (n >= N) return;
  const S theta = S(float(p.theta)), c = S(p.pdf_scale), inv_tau = S(1.0 / p.pdf_tau);
  if (!exact) {  // SLAYER: the refractory is not differentiated
    for (int64_t t = 0; t < T; ++t)
      gu[t * N + n] = mul(surrogate(ur[t * N + n], theta, c, inv_tau), gs[t * N + n]);
    return;
  }
  const KernelDesc& k = p.refractory;
  const S a = S(k.decay), g = S(k.gain), ts = S(p.ts);
  S q = S(0), r = S(0);
  for (int64_t t = T - 1; t >= 0; --t) {
    S b = S(0);  // sum_{j>=1} nu[j] dL/du~[t+j]
    if (k.form == kFIR) {
      for (int j = 1; j < k.taps && t + j < T; ++j)
        b = add(b, mul(S(k.tap[j]), gu[(t + j) * N + n]));
    } else if (k.form == kDelayedExp) {
      b = mul(g, q);
    } else {
      r = mul(a, add(r, q));
      b = mul(g, r);
    }
    const S rho = surrogate(ur[t * N + n], theta, c, inv_tau);
    const S go = mul(rho, add(gs[t * N + n], mul(ts, b)));
    gu[t * N + n] = go;
    if (k.form != kFIR) q = add(mul(a, q), go);
  }
}

void check_launch(const char* what) {
  const cudaError_t e = cudaGetLastError();
  if (e != cudaSuccess)
    throw std::runtime_error(std::string(what) + ": CUDA launch failed: " + cudaGetErrorString(e));
}

dim3 blocks_for(int64_t N) {
  return dim3(unsigned((N + kThreads - 1) / kThreads));
}

}  // namespace

void temporal_filter(const void* x, void* y, bool is_double, int64_t T, int64_t N,
                     const KernelDesc& k, double scale, bool reverse, void* stream) {
  if (T == 0 || N == 0) return;
  auto st = static_cast<cudaStream_t>(stream);
  if (is_double)
    filter_kernel<double><<<blocks_for(N), kThreads, 0, st>>>(
        static_cast<const double*>(x), static_cast<double*>(y), T, N, k, scale, reverse);
  else
    filter_kernel<float><<<blocks_for(N), kThreads, 0, st>>>(
        static_cast<const float*>(x), static_cast<float*>(y), T, N, k, scale, reverse);
  check_launch("psp filter");
}

void spike_forward(void* ur, void* s, bool is_double, int64_t T, int64_t N, const SpikeDesc& p,
                   void* stream) {
  if (T == 0 || N == 0) return;
  auto st = static_cast<cudaStream_t>(stream);
  if (is_double)
    spike_forward_kernel<double><<<blocks_for(N), kThreads, 0, st>>>(
        static_cast<double*>(ur), static_cast<double*>(s), T, N, p);
  else
    spike_forward_kernel<float><<<blocks_for(N), kThreads, 0, st>>>(
        static_cast<float*>(ur), static_cast<float*>(s), T, N, p);
  check_launch("spike forward");
}

void spike_backward(const void* gs, const void* ur, void* gu, bool is_double, int64_t T, int64_t N,
                    const SpikeDesc& p, bool exact, void* stream) {
  if (T == 0 || N == 0) return;
  auto st = static_cast<cudaStream_t>(stream);
  if (is_double)
    spike_backward_kernel<double><<<blocks_for(N), kThreads, 0, st>>>(
        static_cast<const double*>(gs), static_cast<const double*>(ur), static_cast<double*>(gu), T,
        N, p, exact);
  else
    spike_backward_kernel<float><<<blocks_for(N), kThreads, 0, st>>>(
        static_cast<const float*>(gs), static_cast<const float*>(ur), static_cast<float*>(gu), T, N,
        p, exact);
  check_launch("spike backward");
}

}  // namespace spikems::train::cuda
