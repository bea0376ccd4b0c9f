// `spikems train`: teaches the SpikeMS network on labelled event data (docs/training.md).
//
// A run lives in one folder:
//   config.json        the resolved configuration (every key), read back by --resume
//   log.jsonl          one JSON line per `log_every` steps ("train") and per validation ("val")
//   curves.svg         learning curves (loss, validation IoU), redrawn at each validation
//   checkpoint.pt      latest checkpoint (checkpoint.h), every `checkpoint_every` steps
//   model.safetensors  the latest model, in the model format every command reads
//   best.safetensors   the model of the best validation IoU so far
//   val-step<N>.safetensors  the model at each validation, with run.keep_val_models
#pragma once

#include <string>

#include "train/trainer/distributed.h"
#include "train/trainer/train_config.h"

namespace spikems::train {

struct TrainRunOptions {
  std::string out_dir;
  bool resume = false;   // continue the run in out_dir from its checkpoint
  bool progress = true;  // progress bar on stderr
  std::string command;   // the command line, for the model's provenance
  // Wall-clock budget in seconds (0: none): the run stops after the step that ends past it,
  // with a checkpoint, as after Ctrl-C, so a job with a fixed allotment (a batch queue's slot,
  // a rented GPU's time limit) ends cleanly and resumes later.
  double time_limit_s = 0;
  // Data-parallel training (distributed.h): world size 1 is the single-process run. Every rank
  // runs run_training with the same configuration; rank 0 alone writes the run folder.
  DistOptions dist;
};

struct TrainResult {
  int64_t steps = 0;
  bool time_limit_reached = false;
  double best_val_iou = -1, wall_seconds = 0;
};

// Throws Error on bad data, a non-finite loss (naming the step; the last checkpoint stays) or
// an unwritable folder, and in a data-parallel run when a rank dies or hangs (naming it).
// Ctrl-C (on any rank) or the time limit stops after the current step with a checkpoint.
TrainResult run_training(const TrainConfig& cfg, const TrainRunOptions& opt);

// The run folder's saved configuration with `overrides` applied (for --resume).
TrainConfig load_run_config(const std::string& out_dir, const std::vector<std::string>& overrides);

}  // namespace spikems::train
