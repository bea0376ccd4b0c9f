#include "train/loss/ann_loss.h"

namespace spikems::train {

AnnLoss ann_loss(const torch::Tensor& logits, const torch::Tensor& had, const torch::Tensor& fg,
                 bool balanced, double iou_weight) {
  const torch::Tensor z = logits.squeeze(1);
  const torch::Tensor y = fg * had;
  const torch::Tensor l = torch::binary_cross_entropy_with_logits(
      z, y, /*weight=*/{}, /*pos_weight=*/{}, at::Reduction::None);
  AnnLoss r;
  if (balanced) {
    const torch::Tensor bg = had * (1 - y);
    r.bce = 0.5 * ((l * y).sum() / y.sum().clamp_min(1) + (l * bg).sum() / bg.sum().clamp_min(1));
  } else {
    r.bce = (l * had).sum() / had.sum().clamp_min(1);
  }
  r.iou = torch::zeros({}, z.options());
  if (iou_weight > 0) {
    const torch::Tensor p = torch::sigmoid(z) * had;
    const torch::Tensor inter = (p * y).sum({1, 2}), uni = (p + y - p * y).sum({1, 2});
    const torch::Tensor with_fg = (y.sum({1, 2}) > 0).to(z.scalar_type());
    const torch::Tensor per = 1 - (inter + 1) / (uni + 1);
    r.iou = (per * with_fg).sum() / with_fg.sum().clamp_min(1);
  }
  return r;
}

}  // namespace spikems::train
