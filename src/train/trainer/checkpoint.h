// Training checkpoints: everything a run needs to continue exactly where it stopped — the
// network's parameters, the optimizer's state (Adam moments), the step (which is also the data
// position: batches are drawn from (seed, step) alone) and the best validation IoU so far.
// One LibTorch archive, written to a temporary file and renamed into place, so a kill -9 at any
// moment leaves the previous checkpoint intact.
#pragma once

#include <torch/torch.h>

#include <string>
#include <vector>

namespace spikems::train {

struct CheckpointState {
  int64_t step = 0;          // steps completed
  double best_val_iou = -1;  // best validation IoU (%) so far, -1: none yet
  int64_t best_step = -1;
  double wall_seconds = 0;  // training time spent so far (summed over the start and every resume)
  // The averaged weights (optim.ema_decay), one per parameter in parameters() order, and the
  // number of updates they have had; empty without averaging (and in older checkpoints).
  std::vector<torch::Tensor> ema;
  int64_t ema_updates = 0;
};

void save_checkpoint(const std::string& path, torch::nn::Module& net, torch::optim::Optimizer& opt,
                     const CheckpointState& st);
// Throws Error naming the file when it cannot be read or does not fit the network.
CheckpointState load_checkpoint(const std::string& path, torch::nn::Module& net,
                                torch::optim::Optimizer& opt);

}  // namespace spikems::train
