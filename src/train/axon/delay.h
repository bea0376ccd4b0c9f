// Axonal delay (SLAYER's delay layer): every output channel c is shifted later in time by a
// real-valued, learnable delay d_c >= 0 (in time steps), with linear interpolation:
//   y[t] = (1 - f) x[t - k] + f x[t - k - 1],  k = floor(d_c), f = d_c - k,  x[<0] = 0.
// The gradient with respect to d_c is the derivative of that interpolation,
//   dy[t]/dd_c = x[t - k - 1] - x[t - k],
// and the gradient with respect to x is the same shift run backwards. Plain tensor operations,
// so it runs on any device and LibTorch's autograd differentiates it.
#pragma once

#include <torch/torch.h>

namespace spikems::train {

// x: [T, B, C, H, W]; delay: [C] (negative values are clamped to 0).
torch::Tensor axonal_delay(const torch::Tensor& x, const torch::Tensor& delay);

}  // namespace spikems::train
