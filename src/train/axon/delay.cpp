#include "train/axon/delay.h"

namespace spikems::train {

torch::Tensor axonal_delay(const torch::Tensor& x, const torch::Tensor& delay) {
  TORCH_CHECK(x.dim() == 5, "delay: input must be [T, B, C, H, W]");
  TORCH_CHECK(delay.dim() == 1 && delay.size(0) == x.size(2), "delay: one value per channel");
  const int64_t T = x.size(0), C = x.size(2);
  torch::Tensor d = torch::clamp_min(delay.to(x.dtype()), 0.0);
  torch::Tensor k = torch::floor(d).detach();
  torch::Tensor f = (d - k).view({1, 1, C, 1, 1});
  const int64_t P = k.numel() ? k.max().item<int64_t>() + 1 : 1;
  // Zeros before t = 0: x[t - k] = xp[t - k + P].
  torch::Tensor xp =
      torch::cat({torch::zeros({P, x.size(1), C, x.size(3), x.size(4)}, x.options()), x}, 0);
  auto opts = x.options().dtype(torch::kLong);
  torch::Tensor t = torch::arange(T, opts).view({T, 1, 1, 1, 1});
  torch::Tensor i0 = (t - k.to(torch::kLong).view({1, 1, C, 1, 1}) + P).expand(x.sizes());
  torch::Tensor x0 = torch::gather(xp, 0, i0);
  torch::Tensor x1 = torch::gather(xp, 0, i0 - 1);
  return (1 - f) * x0 + f * x1;
}

}  // namespace spikems::train
