// The SpikeMS network (or any stack of spiking layers, with skip connections) built from a
// ModelSpec.
//
// Layout: time-major spikes [T, B, C, H, W] (float; spikes are 1/Ts). Each layer is a
// SpikingLayer (block/spiking_layer.h). The output grid is aligned to the input grid by its
// TOP-LEFT corner: output pixel (y, x) covers input pixel (y, x) (as the authors' test code
// crops to [:H_out, :W_out]); `align_to_input` crops an output that is larger than the input
// (padded geometry on sizes not a multiple of 8) and zero-pads one that is smaller (the
// authors' unpadded geometry, 63x79 for 64x80) at the bottom and right.
#pragma once

#include <torch/torch.h>

#include <vector>

#include "core/model/model_file.h"
#include "train/block/spiking_layer.h"

namespace spikems::train {

class SpikeMSNetworkImpl : public torch::nn::Module {
 public:
  explicit SpikeMSNetworkImpl(const ModelSpec& spec,
                              SpikeGradient gradient = SpikeGradient::Slayer);

  torch::Tensor forward(const torch::Tensor& x);  // last layer's spikes (output-gated)
  // Every layer's spikes; `readout`, when given, receives the last layer's synaptic potential
  // (the potential readout, docs/training.md), at no extra cost.
  std::vector<torch::Tensor> forward_all(const torch::Tensor& x, torch::Tensor* readout = nullptr);
  // Truncated warm-up (the trainer's optim.warmup_backprop = false): the first w0 steps run
  // without gradients, then every layer's spikes over [w0, T) are computed with gradients from
  // that state (SpikingLayerImpl::forward_window). Returns the T - w0 window steps of each
  // layer (and of `readout`); their values equal forward_all(x)'s. w0 = 0 is forward_all.
  std::vector<torch::Tensor> forward_all_truncated(const torch::Tensor& x, int64_t w0,
                                                   torch::Tensor* readout = nullptr);

  // Layer k's input: the network input, its predecessor's spikes, or those and its skip
  // source's concatenated on the channels (out: the spikes of layers 0 .. k-1).
  torch::Tensor input_of(size_t k, const torch::Tensor& x,
                         const std::vector<torch::Tensor>& out) const;
  // The spec with the current parameter values (for save_model).
  ModelSpec to_spec() const;
  void set_gradient(SpikeGradient g);
  void set_kernels(KernelPath k);  // every layer (SpikingLayerImpl::set_kernels)
  size_t size() const { return layers_.size(); }
  SpikingLayer& layer(size_t k) { return layers_[k]; }

 private:
  ModelSpec spec_;  // without weights
  std::vector<SpikingLayer> layers_;
  // The output spikes `out` (steps from .. from + T_out of the input x) through the model's
  // output gate (ModelSpec::output_gate_steps); `out` itself without one. The readout is not
  // gated: the loss sees the potential, the gate only which spikes count.
  torch::Tensor gated(const torch::Tensor& x, const torch::Tensor& out, int64_t from = 0) const;
};
TORCH_MODULE(SpikeMSNetwork);

// One call for C++ users (the streaming runtime compares against it): runs every layer of
// `spec` on input [T, B, C, H, W] (float32 CPU), without gradients, and returns the spikes of
// each layer, [T, B, C_k, H_k, W_k], in the model's own geometry (no alignment).
std::vector<torch::Tensor> forward_all_layers(const ModelSpec& spec, const torch::Tensor& input);

// The output gate's mask for input x [T, B, C, H, W]: [T, B, 1, height, width], 1 at
// step t where the pixel had an input event in steps t-steps+1 .. t (top-left aligned; 0
// beyond the input). As the runtime's and dense_output_gate's.
torch::Tensor output_gate_mask(const torch::Tensor& x, int64_t steps, int64_t height,
                               int64_t width);

// Crops or zero-pads the last two dims of y to (height, width), top-left aligned.
torch::Tensor align_to_input(const torch::Tensor& y, int64_t height, int64_t width);

// x (last two dims H, W) zero-padded at the bottom and right to the size where `spec`'s skips
// meet (ModelSpec::fitted_input_size); x itself for a model without skips. Throws Error when no
// size fits. Both the spiking network and the ANN-2D start with it.
torch::Tensor pad_for_skips(const ModelSpec& spec, const torch::Tensor& x);

}  // namespace spikems::train
