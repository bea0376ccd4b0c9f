// A Batch of core samples as the tensors the network and the loss take, and the per-window
// scores (IoU, detection) of a network output computed with the project's metrics code.
#pragma once

#include <torch/torch.h>

#include "core/dataset/batch_loader.h"
#include "core/eval/metrics.h"

namespace spikems::train {

struct BatchTensors {
  torch::Tensor input;  // [T, B, 2, H, W] spikes (value 1/Ts)
  torch::Tensor fg;     // [T, B, H, W] 1 where a moving-object event fell in the step
  int warmup_steps = 0;
};

// Samples must share T and the warm-up (Error otherwise). Samples of different sizes (whole
// sensors of a dataset with several cameras) are placed at the top-left of the largest height
// and width of the batch, the rest left empty: no input and no foreground there, so the losses
// (which look at pixels with input events, or take silence there as correct) and the window
// counts are those of each sample alone, and the network sees a sensor edge as it sees one
// with zero padding.
BatchTensors to_tensors(const std::vector<Sample>& samples, double ts, torch::Device device);

// Per sample, the mask counts of its window: P = pixels with any output spike in the window's
// steps (out_window [Tw, B, C, H, W]), G = pixels with a foreground event in them (fg_window
// [Tw, B, H, W]). Feed them to WindowScores::add.
// With `gate_events`, P counts only pixels with input spikes in the window (in_window
// [Tw, B, 2, H, W]; WindowScorer::gate_by_events).
std::vector<MaskCounts> window_counts(const torch::Tensor& out_window,
                                      const torch::Tensor& fg_window,
                                      const torch::Tensor& in_window = {});

}  // namespace spikems::train
