// Helpers shared by the train tests: npz arrays <-> tensors in the authors' (N, C, H, W, T)
// layout, running import-slayer on the shared reference weights, random firing networks.
#pragma once

#include <torch/torch.h>

#include <map>
#include <string>

#include "common/test_paths.h"
#include "core/events/formats/npy.h"
#include "core/model/model_file.h"

namespace spikems::test {

// Random weights that make every layer of a 32x24 network fire.
inline ModelSpec random_model(Discretisation d, uint64_t seed, bool skips = false) {
  ModelSpec s = spikems_architecture(true, d, {16, 32, 64}, {}, skips);
  torch::manual_seed(seed);
  for (auto& l : s.layers) {
    torch::Tensor w = torch::randn({l.weight_count()}, torch::kDouble) * 0.5;
    for (size_t i = 0; i < l.weight.size(); ++i) l.weight[i] = float(w[int64_t(i)].item<double>());
  }
  return s;
}

inline torch::Tensor random_spikes(std::vector<int64_t> shape, double density) {
  return (torch::rand(shape, torch::kDouble) < density).to(torch::kDouble);
}

// Largest |a - b| relative to max|b| (the absolute difference when b vanishes).
inline double rel_err(const torch::Tensor& a, const torch::Tensor& b) {
  const double scale = b.abs().max().item<double>();
  const double diff = (a - b).abs().max().item<double>();
  return scale == 0 ? diff : diff / scale;
}

// (N, C, H, W, T) float array -> [T, N, C, H, W] float tensor.
inline torch::Tensor time_major(const NpyArray& a) {
  std::vector<float> v = a.to<float>();
  return torch::from_blob(v.data(), a.shape, torch::kFloat).permute({4, 0, 1, 2, 3}).contiguous();
}

// Imports ../shared weights.npz with the CLI into `dir`; returns the loaded spec.
inline ModelSpec import_reference_model(const std::string& weights, const std::string& dir) {
  std::string model = dir + "/evimo.safetensors", out;
  int rc = run_command(spikems_binary() + " import-slayer " + weights + " --out " + model, &out);
  EXPECT_EQ(rc, 0) << out;
  return load_model(model);
}

// Largest difference between the autograd gradient of sum(f(x) * w) (random w) and central
// finite differences, over every element of x (double precision; keep x small).
template <typename F>
double finite_difference_error(F f, const torch::Tensor& x0, double h = 1e-6) {
  torch::Tensor x = x0.detach().clone().requires_grad_(true);
  torch::Tensor w = torch::randn(f(x.detach()).sizes(), x.options().requires_grad(false));
  torch::Tensor g = torch::autograd::grad({(f(x) * w).sum()}, {x})[0];
  torch::NoGradGuard ng;
  torch::Tensor xf = x.detach().clone().view(-1);
  double err = 0;
  for (int64_t i = 0; i < xf.numel(); ++i) {
    double v = xf[i].item<double>();
    xf[i] = v + h;
    torch::Tensor fpt = f(xf.view(x.sizes()));
    double fp = (fpt * w).sum().item().toDouble();
    xf[i] = v - h;
    torch::Tensor fmt = f(xf.view(x.sizes()));
    double fm = (fmt * w).sum().item().toDouble();
    xf[i] = v;
    err = std::max(err, std::abs((fp - fm) / (2 * h) - g.reshape(-1)[i].item<double>()));
  }
  return err;
}

}  // namespace spikems::test
