#include "train/synapse/conv.h"

namespace spikems::train {

torch::Tensor synapse_forward(const torch::Tensor& a, const torch::Tensor& weight,
                              const SynapseGeometry& g) {
  TORCH_CHECK(a.dim() == 5, "synapse: input must be [T, B, C, H, W]");
  const int64_t T = a.size(0), B = a.size(1);
  torch::Tensor frames = a.reshape({T * B, a.size(2), a.size(3), a.size(4)});
  torch::Tensor u;
  if (g.kind == LayerKind::Conv)
    u = torch::conv2d(frames, weight, {}, g.stride, g.padding);
  else
    u = torch::conv_transpose2d(frames, weight, {}, g.stride, g.padding, g.output_padding);
  return u.view({T, B, u.size(1), u.size(2), u.size(3)});
}

}  // namespace spikems::train
