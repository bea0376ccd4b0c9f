// Synapse: a spatial convolution (or transposed convolution) applied independently at every
// time step, with no bias. The T*B frames of a time-major tensor [T, B, C, H, W] go through one
// conv2d / conv_transpose2d call. Weight layouts as PyTorch: conv [C_out, C_in, k, k],
// transposed conv [C_in, C_out, k, k].
#pragma once

#include <torch/torch.h>

#include "core/model/model_file.h"

namespace spikems::train {

struct SynapseGeometry {
  LayerKind kind = LayerKind::Conv;
  int stride = 2, padding = 0, output_padding = 0;
  static SynapseGeometry of(const LayerSpec& l) {
    return {l.kind, l.stride, l.padding, l.output_padding};
  }
};

// a: [T, B, C_in, H, W] -> [T, B, C_out, H', W'].
torch::Tensor synapse_forward(const torch::Tensor& a, const torch::Tensor& weight,
                              const SynapseGeometry& g);

}  // namespace spikems::train
