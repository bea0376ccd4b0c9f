#include "train/network/ann2d_network.h"

#include "core/util/error.h"
#include "train/network/spikems_network.h"

namespace spikems::train {

Ann2dNetworkImpl::Ann2dNetworkImpl(const ModelSpec& spec) : spec_(spec) {
  spec.validate(spec.name);
  if (spec.type != ModelType::ANN2D) fail(spec.name, "", "not an ANN-2D model");
  for (size_t k = 0; k < spec.layers.size(); ++k) {
    const LayerSpec& l = spec.layers[k];
    torch::Tensor w, b;
    const std::string name = "layer" + std::to_string(k + 1);
    if (l.kind == LayerKind::Conv) {
      auto m = register_module(
          name, torch::nn::Conv2d(torch::nn::Conv2dOptions(l.in_channels, l.out_channels, l.kernel)
                                      .stride(l.stride)
                                      .padding(l.padding)));
      w = m->weight;
      b = m->bias;
      layers_.emplace_back(m);
    } else {
      auto m = register_module(
          name, torch::nn::ConvTranspose2d(
                    torch::nn::ConvTranspose2dOptions(l.in_channels, l.out_channels, l.kernel)
                        .stride(l.stride)
                        .padding(l.padding)
                        .output_padding(l.output_padding)));
      w = m->weight;
      b = m->bias;
      layers_.emplace_back(m);
    }
    const bool given =
        std::any_of(l.weight.begin(), l.weight.end(), [](float v) { return v != 0; });
    if (given) {
      torch::NoGradGuard ng;
      w.copy_(torch::from_blob(const_cast<float*>(l.weight.data()), w.sizes(), torch::kFloat));
      b.copy_(torch::from_blob(const_cast<float*>(l.bias.data()), b.sizes(), torch::kFloat));
    }
    weights_.push_back(w);
    biases_.push_back(b);
  }
  for (auto& l : spec_.layers) {
    l.weight.clear();
    l.bias.clear();
  }
}

std::vector<torch::Tensor> Ann2dNetworkImpl::forward_all(const torch::Tensor& x) {
  std::vector<torch::Tensor> out;
  torch::Tensor s = pad_for_skips(spec_, x);
  for (size_t k = 0; k < layers_.size(); ++k) {
    const int skip = spec_.layers[k].skip_from;
    if (skip >= 0) s = torch::cat({s, out[size_t(skip)]}, 1);  // the predecessor's, then the skip's
    s = layers_[k].forward(s);
    if (k + 1 < layers_.size()) s = torch::relu(s);
    out.push_back(s);
  }
  return out;
}

torch::Tensor Ann2dNetworkImpl::forward(const torch::Tensor& x) {
  return align_to_input(forward_all(x).back(), x.size(2), x.size(3));
}

ModelSpec Ann2dNetworkImpl::to_spec() const {
  ModelSpec s = spec_;
  for (size_t k = 0; k < s.layers.size(); ++k) {
    auto w = weights_[k].detach().cpu().contiguous(), b = biases_[k].detach().cpu().contiguous();
    s.layers[k].weight.assign(w.data_ptr<float>(), w.data_ptr<float>() + w.numel());
    s.layers[k].bias.assign(b.data_ptr<float>(), b.data_ptr<float>() + b.numel());
  }
  return s;
}

namespace {

// The 4 features of steps [a, a + T) of input spikes [*, B, 2, H, W] (values 1/Ts).
torch::Tensor frame_features(const torch::Tensor& input, int64_t a, int64_t T, double ts,
                             int64_t group) {
  torch::Tensor s = (input.narrow(0, a, T) * ts > 0.5).to(torch::kFloat);  // [T, B, 2, H, W]
  if (group > 1) {
    auto shape = s.sizes().vec();
    shape[0] = group;
    shape.insert(shape.begin(), T / group);
    s = s.reshape(shape).amax(1);
    T /= group;
  }
  auto when = (torch::arange(T, s.options()) + 0.5) / double(T);
  torch::Tensor count = s.sum(0);
  torch::Tensor mean_t = (s * when.view({T, 1, 1, 1, 1})).sum(0) / count.clamp_min(1);
  return torch::cat({torch::log1p(count), mean_t}, 1);
}

}  // namespace

torch::Tensor ann_feature_tensor(const torch::Tensor& input, int64_t w0, double ts, int64_t group,
                                 int64_t history) {
  torch::NoGradGuard ng;
  const int64_t T = input.size(0) - w0;
  if (group < 1 || T % group != 0)
    fail("ann features", "",
         "the window's " + std::to_string(T) + " steps cannot be merged in runs of " +
             std::to_string(group));
  if (history < 0 || history * T > w0)
    fail("ann features", "",
         std::to_string(history) + " past frames of " + std::to_string(T) + " steps need " +
             std::to_string(history * T) + " steps before the window, the sample has " +
             std::to_string(w0) + " (raise sample.warmup_ms)");
  std::vector<torch::Tensor> frames;
  for (int64_t h = 0; h <= history; ++h)
    frames.push_back(frame_features(input, w0 - h * T, T, ts, group));
  return torch::cat(frames, 1).contiguous();
}

}  // namespace spikems::train
