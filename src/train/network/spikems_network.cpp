#include "train/network/spikems_network.h"

namespace spikems::train {

SpikeMSNetworkImpl::SpikeMSNetworkImpl(const ModelSpec& spec, SpikeGradient gradient)
    : spec_(spec) {
  spec.validate(spec.name);
  for (size_t k = 0; k < spec.layers.size(); ++k)
    layers_.push_back(register_module("layer" + std::to_string(k + 1),
                                      SpikingLayer(spec.layers[k], spec.time_step_ms, gradient)));
  for (auto& l : spec_.layers) {
    l.weight.clear();
    l.delay.clear();
  }
}

torch::Tensor SpikeMSNetworkImpl::input_of(size_t k, const torch::Tensor& x,
                                           const std::vector<torch::Tensor>& out) const {
  if (k == 0) return pad_for_skips(spec_, x);
  const int skip = spec_.layers[k].skip_from;
  if (skip < 0) return out[k - 1];
  return torch::cat({out[k - 1], out[size_t(skip)]}, 2);  // [T, B, C, H, W]: channels
}

torch::Tensor SpikeMSNetworkImpl::forward(const torch::Tensor& x) {
  if (!spec_.has_skips()) {
    torch::Tensor s = x;
    for (auto& l : layers_) s = l->forward(s);
    return gated(x, s);
  }
  return forward_all(x).back();
}

torch::Tensor SpikeMSNetworkImpl::gated(const torch::Tensor& x, const torch::Tensor& out,
                                        int64_t from) const {
  if (spec_.output_gate_steps <= 0) return out;
  const int64_t d = out.dim();
  return out * output_gate_mask(x, spec_.output_gate_steps, out.size(d - 2), out.size(d - 1))
                   .narrow(0, from, out.size(0))
                   .to(out.dtype());
}

std::vector<torch::Tensor> SpikeMSNetworkImpl::forward_all(const torch::Tensor& x,
                                                           torch::Tensor* readout) {
  std::vector<torch::Tensor> out;
  for (size_t k = 0; k < layers_.size(); ++k)
    out.push_back(
        layers_[k]->forward(input_of(k, x, out), k + 1 == layers_.size() ? readout : nullptr));
  out.back() = gated(x, out.back());
  return out;
}

std::vector<torch::Tensor> SpikeMSNetworkImpl::forward_all_truncated(const torch::Tensor& x,
                                                                     int64_t w0,
                                                                     torch::Tensor* readout) {
  if (w0 <= 0) return forward_all(x, readout);
  const int64_t T = x.size(0);
  TORCH_CHECK(w0 < T, "forward_all_truncated: the warm-up must be shorter than the input");
  // Pass 1: the warm-up alone, forward only and without a graph.
  std::vector<torch::Tensor> warm_in, warm_out;
  {
    torch::NoGradGuard ng;
    const torch::Tensor xw = x.narrow(0, 0, w0);
    for (size_t k = 0; k < layers_.size(); ++k) {
      warm_in.push_back(input_of(k, xw, warm_out));
      warm_out.push_back(layers_[k]->forward(warm_in.back()));
    }
  }
  // Pass 2: the window with gradients, each layer continuing from its warm-up.
  std::vector<torch::Tensor> out;
  const torch::Tensor xs = x.narrow(0, w0, T - w0);
  for (size_t k = 0; k < layers_.size(); ++k)
    out.push_back(layers_[k]->forward_window(torch::cat({warm_in[k], input_of(k, xs, out)}, 0), w0,
                                             warm_out[k],
                                             k + 1 == layers_.size() ? readout : nullptr));
  out.back() = gated(x, out.back(), w0);
  return out;
}

ModelSpec SpikeMSNetworkImpl::to_spec() const {
  ModelSpec s = spec_;
  for (size_t k = 0; k < layers_.size(); ++k) s.layers[k] = layers_[k]->to_spec();
  return s;
}

void SpikeMSNetworkImpl::set_gradient(SpikeGradient g) {
  for (auto& l : layers_) l->set_gradient(g);
}

void SpikeMSNetworkImpl::set_kernels(KernelPath k) {
  for (auto& l : layers_) l->set_kernels(k);
}

std::vector<torch::Tensor> forward_all_layers(const ModelSpec& spec, const torch::Tensor& input) {
  TORCH_CHECK(input.dim() == 5, "forward_all_layers: input must be [T, B, C, H, W]");
  torch::NoGradGuard no_grad;
  SpikeMSNetwork net(spec);
  return net->forward_all(input);
}

torch::Tensor output_gate_mask(const torch::Tensor& x, int64_t steps, int64_t height,
                               int64_t width) {
  TORCH_CHECK(x.dim() == 5 && steps > 0, "output_gate_mask: input [T, B, C, H, W], steps > 0");
  // Events per step and pixel, summed over the last `steps` steps by a cumulative sum.
  const torch::Tensor e = x.ne(0).any(2, /*keepdim=*/true).to(torch::kFloat);
  torch::Tensor c = e.cumsum(0);
  const int64_t T = x.size(0);
  if (steps < T)
    c = torch::cat(
        {c.narrow(0, 0, steps), c.narrow(0, steps, T - steps) - c.narrow(0, 0, T - steps)}, 0);
  return align_to_input(c.gt(0.5).to(torch::kFloat), height, width);
}

torch::Tensor align_to_input(const torch::Tensor& y, int64_t height, int64_t width) {
  const int64_t d = y.dim();
  TORCH_CHECK(d >= 2, "align_to_input: needs at least 2 dims");
  torch::Tensor c = y.narrow(d - 2, 0, std::min(height, y.size(d - 2)))
                        .narrow(d - 1, 0, std::min(width, y.size(d - 1)));
  const int64_t ph = height - c.size(d - 2), pw = width - c.size(d - 1);
  if (ph == 0 && pw == 0) return c;
  return torch::constant_pad_nd(c, {0, pw, 0, ph}, 0);
}

torch::Tensor pad_for_skips(const ModelSpec& spec, const torch::Tensor& x) {
  if (!spec.has_skips()) return x;
  const int64_t d = x.dim();
  const auto [fh, fw] = spec.fitted_input_size(int(x.size(d - 2)), int(x.size(d - 1)));
  spec.check_input_size(fh, fw, spec.name);
  return align_to_input(x, fh, fw);  // fh, fw >= the input's: pads only
}

}  // namespace spikems::train
