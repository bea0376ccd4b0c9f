// The SRM neuron pieces against direct formulas (double precision, small tensors): psp vs the
// explicit sum, FIR vs IIR, spike loop vs a scalar transcription of getSpikes, custom backward
// vs a per-step autograd reference and vs finite differences.
#include <gtest/gtest.h>

#include <cmath>

#include "train/neuron/psp.h"
#include "train/neuron/spike.h"
#include "train_test_util.h"

namespace spikems::train {
namespace {

using Form = TemporalKernel::Form;

torch::Tensor random_spikes(int64_t T, int64_t N, double p, uint64_t seed, torch::Dtype dt) {
  torch::manual_seed(seed);
  return (torch::rand({T, N}, torch::kDouble) < p).to(dt);
}

// Long sampled kernels (no 0.01 cutoff) so that FIR == IIR up to the float rounding.
std::vector<float> long_alpha(double tau, double ts, double amp, int n) {
  std::vector<float> k;
  for (int i = 0; i < n; ++i) k.push_back(float(amp * (i * ts / tau) * std::exp(1 - i * ts / tau)));
  return k;
}
std::vector<float> long_delayed_exp(double tau, double ts, double gain, int n) {
  std::vector<float> k{0.f};
  for (int i = 1; i < n; ++i) k.push_back(float(gain * std::exp(-(i - 1) * ts / tau)));
  return k;
}

std::vector<TemporalKernel> all_kernels() {
  return {TemporalKernel::fir({0.f, 0.8f, 1.f, 0.5f, 0.25f}),
          TemporalKernel::alpha(2.0, 1.0, 1.0),
          TemporalKernel::delayed_exp(3.0, 1.0, -0.48),
          TemporalKernel::alpha(1.5, 0.5, -0.44),
          TemporalKernel::alpha_lead(2.0, 1.0, 1.0),
          TemporalKernel::alpha_lead(1.0, 2.0, 0.7)};
}

// SrmOnset::SameStep: the alpha kernel sampled a step later, eps(Ts) at n = 0, so the psp of a
// spike train is SLAYER's one step earlier: lead[t] = alpha[t + 1].
TEST(Psp, SameStepKernelIsTheAlphaOneStepEarlier) {
  const double ts = 2.0, tau = 1.0;
  const auto lead = TemporalKernel::alpha_lead(tau, ts, 1.0);
  const auto h = lead.impulse_response(3);
  EXPECT_NEAR(h[0], (ts / tau) * std::exp(1 - ts / tau), 1e-15);
  EXPECT_NEAR(h[1], (2 * ts / tau) * std::exp(1 - 2 * ts / tau), 1e-15);
  torch::Tensor x = random_spikes(30, 40, 0.2, 3, torch::kDouble);
  const torch::Tensor a = psp(x, TemporalKernel::alpha(tau, ts, 1.0), ts);
  const torch::Tensor b = psp(x, lead, ts);
  EXPECT_GT(b[0].abs().max().item<double>(), 0.0);
  EXPECT_EQ(a[0].abs().max().item<double>(), 0.0);
  EXPECT_LT((b.narrow(0, 0, 29) - a.narrow(0, 1, 29)).abs().max().item<double>(), 1e-12);
  LayerSpec l;
  l.neuron.discretisation = Discretisation::IIR;
  l.neuron.tau_s = float(tau);
  l.neuron.srm_onset = SrmOnset::SameStep;
  EXPECT_EQ(TemporalKernel::srm(l, ts).form, TemporalKernel::Form::AlphaLead);
}

TEST(Psp, MatchesExplicitSumForEveryKernelForm) {
  const int64_t T = 23, N = 37;
  torch::Tensor x = torch::randn({T, N}, torch::kDouble);
  for (const auto& k : all_kernels()) {
    auto h = k.impulse_response(int(T));
    for (bool rev : {false, true}) {
      torch::Tensor y = apply_temporal_kernel_cpu(x, k, 0.5, rev);
      torch::Tensor yo = apply_temporal_kernel_ops(x, k, 0.5, rev);
      auto xa = x.accessor<double, 2>();
      double maxerr = 0;
      for (int64_t t = 0; t < T; ++t)
        for (int64_t n = 0; n < N; ++n) {
          double s = 0;
          for (int64_t i = 0; i < T; ++i) {
            int64_t src = rev ? t + i : t - i;
            if (src >= 0 && src < T) s += h[size_t(i)] * xa[src][n];
          }
          maxerr = std::max(maxerr, std::abs(0.5 * s - y[t][n].item<double>()));
        }
      EXPECT_LT(maxerr, 1e-12) << "form " << int(k.form) << " reverse " << rev;
      EXPECT_LT((y - yo).abs().max().item<double>(), 1e-12);
    }
  }
}

TEST(Psp, FirReferenceOrderIsBitExactInFloat) {
  // Sum with i ascending then multiply by Ts, as the SLAYER kernel: compare bit for bit.
  auto eps = sample_srm_kernel(4.0, 1.0);
  torch::Tensor x = random_spikes(40, 100, 0.2, 1, torch::kFloat);
  torch::Tensor y = apply_temporal_kernel_cpu(x, TemporalKernel::fir(eps), 1.0, false);
  auto xa = x.accessor<float, 2>();
  for (int64_t t = 0; t < 40; ++t)
    for (int64_t n = 0; n < 100; ++n) {
      float s = 0.f;
      for (int64_t i = 0; i < int64_t(eps.size()) && i <= t; ++i)
        s += xa[t - i][n] * eps[size_t(i)];
      ASSERT_EQ(s * 1.0f, y[t][n].item<float>());
    }
}

TEST(Psp, FirAndIirAgreeWithALongKernel) {
  torch::Tensor x = random_spikes(60, 500, 0.1, 2, torch::kFloat);
  for (double tau : {2.0, 4.0}) {
    torch::Tensor a = psp(x, TemporalKernel::fir(long_alpha(tau, 1.0, 1.0, 400)), 1.0);
    torch::Tensor b = psp(x, TemporalKernel::alpha(tau, 1.0, 1.0), 1.0);
    EXPECT_LT((a - b).abs().max().item<double>(), 1e-5) << "tau " << tau;
  }
}

TEST(Psp, BackwardMatchesFiniteDifferencesAndAutograd) {
  for (const auto& k : all_kernels()) {
    torch::Tensor x = torch::randn({9, 2, 3}, torch::kDouble).requires_grad_(true);
    EXPECT_LT(spikems::test::finite_difference_error(
                  [&](const torch::Tensor& v) { return psp(v, k, 0.7); }, x),
              1e-7);
    torch::Tensor w = torch::randn({9, 2, 3}, torch::kDouble);
    torch::Tensor g1 = torch::autograd::grad({(psp(x, k, 0.7) * w).sum()}, {x})[0];
    torch::Tensor g2 =
        torch::autograd::grad({(apply_temporal_kernel_ops(x, k, 0.7, false) * w).sum()}, {x})[0];
    EXPECT_LT((g1 - g2).abs().max().item<double>(), 1e-12);
  }
}

// Scalar transcription of the README's getSpikes (in place, >= theta, tail cut at T), for any
// refractory given by its impulse response (which is what the IIR forms must reproduce).
template <typename S>
void scalar_spikes(std::vector<S>& u, std::vector<S>& s, int64_t T, int64_t N, S theta,
                   const std::vector<S>& nu, S ts) {
  for (int64_t n = 0; n < N; ++n)
    for (int64_t t = 0; t < T; ++t) {
      if (u[size_t(t * N + n)] >= theta) {
        s[size_t(t * N + n)] = S(1) / ts;
        for (int64_t j = 0; j < int64_t(nu.size()) && t + j < T; ++j)
          u[size_t((t + j) * N + n)] += nu[size_t(j)];
      } else {
        s[size_t(t * N + n)] = 0;
      }
    }
}

TEST(Spike, FirIsBitExactToTheScalarReferenceInFloat) {
  const int64_t T = 40, N = 777;
  torch::manual_seed(3);
  torch::Tensor u = torch::rand({T, N}) * 0.6f;
  SpikeParams p;
  p.theta = 0.24f;
  p.refractory = TemporalKernel::fir(sample_refractory_kernel(NeuronParams{0.24f, 4, 3}, 1.0));
  std::vector<float> uv(u.data_ptr<float>(), u.data_ptr<float>() + u.numel()), sv(uv.size());
  scalar_spikes<float>(uv, sv, T, N, 0.24f, p.refractory.taps, 1.f);
  for (bool cpu : {true, false}) {
    auto [s, ur] = spike_forward(u, p, cpu);
    for (int64_t i = 0; i < T * N; ++i) {
      ASSERT_EQ(s.data_ptr<float>()[i], sv[size_t(i)]) << i << " cpu " << cpu;
      ASSERT_EQ(ur.data_ptr<float>()[i], uv[size_t(i)]) << i << " cpu " << cpu;
    }
  }
}

TEST(Spike, IirFormsMatchTheScalarReferenceWithTheirImpulseResponse) {
  const int64_t T = 50, N = 300;
  torch::manual_seed(4);
  torch::Tensor u = torch::rand({T, N}, torch::kDouble) * 0.6;
  for (const auto& k :
       {TemporalKernel::delayed_exp(3.0, 1.0, -0.48), TemporalKernel::alpha(1.0, 1.0, -0.44)}) {
    SpikeParams p;
    p.theta = 0.24f;
    p.refractory = k;
    auto h = k.impulse_response(int(T));
    std::vector<double> uv(u.data_ptr<double>(), u.data_ptr<double>() + u.numel()), sv(uv.size());
    scalar_spikes<double>(uv, sv, T, N, double(p.theta), h, 1.0);
    for (bool cpu : {true, false}) {
      auto [s, ur] = spike_forward(u, p, cpu);
      torch::Tensor sr = torch::from_blob(sv.data(), {T, N}, torch::kDouble);
      torch::Tensor urr = torch::from_blob(uv.data(), {T, N}, torch::kDouble);
      EXPECT_EQ((s != sr).sum().item<int64_t>(), 0) << "form " << int(k.form) << " cpu " << cpu;
      EXPECT_LT((ur - urr).abs().max().item<double>(), 1e-12);
      EXPECT_GT(s.sum().item<double>(), 100);  // the test exercises the refractory
    }
  }
}

TEST(Spike, FirAndIirRefractoryAgreeWithALongKernel) {
  torch::manual_seed(5);
  torch::Tensor u = torch::rand({60, 400}, torch::kDouble) * 0.8;
  SpikeParams a, b;
  a.refractory = TemporalKernel::fir(long_delayed_exp(3.0, 1.0, -0.44, 200));
  b.refractory = TemporalKernel::delayed_exp(3.0, 1.0, -0.44);
  auto [sa, ua] = spike_forward(u, a, true);
  auto [sb, ub] = spike_forward(u, b, true);
  EXPECT_EQ((sa != sb).sum().item<int64_t>(), 0);
  EXPECT_LT((ua - ub).abs().max().item<double>(), 1e-5);
}

// Straight-through Heaviside with the SLAYER surrogate, for the autograd reference.
struct SurrogateStep : torch::autograd::Function<SurrogateStep> {
  static torch::Tensor forward(torch::autograd::AutogradContext* ctx, torch::Tensor u, double theta,
                               double c, double tau) {
    ctx->save_for_backward({u});
    ctx->saved_data["theta"] = theta;
    ctx->saved_data["c"] = c;
    ctx->saved_data["tau"] = tau;
    return (u >= theta).to(u.dtype());
  }
  static torch::autograd::variable_list backward(torch::autograd::AutogradContext* ctx,
                                                 torch::autograd::variable_list g) {
    auto u = ctx->get_saved_variables()[0];
    double th = ctx->saved_data["theta"].toDouble(), c = ctx->saved_data["c"].toDouble(),
           tau = ctx->saved_data["tau"].toDouble();
    return {g[0] * c * torch::exp(-torch::abs(u - th) / tau), {}, {}, {}};
  }
};

// Per-step reference built from differentiable ops: u~[t] = u[t] + sum_{t'<t} nu[t-t'] ind[t'].
torch::Tensor reference_spikes(const torch::Tensor& u, const SpikeParams& p) {
  const int64_t T = u.size(0);
  auto h = p.refractory.impulse_response(int(T));
  double c = p.surrogate == SurrogateForm::Slayer ? p.scale_rho / (p.tau_rho * p.theta)
                                                  : p.scale_rho / p.theta;
  std::vector<torch::Tensor> ind;
  for (int64_t t = 0; t < T; ++t) {
    torch::Tensor ut = u[t];
    for (int64_t tp = 0; tp < t; ++tp) {
      torch::Tensor i =
          p.gradient == SpikeGradient::Exact ? ind[size_t(tp)] : ind[size_t(tp)].detach();
      ut = ut + h[size_t(t - tp)] * i;
    }
    ind.push_back(SurrogateStep::apply(ut, double(p.theta), c, p.tau_rho * p.theta));
  }
  return torch::stack(ind, 0) / p.ts;
}

TEST(Spike, BackwardMatchesPerStepAutogradReference) {
  const int64_t T = 25, N = 60;
  for (auto g : {SpikeGradient::Slayer, SpikeGradient::Exact})
    for (auto form : {SurrogateForm::Slayer, SurrogateForm::SpikeMS})
      for (const auto& k :
           {TemporalKernel::fir(sample_refractory_kernel(NeuronParams{0.24f, 4, 3}, 1.0)),
            TemporalKernel::delayed_exp(3.0, 1.0, -0.48), TemporalKernel::alpha(1.0, 1.0, -0.48)}) {
        SpikeParams p;
        p.theta = 0.24f;
        p.refractory = k;
        p.gradient = g;
        p.surrogate = form;
        p.scale_rho = 0.3;
        torch::manual_seed(6);
        torch::Tensor u = (torch::rand({T, N}, torch::kDouble) * 0.6).requires_grad_(true);
        torch::Tensor w = torch::randn({T, N}, torch::kDouble);
        torch::Tensor s1 = spike(u, p), s2 = reference_spikes(u, p);
        EXPECT_EQ((s1 != s2).sum().item<int64_t>(), 0);
        torch::Tensor g1 = torch::autograd::grad({(s1 * w).sum()}, {u})[0];
        torch::Tensor g2 = torch::autograd::grad({(s2 * w).sum()}, {u})[0];
        EXPECT_LT((g1 - g2).abs().max().item<double>(), 1e-10 * (1 + g2.abs().max().item<double>()))
            << "gradient " << int(g) << " kernel " << int(k.form);
        // CPU kernel vs the per-step tensor-op path (other devices).
        auto [s, ur] = spike_forward(u.detach(), p, true);
        torch::Tensor b1 = spike_backward(w, ur, p, true), b2 = spike_backward(w, ur, p, false);
        EXPECT_LT((b1 - b2).abs().max().item<double>(), 1e-10);
        if (g == SpikeGradient::Exact) {
          EXPECT_GT((g1 - surrogate_pdf(ur, p) * w).abs().max().item<double>(), 1e-6);
        }
      }
}

TEST(Spike, SurrogateFormulas) {
  SpikeParams p;
  p.theta = 0.25f;
  p.tau_rho = 0.3;
  p.scale_rho = 0.2;
  torch::Tensor u = torch::tensor({0.25, 0.4}, torch::kDouble);
  p.surrogate = SurrogateForm::Slayer;
  torch::Tensor a = surrogate_pdf(u, p);
  EXPECT_NEAR(a[0].item<double>(), 0.2 / (0.3 * 0.25), 1e-12);
  EXPECT_NEAR(a[1].item<double>(), 0.2 / (0.3 * 0.25) * std::exp(-0.15 / 0.075), 1e-12);
  p.surrogate = SurrogateForm::SpikeMS;
  EXPECT_NEAR(surrogate_pdf(u, p)[1].item<double>(), 0.2 / 0.25 * std::exp(-0.15 / 0.075), 1e-12);
}

}  // namespace
}  // namespace spikems::train
