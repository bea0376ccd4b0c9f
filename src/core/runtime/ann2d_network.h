// The ANN-2D baseline's forward pass on the CPU without LibTorch (for `spikems eval` and the
// runtime): dense 3x3 convolutions and transposed convolutions with biases and ReLU, as
// model_file.h's ann2d_architecture describes, on the event frame of ann_features.h. The
// trainer's LibTorch module (train/network/ann2d_network.h) computes the same function; a test
// checks the two against each other.
#pragma once

#include <cstdint>
#include <vector>

#include "core/model/model_file.h"

namespace spikems {

class Ann2dForward {
 public:
  // Throws Error unless `model` is a valid ANN-2D model.
  explicit Ann2dForward(ModelSpec model);

  // features [ann_input_channels(), H, W] (ann_features of the window's frame, then of each
  // past frame, newest first: ModelSpec::ann_history) -> logits [H, W] of "moving", the output
  // aligned to the input by its top-left corner (cropped where larger, zero logits where
  // smaller), as the SNN's output.
  std::vector<float> forward(const std::vector<float>& features, int H, int W) const;

  const ModelSpec& model() const { return model_; }

 private:
  ModelSpec model_;
};

}  // namespace spikems
