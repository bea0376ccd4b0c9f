#include "train/neuron/temporal_kernel.h"

#include <ATen/Dispatch.h>
#include <ATen/Parallel.h>

#include <cmath>

#include "core/util/error.h"
#include "core/util/simd.h"
#include "train/neuron/kernel_choice.h"
#include "train/neuron/neuron_cuda_torch.h"

namespace spikems::train {

namespace {
// Neurons per parallel chunk: a chunk's rows for all T stay in L2 and the inner loops vectorise.
constexpr int64_t kGrain = 512;
}  // namespace

TemporalKernel TemporalKernel::fir(std::vector<float> taps) {
  TemporalKernel k;
  k.form = Form::FIR;
  k.taps = std::move(taps);
  return k;
}

TemporalKernel TemporalKernel::alpha(double tau, double ts, double amplitude) {
  // amplitude * (nTs/tau) e^{1-nTs/tau} = (amplitude e Ts/tau) * n * (e^{-Ts/tau})^n
  TemporalKernel k;
  k.form = Form::Alpha;
  k.decay = std::exp(-ts / tau);
  k.gain = amplitude * std::exp(1.0) * ts / tau;
  return k;
}

TemporalKernel TemporalKernel::alpha_lead(double tau, double ts, double amplitude) {
  // h[n] = alpha's h[n + 1]: the same recursion with the drive entering before the output
  // state is advanced (q first, then r), so y[t] = gain * sum_i (i + 1) a^(i+1) x[t - i].
  TemporalKernel k = alpha(tau, ts, amplitude);
  k.form = Form::AlphaLead;
  return k;
}

TemporalKernel TemporalKernel::delayed_exp(double tau, double ts, double gain) {
  TemporalKernel k;
  k.form = Form::DelayedExp;
  k.decay = std::exp(-ts / tau);
  k.gain = gain;
  return k;
}

TemporalKernel TemporalKernel::srm(const LayerSpec& l, double ts) {
  if (l.neuron.discretisation == Discretisation::FIR) return fir(l.srm_kernel);
  if (l.neuron.srm_onset == SrmOnset::SameStep) return alpha_lead(l.neuron.tau_s, ts, 1.0);
  return alpha(l.neuron.tau_s, ts, 1.0);
}

TemporalKernel TemporalKernel::refractory(const LayerSpec& l, double ts) {
  const auto& n = l.neuron;
  if (n.discretisation == Discretisation::FIR) return fir(l.ref_kernel);
  double amp = -double(n.scale_ref) * double(n.theta);
  if (n.refractory == RefractoryShape::SpikeMS) return delayed_exp(n.tau_r, ts, amp);
  return alpha(n.tau_r, ts, amp);
}

std::vector<double> TemporalKernel::impulse_response(int count) const {
  std::vector<double> h(size_t(std::max(count, 0)), 0.0);
  for (int n = 0; n < count; ++n) {
    switch (form) {
      case Form::FIR:
        h[n] = n < int(taps.size()) ? taps[n] : 0.0;
        break;
      case Form::Alpha:
        h[n] = gain * n * std::pow(decay, n);
        break;
      case Form::AlphaLead:
        h[n] = gain * (n + 1) * std::pow(decay, n + 1);
        break;
      case Form::DelayedExp:
        h[n] = n == 0 ? 0.0 : gain * std::pow(decay, n - 1);
        break;
    }
  }
  return h;
}

torch::Tensor apply_temporal_kernel_ops(const torch::Tensor& x, const TemporalKernel& k,
                                        double scale, bool reverse) {
  const int64_t T = x.size(0);
  auto shifted = [&](int64_t i) {  // x[t-i] (forward) or x[t+i] (reverse), zero outside
    if (i == 0) return x;
    auto z = torch::zeros_like(x.narrow(0, 0, i));
    return reverse ? torch::cat({x.narrow(0, i, T - i), z}, 0)
                   : torch::cat({z, x.narrow(0, 0, T - i)}, 0);
  };
  if (k.form == TemporalKernel::Form::FIR) {
    torch::Tensor y = torch::zeros_like(x);
    for (int64_t i = 0; i < int64_t(k.taps.size()) && i < T; ++i)
      if (k.taps[i] != 0.f) y = y + double(k.taps[i]) * shifted(i);
    return y * scale;
  }
  // IIR: per-step recursion with differentiable tensor ops.
  std::vector<torch::Tensor> out(static_cast<size_t>(T));
  torch::Tensor q = torch::zeros_like(x[0]), r = torch::zeros_like(x[0]);
  const double a = k.decay;
  for (int64_t s = 0; s < T; ++s) {
    int64_t t = reverse ? T - 1 - s : s;
    if (k.form == TemporalKernel::Form::Alpha) {
      r = a * (r + q);
      q = a * q + x[t];
      out[size_t(t)] = (scale * k.gain) * r;
    } else if (k.form == TemporalKernel::Form::AlphaLead) {
      q = a * q + x[t];
      r = a * (r + q);
      out[size_t(t)] = (scale * k.gain) * r;
    } else {
      out[size_t(t)] = (scale * k.gain) * q;
      q = a * q + x[t];
    }
  }
  return torch::stack(out, 0);
}

namespace {

// The per-chunk loops below are compiled per instruction set (util/simd.h: AVX-512, AVX2,
// baseline; chosen when the program loads), as LibTorch's own element-wise kernels are.
template <typename S>
SPIKEMS_INLINE void fir_chunk(const S* x, S* y, int64_t T, int64_t N, int64_t n0, int64_t len,
                              const float* taps, int64_t K, S scale, bool reverse) {
  for (int64_t t = 0; t < T; ++t) {
    S* __restrict yr = y + t * N + n0;
    for (int64_t n = 0; n < len; ++n) yr[n] = S(0);
    // Sum with i ascending, then multiply by the scale: the order of the SLAYER kernel.
    for (int64_t i = 0; i < K; ++i) {
      const int64_t src = reverse ? t + i : t - i;
      if (src < 0 || src >= T) break;
      const S h = S(taps[i]);
      if (h == S(0)) continue;
      const S* __restrict xr = x + src * N + n0;
      for (int64_t n = 0; n < len; ++n) yr[n] += h * xr[n];
    }
    if (scale != S(1))
      for (int64_t n = 0; n < len; ++n) yr[n] *= scale;
  }
}
SPIKEMS_MULTIVERSION void fir_chunk_mv(const float* x, float* y, int64_t T, int64_t N, int64_t n0,
                                       int64_t len, const float* taps, int64_t K, float scale,
                                       bool reverse) {
  fir_chunk(x, y, T, N, n0, len, taps, K, scale, reverse);
}
SPIKEMS_MULTIVERSION void fir_chunk_mv(const double* x, double* y, int64_t T, int64_t N, int64_t n0,
                                       int64_t len, const float* taps, int64_t K, double scale,
                                       bool reverse) {
  fir_chunk(x, y, T, N, n0, len, taps, K, scale, reverse);
}

template <typename S>
void fir_cpu(const S* x, S* y, int64_t T, int64_t N, const std::vector<float>& taps, S scale,
             bool reverse) {
  at::parallel_for(0, N, kGrain, [&](int64_t n0, int64_t n1) {
    fir_chunk_mv(x, y, T, N, n0, n1 - n0, taps.data(), int64_t(taps.size()), scale, reverse);
  });
}

// form: 0 alpha, 1 alpha with the drive first (AlphaLead), 2 delayed exponential.
template <typename S>
SPIKEMS_INLINE void iir_chunk(const S* x, S* y, int64_t T, int64_t N, int64_t n0, int64_t len,
                              int form, S a, S g, bool reverse, S* __restrict q, S* __restrict r) {
  for (int64_t s = 0; s < T; ++s) {
    const int64_t t = reverse ? T - 1 - s : s;
    const S* __restrict xr = x + t * N + n0;
    S* __restrict yr = y + t * N + n0;
    if (form == 0) {
      for (int64_t n = 0; n < len; ++n) {
        r[n] = a * (r[n] + q[n]);
        q[n] = a * q[n] + xr[n];
        yr[n] = g * r[n];
      }
    } else if (form == 1) {
      for (int64_t n = 0; n < len; ++n) {
        q[n] = a * q[n] + xr[n];
        r[n] = a * (r[n] + q[n]);
        yr[n] = g * r[n];
      }
    } else {
      for (int64_t n = 0; n < len; ++n) {
        yr[n] = g * q[n];
        q[n] = a * q[n] + xr[n];
      }
    }
  }
}
SPIKEMS_MULTIVERSION void iir_chunk_mv(const float* x, float* y, int64_t T, int64_t N, int64_t n0,
                                       int64_t len, int form, float a, float g, bool reverse,
                                       float* q, float* r) {
  iir_chunk(x, y, T, N, n0, len, form, a, g, reverse, q, r);
}
SPIKEMS_MULTIVERSION void iir_chunk_mv(const double* x, double* y, int64_t T, int64_t N, int64_t n0,
                                       int64_t len, int form, double a, double g, bool reverse,
                                       double* q, double* r) {
  iir_chunk(x, y, T, N, n0, len, form, a, g, reverse, q, r);
}

template <typename S>
void iir_cpu(const S* x, S* y, int64_t T, int64_t N, const TemporalKernel& k, S scale,
             bool reverse) {
  const S a = S(k.decay), g = S(scale * k.gain);
  const int form = k.form == TemporalKernel::Form::Alpha       ? 0
                   : k.form == TemporalKernel::Form::AlphaLead ? 1
                                                               : 2;
  at::parallel_for(0, N, kGrain, [&](int64_t n0, int64_t n1) {
    const int64_t len = n1 - n0;
    std::vector<S> qv(static_cast<size_t>(len), S(0)), rv(size_t(len), S(0));
    iir_chunk_mv(x, y, T, N, n0, len, form, a, g, reverse, qv.data(), rv.data());
  });
}

}  // namespace

torch::Tensor apply_temporal_kernel_cpu(const torch::Tensor& x_in, const TemporalKernel& k,
                                        double scale, bool reverse) {
  TORCH_CHECK(x_in.device().is_cpu(), "apply_temporal_kernel_cpu needs a CPU tensor");
  torch::Tensor x = x_in.contiguous();
  const int64_t T = x.size(0), N = T == 0 ? 0 : x.numel() / T;
  torch::Tensor y = torch::empty_like(x);
  if (x.numel() == 0) return y;
  AT_DISPATCH_FLOATING_TYPES(x.scalar_type(), "temporal_kernel", [&] {
    const scalar_t* xp = x.data_ptr<scalar_t>();
    scalar_t* yp = y.data_ptr<scalar_t>();
    if (k.form == TemporalKernel::Form::FIR)
      fir_cpu<scalar_t>(xp, yp, T, N, k.taps, scalar_t(scale), reverse);
    else
      iir_cpu<scalar_t>(xp, yp, T, N, k, scalar_t(scale), reverse);
  });
  return y;
}

bool fused_kernel_exists(const torch::Tensor& x, const TemporalKernel& k) {
  if (x.numel() == 0) return false;
  if (x.device().is_cpu()) return true;
  return x.is_cuda() && cuda_kernels_built() && cuda_kernel_fits(k);
}

bool fused_temporal_kernel_for(const torch::Tensor& x, const TemporalKernel& k) {
  return neuron_kernels() == NeuronKernels::Fused && fused_kernel_exists(x, k);
}

torch::Tensor apply_temporal_kernel_fused(const torch::Tensor& x, const TemporalKernel& k,
                                          double scale, bool reverse) {
  if (x.device().is_cpu()) return apply_temporal_kernel_cpu(x, k, scale, reverse);
  return cuda_temporal_filter(x.contiguous(), k, scale, reverse);
}

}  // namespace spikems::train
