#include "train/trainer/weight_init.h"

#include <cmath>

namespace spikems::train {

double firing_rate(const torch::Tensor& spikes, double ts) {
  return spikes.detach().mean().item<double>() * ts;
}

std::vector<double> init_weights_from_data(SpikeMSNetwork& net, const torch::Tensor& input,
                                           const std::vector<double>& rates, double ts,
                                           uint64_t seed) {
  torch::NoGradGuard ng;
  auto gen = at::detail::createCPUGenerator(seed);
  std::vector<double> reached;
  std::vector<torch::Tensor> outs;
  for (size_t k = 0; k < net->size(); ++k) {
    const torch::Tensor x = net->input_of(k, input, outs);
    SpikingLayer& l = net->layer(k);
    const auto sz = l->weight.sizes();
    const double fan_in =
        double(sz[1 - (l->to_spec().kind == LayerKind::ConvTranspose)]) * double(sz[2] * sz[3]);
    torch::Tensor w0 = at::normal(0.0, 1.0 / std::sqrt(fan_in), l->weight.sizes(), gen);
    auto rate_at = [&](double g) {
      l->weight.copy_(w0 * g);
      return firing_rate(l->forward(x), ts);
    };
    // Bisection in log scale on the gain (the rate grows with it).
    double lo = 1e-2, hi = 1e3;
    for (int it = 0; it < 18; ++it) {
      const double mid = std::sqrt(lo * hi);
      (rate_at(mid) < rates[k] ? lo : hi) = mid;
    }
    const double r = rate_at(hi);
    reached.push_back(r);
    outs.push_back(l->forward(x));
  }
  return reached;
}

}  // namespace spikems::train
