#include "train/trainer/weight_init.h"

#include <cmath>

#include "core/util/error.h"

namespace spikems::train {

double firing_rate(const torch::Tensor& spikes, double ts) {
  return spikes.detach().mean().item<double>() * ts;
}

std::vector<torch::Tensor> ann_weight_directions(const ModelSpec& ann, const ModelSpec& snn,
                                                 const std::string& source) {
  auto bad = [&](size_t k, const std::string& why) {
    throw Error(source + ": layer " + std::to_string(k) + ": " + why +
                ": the ANN-2D's weights cannot start this network (the same model.channels)");
  };
  if (ann.type != ModelType::ANN2D) throw Error(source + ": not an ANN-2D model file");
  if (ann.layers.size() != snn.layers.size())
    throw Error(source + ": " + std::to_string(ann.layers.size()) + " layers, the network " +
                std::to_string(snn.layers.size()) + " (the same model.channels)");
  std::vector<torch::Tensor> out;
  for (size_t k = 0; k < snn.layers.size(); ++k) {
    const LayerSpec &a = ann.layers[k], &s = snn.layers[k];
    if (a.kind != s.kind || a.kernel != s.kernel || a.stride != s.stride) bad(k, "other kernels");
    const bool first = k == 0, last = k + 1 == snn.layers.size();
    const int pred_in =
        s.skip_from >= 0 ? s.in_channels - snn.layers[s.skip_from].out_channels : s.in_channels;
    // A teacher with the same skip feeds every input channel; one without it, the predecessor's.
    const bool same_skip = a.skip_from >= 0 && a.skip_from == s.skip_from;
    const int fed = same_skip ? s.in_channels : pred_in;
    if (first ? (a.in_channels != ann.ann_input_channels() || s.in_channels != 2)
              : a.in_channels != fed)
      bad(k, "other input channels");
    if (last ? a.out_channels != 1 : a.out_channels != s.out_channels)
      bad(k, "other output channels");
    const bool transposed = s.kind == LayerKind::ConvTranspose;
    const torch::Tensor w =
        torch::tensor(a.weight, torch::kFloat)
            .reshape(transposed
                         ? std::vector<int64_t>{a.in_channels, a.out_channels, a.kernel, a.kernel}
                         : std::vector<int64_t>{a.out_channels, a.in_channels, a.kernel, a.kernel});
    // The SNN's weight shape: conv [out, in, k, k], transposed conv [in, out, k, k].
    torch::Tensor d = transposed
                          ? torch::zeros({s.in_channels, s.out_channels, s.kernel, s.kernel})
                          : torch::zeros({s.out_channels, s.in_channels, s.kernel, s.kernel});
    // The output layer's one logit channel is broadcast into each of the SNN's channels.
    const int64_t in_dim = transposed ? 0 : 1;
    if (first) {
      TORCH_CHECK(!transposed, "the first layer is a convolution");
      // The window's own frame (channels 0-3); a teacher's past frames have no counterpart
      // in the SNN's input: its state carries the past instead.
      d.copy_(std::log(2.0) * w.narrow(1, 0, 2) + 0.5 * w.narrow(1, 2, 2));
    } else {
      // Input channels first: the predecessor's, then the skip's (zero unless the teacher
      // has the same skip).
      torch::Tensor block = d.narrow(in_dim, 0, fed);
      block.copy_(last ? w.expand_as(block) : w);
    }
    out.push_back(d);
  }
  return out;
}

std::vector<double> init_weights_from_data(SpikeMSNetwork& net, const torch::Tensor& input,
                                           const std::vector<double>& rates, double ts,
                                           uint64_t seed,
                                           const std::vector<torch::Tensor>& directions) {
  TORCH_CHECK(directions.empty() || directions.size() == net->size(),
              "weight init: one direction per layer");
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
    // Drawn even when a direction replaces it, so the generator's sequence stays the same.
    torch::Tensor w0 = at::normal(0.0, 1.0 / std::sqrt(fan_in), l->weight.sizes(), gen);
    if (!directions.empty()) {
      const torch::Tensor& d = directions[k];
      TORCH_CHECK(d.sizes() == l->weight.sizes(), "weight init: layer ", k, " direction ",
                  d.sizes(), " for weights ", l->weight.sizes());
      // The same RMS over its non-zero entries as the random draw's (the bisection's range).
      const torch::Tensor nz = d.ne(0);
      const double n = nz.sum().item<double>();
      const double rms = n > 0 ? std::sqrt(d.pow(2).sum().item<double>() / n) : 0.0;
      if (rms > 0) w0 = (d * (1.0 / (rms * std::sqrt(fan_in)))).to(l->weight.dtype());
    }
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
