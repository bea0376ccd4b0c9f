#include "train/neuron/spike.h"

#include <ATen/Dispatch.h>
#include <ATen/Parallel.h>

#include <cmath>

#include "core/util/simd.h"
#include "train/neuron/kernel_choice.h"
#include "train/neuron/neuron_cuda_torch.h"
#include "train/neuron/psp.h"

namespace spikems::train {

using torch::autograd::AutogradContext;
using torch::autograd::variable_list;
using Form = TemporalKernel::Form;

namespace {
constexpr int64_t kGrain = 512;

// Which fused kernel takes a tensor: none (tensor ops), the CPU one or the CUDA one.
enum class Fused { None, Cpu, Cuda };
Fused fused_for(const torch::Tensor& t, const SpikeParams& p, bool use_fused) {
  if (!use_fused || !fused_kernel_exists(t, p.refractory)) return Fused::None;
  return t.device().is_cpu() ? Fused::Cpu : Fused::Cuda;
}

// ---- CPU kernels: time loop outside, neurons of one chunk contiguous inside ----

// form: 0 FIR (taps), 1 delayed exponential, 2 alpha. Compiled per instruction set (util/simd.h).
template <typename S>
SPIKEMS_INLINE void forward_chunk(S* ur, S* s, int64_t T, int64_t N, int64_t n0, int64_t len,
                                  int form, const float* taps, int64_t R, S a, S g, S theta,
                                  S inv_ts, S* __restrict sp, S* __restrict q, S* __restrict r) {
  for (int64_t t = 0; t < T; ++t) {
    S* __restrict u = ur + t * N + n0;
    S* __restrict so = s + t * N + n0;
    if (form == 0) {
      for (int64_t n = 0; n < len; ++n) {
        sp[n] = u[n] >= theta ? S(1) : S(0);
        so[n] = sp[n] * inv_ts;
      }
      // In place, in spike order: exactly the reference's sequence of float additions.
      for (int64_t j = 0; j < R && t + j < T; ++j) {
        const S nu = S(taps[j]);
        if (nu == S(0)) continue;
        S* __restrict uj = ur + (t + j) * N + n0;
        for (int64_t n = 0; n < len; ++n) uj[n] += sp[n] * nu;
      }
    } else if (form == 1) {
      for (int64_t n = 0; n < len; ++n) {
        u[n] += g * q[n];
        const S spk = u[n] >= theta ? S(1) : S(0);
        so[n] = spk * inv_ts;
        q[n] = a * q[n] + spk;
      }
    } else {
      for (int64_t n = 0; n < len; ++n) {
        r[n] = a * (r[n] + q[n]);
        u[n] += g * r[n];
        const S spk = u[n] >= theta ? S(1) : S(0);
        so[n] = spk * inv_ts;
        q[n] = a * q[n] + spk;
      }
    }
  }
}
SPIKEMS_MULTIVERSION void forward_chunk_mv(float* ur, float* s, int64_t T, int64_t N, int64_t n0,
                                           int64_t len, int form, const float* taps, int64_t R,
                                           float a, float g, float theta, float inv_ts, float* sp,
                                           float* q, float* r) {
  forward_chunk(ur, s, T, N, n0, len, form, taps, R, a, g, theta, inv_ts, sp, q, r);
}
SPIKEMS_MULTIVERSION void forward_chunk_mv(double* ur, double* s, int64_t T, int64_t N, int64_t n0,
                                           int64_t len, int form, const float* taps, int64_t R,
                                           double a, double g, double theta, double inv_ts,
                                           double* sp, double* q, double* r) {
  forward_chunk(ur, s, T, N, n0, len, form, taps, R, a, g, theta, inv_ts, sp, q, r);
}

template <typename S>
void forward_cpu(S* ur, S* s, int64_t T, int64_t N, const SpikeParams& p) {
  const S theta = S(p.theta), inv_ts = S(1.0 / p.ts);
  const auto& k = p.refractory;
  const int form = k.form == Form::FIR ? 0 : k.form == Form::DelayedExp ? 1 : 2;
  at::parallel_for(0, N, kGrain, [&](int64_t n0, int64_t n1) {
    const int64_t len = n1 - n0;
    std::vector<S> spv(static_cast<size_t>(len)), qv(size_t(len), S(0)), rv(size_t(len), S(0));
    forward_chunk_mv(ur, s, T, N, n0, len, form, k.taps.data(), int64_t(k.taps.size()), S(k.decay),
                     S(k.gain), theta, inv_ts, spv.data(), qv.data(), rv.data());
  });
}

template <typename S>
void backward_exact_cpu(const S* gs, const S* ur, S* gu, int64_t T, int64_t N,
                        const SpikeParams& p) {
  const S theta = S(p.theta), c = S(p.pdf_scale()), inv_tau = S(1.0 / p.pdf_tau()), ts = S(p.ts);
  const auto& k = p.refractory;
  at::parallel_for(0, N, kGrain, [&](int64_t n0, int64_t n1) {
    const int64_t len = n1 - n0;
    std::vector<S> bv(static_cast<size_t>(len)), qv(size_t(len), S(0)), rv(size_t(len), S(0));
    S* __restrict b = bv.data();
    S* __restrict q = qv.data();
    S* __restrict r = rv.data();
    const S a = S(k.decay), g = S(k.gain);
    for (int64_t t = T - 1; t >= 0; --t) {
      // b[n] = sum_{j>=1} nu[j] * dL/du~[t+j]
      if (k.form == Form::FIR) {
        for (int64_t n = 0; n < len; ++n) b[n] = S(0);
        const int64_t R = int64_t(k.taps.size());
        for (int64_t j = 1; j < R && t + j < T; ++j) {
          const S nu = S(k.taps[size_t(j)]);
          const S* __restrict gj = gu + (t + j) * N + n0;
          for (int64_t n = 0; n < len; ++n) b[n] += nu * gj[n];
        }
      } else if (k.form == Form::DelayedExp) {
        for (int64_t n = 0; n < len; ++n) b[n] = g * q[n];
      } else {
        for (int64_t n = 0; n < len; ++n) {
          r[n] = a * (r[n] + q[n]);
          b[n] = g * r[n];
        }
      }
      const S* __restrict gsr = gs + t * N + n0;
      const S* __restrict u = ur + t * N + n0;
      S* __restrict go = gu + t * N + n0;
      for (int64_t n = 0; n < len; ++n) {
        const S rho = c * std::exp(-std::abs(u[n] - theta) * inv_tau);
        go[n] = rho * (gsr[n] + ts * b[n]);
      }
      if (k.form != Form::FIR)
        for (int64_t n = 0; n < len; ++n) q[n] = a * q[n] + go[n];
    }
  });
}

// ---- Per-step tensor-op path (any device) ----

std::pair<torch::Tensor, torch::Tensor> forward_ops(const torch::Tensor& u, const SpikeParams& p) {
  const int64_t T = u.size(0);
  torch::Tensor ur = u.clone(), s = torch::zeros_like(u);
  const auto& k = p.refractory;
  torch::Tensor q = torch::zeros_like(u[0]), r = torch::zeros_like(u[0]);
  for (int64_t t = 0; t < T; ++t) {
    torch::Tensor ut = ur[t];
    if (k.form == Form::DelayedExp) ut.add_(k.gain * q);
    if (k.form == Form::Alpha) {
      r = k.decay * (r + q);
      ut.add_(k.gain * r);
    }
    torch::Tensor sp = (ut >= double(p.theta)).to(u.scalar_type());
    s[t].copy_(sp / p.ts);
    if (k.form == Form::FIR) {
      for (int64_t j = 0; j < int64_t(k.taps.size()) && t + j < T; ++j)
        if (k.taps[size_t(j)] != 0.f) ur[t + j].add_(sp * double(k.taps[size_t(j)]));
    } else {
      q = k.decay * q + sp;
    }
  }
  return {s, ur};
}

torch::Tensor backward_exact_ops(const torch::Tensor& gs, const torch::Tensor& ur,
                                 const SpikeParams& p) {
  const int64_t T = gs.size(0);
  torch::Tensor rho = surrogate_pdf(ur, p), gu = torch::zeros_like(gs);
  const auto& k = p.refractory;
  torch::Tensor q = torch::zeros_like(gs[0]), r = torch::zeros_like(gs[0]);
  for (int64_t t = T - 1; t >= 0; --t) {
    torch::Tensor b = torch::zeros_like(gs[0]);
    if (k.form == Form::FIR) {
      for (int64_t j = 1; j < int64_t(k.taps.size()) && t + j < T; ++j)
        b = b + double(k.taps[size_t(j)]) * gu[t + j];
    } else if (k.form == Form::DelayedExp) {
      b = k.gain * q;
    } else {
      r = k.decay * (r + q);
      b = k.gain * r;
    }
    gu[t].copy_(rho[t] * (gs[t] + p.ts * b));
    if (k.form != Form::FIR) q = k.decay * q + gu[t];
  }
  return gu;
}

class SpikeFunction : public torch::autograd::Function<SpikeFunction> {
 public:
  static torch::Tensor forward(AutogradContext* ctx, torch::Tensor u2d, const SpikeParams& p) {
    auto [s, ur] = spike_forward(u2d, p, neuron_kernels() == NeuronKernels::Fused);
    ctx->save_for_backward({ur});
    save_kernel(ctx, "ref", p.refractory);
    ctx->saved_data["theta"] = double(p.theta);
    ctx->saved_data["ts"] = p.ts;
    ctx->saved_data["surrogate"] = int64_t(p.surrogate);
    ctx->saved_data["tau_rho"] = p.tau_rho;
    ctx->saved_data["scale_rho"] = p.scale_rho;
    ctx->saved_data["gradient"] = int64_t(p.gradient);
    return s;
  }
  static variable_list backward(AutogradContext* ctx, variable_list g) {
    SpikeParams p;
    p.refractory = load_kernel(ctx, "ref");
    p.theta = float(ctx->saved_data["theta"].toDouble());
    p.ts = ctx->saved_data["ts"].toDouble();
    p.surrogate = SurrogateForm(ctx->saved_data["surrogate"].toInt());
    p.tau_rho = ctx->saved_data["tau_rho"].toDouble();
    p.scale_rho = ctx->saved_data["scale_rho"].toDouble();
    p.gradient = SpikeGradient(ctx->saved_data["gradient"].toInt());
    torch::Tensor ur = ctx->get_saved_variables()[0];
    return {spike_backward(g[0], ur, p, neuron_kernels() == NeuronKernels::Fused), torch::Tensor()};
  }
};

}  // namespace

SpikeParams SpikeParams::from_layer(const LayerSpec& l, double ts, SpikeGradient g) {
  SpikeParams p;
  p.theta = l.neuron.theta;
  p.ts = ts;
  p.refractory = TemporalKernel::refractory(l, ts);
  p.surrogate = l.neuron.surrogate;
  p.tau_rho = l.neuron.tau_rho;
  p.scale_rho = l.neuron.scale_rho;
  p.gradient = g;
  return p;
}

double SpikeParams::pdf_scale() const {
  const double th = double(theta);
  return surrogate == SurrogateForm::Slayer ? scale_rho / (tau_rho * th) : scale_rho / th;
}

double SpikeParams::pdf_tau() const {
  return tau_rho * double(theta);
}

torch::Tensor surrogate_pdf(const torch::Tensor& ur, const SpikeParams& p) {
  return p.pdf_scale() * torch::exp(-torch::abs(ur - double(p.theta)) / p.pdf_tau());
}

std::pair<torch::Tensor, torch::Tensor> spike_forward(const torch::Tensor& u_in,
                                                      const SpikeParams& p, bool use_fused) {
  torch::Tensor u = u_in.contiguous();
  const Fused f = fused_for(u, p, use_fused);
  if (f == Fused::None) return forward_ops(u, p);
  if (f == Fused::Cuda) return cuda_spike_forward(u, p);
  const int64_t T = u.size(0), N = u.numel() / T;
  torch::Tensor ur = u.clone(), s = torch::empty_like(u);
  AT_DISPATCH_FLOATING_TYPES(u.scalar_type(), "spike_forward", [&] {
    forward_cpu<scalar_t>(ur.data_ptr<scalar_t>(), s.data_ptr<scalar_t>(), T, N, p);
  });
  return {s, ur};
}

torch::Tensor spike_backward(const torch::Tensor& gs_in, const torch::Tensor& ur_in,
                             const SpikeParams& p, bool use_fused) {
  const Fused f = fused_for(gs_in, p, use_fused);
  if (f == Fused::Cuda) return cuda_spike_backward(gs_in.contiguous(), ur_in.contiguous(), p);
  if (p.gradient == SpikeGradient::Slayer) return surrogate_pdf(ur_in, p) * gs_in;
  torch::Tensor gs = gs_in.contiguous(), ur = ur_in.contiguous();
  if (f == Fused::None) return backward_exact_ops(gs, ur, p);
  const int64_t T = gs.size(0), N = gs.numel() / T;
  torch::Tensor gu = torch::empty_like(gs);
  AT_DISPATCH_FLOATING_TYPES(gs.scalar_type(), "spike_backward", [&] {
    backward_exact_cpu<scalar_t>(gs.data_ptr<scalar_t>(), ur.data_ptr<scalar_t>(),
                                 gu.data_ptr<scalar_t>(), T, N, p);
  });
  return gu;
}

torch::Tensor spike(const torch::Tensor& u, const SpikeParams& p) {
  TORCH_CHECK(u.dim() >= 1, "spike: input needs a leading time axis");
  const int64_t T = u.size(0);
  torch::Tensor s = SpikeFunction::apply(u.reshape({T, -1}), p);
  return s.view(u.sizes());
}

}  // namespace spikems::train
