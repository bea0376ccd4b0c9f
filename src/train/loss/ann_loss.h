// The ANN-2D baseline's loss, on the pixels that had input events in the window (where the
// evaluation looks: P is taken among them): binary cross-entropy of the logits against
// "moving" (a foreground event fell there), class-balanced like L_bce's `balanced` option
// (mean over foreground pixels + mean over background pixels, each 1/2) or a plain mean, plus
// `iou_weight` times the soft IoU of sigmoid(logit) over the samples with moving objects
// (spikems_loss.h explains why those only).
#pragma once

#include <torch/torch.h>

namespace spikems::train {

struct AnnLoss {
  torch::Tensor bce, iou;
};

// logits [B, 1, H, W]; had, fg: [B, H, W] (1 = the pixel had input events / foreground events).
AnnLoss ann_loss(const torch::Tensor& logits, const torch::Tensor& had, const torch::Tensor& fg,
                 bool balanced, double iou_weight);

}  // namespace spikems::train
