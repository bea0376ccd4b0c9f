#include "train/model_io.h"

#include "core/util/error.h"

namespace spikems::train {

namespace {
std::vector<int64_t> weight_shape(const LayerSpec& l) {
  if (l.kind == LayerKind::Conv) return {l.out_channels, l.in_channels, l.kernel, l.kernel};
  return {l.in_channels, l.out_channels, l.kernel, l.kernel};
}
std::vector<float> to_vector(const torch::Tensor& t) {
  torch::Tensor c = t.detach().to(torch::kCPU, torch::kFloat).contiguous();
  return std::vector<float>(c.data_ptr<float>(), c.data_ptr<float>() + c.numel());
}
}  // namespace

torch::Tensor weight_tensor(const LayerSpec& l) {
  if (int64_t(l.weight.size()) != l.weight_count())
    throw Error("layer weight has " + std::to_string(l.weight.size()) + " values, expected " +
                std::to_string(l.weight_count()));
  return torch::from_blob(const_cast<float*>(l.weight.data()), weight_shape(l), torch::kFloat)
      .clone();
}

void store_weight(LayerSpec& l, const torch::Tensor& w) {
  if (w.sizes().vec() != weight_shape(l))
    throw Error("store_weight: tensor shape does not match the layer");
  l.weight = to_vector(w);
}

torch::Tensor delay_tensor(const LayerSpec& l) {
  if (l.delay.empty()) return torch::Tensor();
  return torch::from_blob(const_cast<float*>(l.delay.data()), {int64_t(l.delay.size())},
                          torch::kFloat)
      .clone();
}

void store_delay(LayerSpec& l, const torch::Tensor& d) {
  if (!d.defined()) {
    l.delay.clear();
    return;
  }
  if (d.numel() != l.out_channels) throw Error("store_delay: one value per output channel");
  l.delay = to_vector(d);
}

}  // namespace spikems::train
