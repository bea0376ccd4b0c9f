// Conversions between the model file's LayerSpec (std::vector weights, core) and LibTorch
// tensors, so a network is built FROM a ModelSpec and exported TO one.
#pragma once

#include <torch/torch.h>

#include "core/model/model_file.h"

namespace spikems::train {

// The layer's weight as a float32 tensor in PyTorch layout (a copy).
torch::Tensor weight_tensor(const LayerSpec& l);
// Writes a tensor (any dtype/device, PyTorch layout, matching shape) back into l.weight.
void store_weight(LayerSpec& l, const torch::Tensor& w);
// Delay [C_out] (empty tensor when the layer has none) and back.
torch::Tensor delay_tensor(const LayerSpec& l);
void store_delay(LayerSpec& l, const torch::Tensor& d);

}  // namespace spikems::train
