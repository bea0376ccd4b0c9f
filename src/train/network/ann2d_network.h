// The ANN-2D baseline in LibTorch (model_file.h: ann2d_architecture): the SpikeMS hourglass
// with ReLU units and biases on event frames (core/runtime/ann_features.h), giving the logit of
// "moving" per pixel. The core's Ann2dForward computes the same function without LibTorch.
#pragma once

#include <torch/torch.h>

#include <vector>

#include "core/model/model_file.h"

namespace spikems::train {

class Ann2dNetworkImpl : public torch::nn::Module {
 public:
  // Weights from `spec`, or PyTorch's default initialisation where a layer's are all zero.
  explicit Ann2dNetworkImpl(const ModelSpec& spec);

  // features [B, 4 (1 + ann_history), H, W] -> logits [B, 1, H, W], top-left aligned to the input.
  torch::Tensor forward(const torch::Tensor& features);
  // Every layer's output (after ReLU; the last: logits), each in its own geometry.
  std::vector<torch::Tensor> forward_all(const torch::Tensor& features);

  ModelSpec to_spec() const;  // the spec with the current parameters
  size_t size() const { return layers_.size(); }
  int history() const { return spec_.ann_history; }  // past frames in its input

 private:
  ModelSpec spec_;  // without weights
  std::vector<torch::nn::AnyModule> layers_;
  std::vector<torch::Tensor> weights_, biases_;
};
TORCH_MODULE(Ann2dNetwork);

// [B, 4 (1 + history), H, W]: ann_features for the window steps [w0, T) of input spikes [T, B, 2,
// H, W] (values 1/Ts): the same features as core's ann_features, computed on the batch. group > 1:
// the window's steps are first merged in runs of `group` (a spike in any of them is one spike),
// which is exactly the binning at group x Ts (one spike per pixel, polarity and step) of the same
// events: features for an ANN trained with coarser steps (loss.teacher). The window's step count
// must be a multiple of group. history > 0: the features of that many past frames follow, each as
// long as the window and just before it, newest first (ModelSpec::ann_history); w0 must cover them.
torch::Tensor ann_feature_tensor(const torch::Tensor& input, int64_t w0, double ts,
                                 int64_t group = 1, int64_t history = 0);

}  // namespace spikems::train
