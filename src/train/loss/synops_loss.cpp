#include "train/loss/synops_loss.h"

#include "core/util/error.h"
#include "train/synapse/conv_taps.h"

namespace spikems::train {

SynopsCounter::SynopsCounter(const ModelSpec& spec) : consumers_(spec.layers.size() + 1) {
  spec.validate(spec.name);  // skip sources are earlier layers, other than the predecessor
  for (size_t j = 0; j < spec.layers.size(); ++j) {
    const LayerSpec& l = spec.layers[j];
    const Consumer c{j,         l.kernel,       l.stride,
                     l.padding, l.out_channels, l.kind == LayerKind::ConvTranspose};
    consumers_[j].push_back(c);  // its predecessor (j - 1), or the input for j = 0
    if (l.skip_from >= 0) consumers_[size_t(l.skip_from) + 1].push_back(c);
  }
}

std::vector<double> SynopsCounter::reach(int64_t in, int64_t out, int kernel, int stride,
                                         int padding, bool transposed) {
  std::vector<double> r(static_cast<size_t>(std::max<int64_t>(0, in)), 0.0);
  for (int64_t i = 0; i < in; ++i)
    for (int tap = 0; tap < kernel; ++tap)
      r[size_t(i)] += tap_output(i, tap, stride, padding, transposed, out) >= 0;
  return r;
}

torch::Tensor SynopsCounter::per_sample(const torch::Tensor& input,
                                        const std::vector<torch::Tensor>& layers, double ts,
                                        const std::vector<double>& source_weights) const {
  if (layers.size() + 1 != consumers_.size())
    throw Error("SynOps: " + std::to_string(layers.size()) + " layers given, the model has " +
                std::to_string(consumers_.size() - 1));
  if (!source_weights.empty() && source_weights.size() != consumers_.size())
    throw Error("SynOps: " + std::to_string(source_weights.size()) +
                " source weights given, the model has " + std::to_string(consumers_.size()) +
                " sources (the input and each layer)");
  const auto opt = input.options();
  torch::Tensor total = torch::zeros({input.size(1)}, opt);
  for (size_t s = 0; s < consumers_.size(); ++s) {
    const double weight = source_weights.empty() ? 1.0 : source_weights[s];
    if (consumers_[s].empty() || weight == 0) continue;
    const torch::Tensor& src = s == 0 ? input : layers[s - 1];
    // Spikes per position and sample, over steps and channels (spikes are 1/ts).
    const torch::Tensor count = src.sum(std::vector<int64_t>{0, 2}) * ts;  // [B, H, W]
    const int64_t h = src.size(3), w = src.size(4);
    for (const Consumer& c : consumers_[s]) {
      const torch::Tensor& out = layers[c.layer];
      const auto rows = reach(h, out.size(3), c.kernel, c.stride, c.padding, c.transposed);
      const auto cols = reach(w, out.size(4), c.kernel, c.stride, c.padding, c.transposed);
      const auto dopt = torch::TensorOptions().dtype(torch::kDouble);
      const torch::Tensor map =
          torch::outer(torch::tensor(rows, dopt), torch::tensor(cols, dopt)).to(opt) *
          double(c.out_channels);
      total = total + weight * (count * map).sum(std::vector<int64_t>{1, 2});
    }
  }
  return total;
}

torch::Tensor synops_penalty(const torch::Tensor& sope, double weight, double budget) {
  if (budget > 0) return weight * torch::relu(sope / budget - 1).pow(2).mean();
  return weight * (sope / 1000).mean();
}

}  // namespace spikems::train
