// The training configuration: one TOML file (configs/train/*.toml), every key documented in
// docs/training.md, overridable from the command line with `--set section.key=value`.
// Unknown keys, wrong types and out-of-range values are errors naming the key.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/dataset/sample.h"
#include "core/dataset/sequence.h"

namespace spikems::train {

struct TrainConfig {
  // [model]
  std::string type = "snn";           // snn | ann2d (the ANN-2D baseline: padded, no neurons)
  bool padded = true;                 // padding 1: a multiple-of-8 input keeps its size
  std::string neurons = "iir";        // iir | fir
  std::string surrogate = "spikems";  // spikems | slayer
  std::string backward = "slayer";    // slayer | exact
  bool delays = false;                // learnable axonal delays
  std::string init = "data";          // data | <path of a model file to start from>
  // Encoder channels per stride-2 level, the decoder mirrored (the paper: 16, 32, 64); only for
  // init = "data" (a model file brings its own geometry).
  std::vector<int> channels = {16, 32, 64};
  // Synaptic time constant (ms) per level, encoder and decoder layer alike (empty: the
  // paper's 2, 2, 4, levels past the third 4). Each layer answers ~tau_s late.
  std::vector<double> tau_s;
  // Refractory time constant (ms) per level or per layer, as tau_s (empty: the paper's 1, 1, 3,
  // levels past the third 3). A network made for 10 ms steps takes 5x the values of 2 ms steps.
  std::vector<double> tau_r;
  // U-Net skip connections (encoder level i into the decoder layer at its resolution): the
  // gradient's short path through a deep stack (docs/training.md, "Skip connections").
  bool skips = false;
  // "spikes" (the paper: the loss scores the output layer's spike counts) or "potential": the
  // output layer loses its refractory (scale_ref = 0, saved in the model file) and the loss
  // scores its synaptic potential, graded and without a surrogate (docs/training.md).
  std::string readout = "spikes";
  // The output gate, ms (docs/model-format.md, "Output gate"): the model keeps an output spike
  // only where its pixel had an input event that recently, and validation scores that output.
  // 0: none (a model.init file keeps its own gate).
  double output_gate_ms = 0;
  // With skips: only these encoder levels (1-based, 1 = the finest) feed the decoder; empty =
  // every level. Leaving the finest out removes the output's two-layer path from the input.
  std::vector<int> skip_levels;
  // ANN-2D only: past frames shown beside the window's, each as long as the window and just
  // before it (ModelSpec::ann_history); sample.warmup_ms must cover them. 0: the window alone.
  int history = 0;
  // The surrogate's width in units of theta for every layer (0: keep the model's, the
  // authors' 0.3). Training only: the forward pass does not depend on it.
  double tau_rho = 0;
  // Data-init firing targets, one per layer (2 x levels); 0.03 each and 0.02 for the output
  // when not given.
  std::vector<double> init_rates = {0.03, 0.03, 0.03, 0.03, 0.03, 0.02};
  // With init = "data": an ANN-2D model file of the same geometry whose weights give each
  // layer's starting pattern (weight_init.h, ann_weight_directions) instead of random draws;
  // the scales are still set on data. Empty: random.
  std::string init_ann;
  // With init = a file trained at another time step than sample.step_ms: "steps" scales its
  // time constants so each step behaves as before, "ms" keeps them in milliseconds
  // (core/model/time_step.h). Empty: such a file is refused.
  std::string init_time_constants;
  // "next_step" (SLAYER's kernel: one step of latency per layer) or "same_step" (the kernel
  // sampled at the end of the spike's step, core/model/model_file.h SrmOnset), set on every
  // layer; empty: the model file's own (init = "data": next_step).
  std::string srm_onset;
  // [data]
  std::vector<DatasetSource> train, val;
  // Static scenes (every event background, e.g. the simulator's `poster` preset with flat
  // patches): at each validation the share of their events the model calls moving is logged
  // (`static_moving`), a false-positive rate on data other than the real recordings it will be
  // judged on. Needs `val`; default split "all".
  std::vector<DatasetSource> val_static;
  // [sample]
  SampleOptions sample;
  // [loss]
  std::string loss = "both";  // bce | spike | both | iou
  double lambda = 0.1;        // weight of L_spike
  double iou_weight = 0;      // weight of the soft-IoU term (kind "iou": it alone)
  // Distillation (spikems_loss.h, distill_loss): an ANN-2D model file whose per-pixel
  // probabilities the SNN's output is pulled to, with this weight (0: off).
  std::string teacher;
  double teacher_weight = 0;
  // Samples whose window has no moving event (static scenes, crops of background): "teacher"
  // distils them like the others; "skip" leaves them to the task's terms (their labels: all
  // background); "labels" distils them towards their labels (q = 0), with teacher_weight.
  // A teacher that calls static look-alikes moving otherwise pulls the student to its mistake
  // on exactly the samples that show it is one.
  std::string teacher_static = "teacher";
  // Attention transfer from the same teacher (spikems_loss.h, attention_transfer_loss): each
  // hidden layer's spatial activity matched to the teacher's layer of the same index (0: off).
  double attention_weight = 0;
  // Feature transfer (spikems_loss.h, feature_transfer_loss): each hidden layer's activity
  // matched channel by channel to the teacher's (0: off).
  double feature_weight = 0;
  // Off-event false positives (spikems_loss.h, offevent_loss): output at pixels without input
  // events weighed as L_bce weighs a moving pixel (0: off).
  double offevent_weight = 0;
  // Whether any term needs `teacher` (distillation, attention or feature transfer).
  bool uses_teacher() const {
    return teacher_weight > 0 || attention_weight > 0 || feature_weight > 0;
  }
  std::string projection = "sigmoid";  // sigmoid | exponential
  double alpha = 4.0, beta = 0.5, kappa = 1.0;
  bool all_pixels = true;
  double pos_weight = 1.0;
  bool balanced = true;
  double activity_weight = 0.5;  // times the summed per-layer firing rates
  // Hidden layers (all but the output) firing less than rate_floor spikes per neuron per step
  // pay floor_weight * ((rate_floor - rate) / rate_floor)^2: a layer that falls silent passes
  // no surrogate gradient and never recovers (Zenke & Vogels 2021 use such lower bounds).
  double rate_floor = 0.005, floor_weight = 1.0;
  // The same lower bound for the output layer (0: none): a loss that punishes false positives
  // hard (soft IoU on crops without moving objects) can silence it for good.
  double output_floor = 0;
  // An upper bound for the hidden layers (0: none), paid as floor_weight * (r / ceiling - 1)^2
  // above it: fine-tuning a densely firing model drove layers 3-5 from 3-9 % to 15-34 % firing
  // (inhibiting the output) within 50 steps (measured, docs/training.md).
  double rate_ceiling = 0;
  // One ceiling per hidden layer (empty: rate_ceiling for each; 0: none for that layer). The
  // runtime's cost is the spikes times their fan-out, dominated by the full-resolution levels:
  // the coarse levels have 4^(level-1) fewer neurons and can fire far more for little cost.
  std::vector<double> rate_ceilings;
  // One floor per hidden layer, the same way (empty: rate_floor for each; 0: none). With
  // rate_ceilings it holds a coarse level's rate in a band: the task's gradient alone drove
  // levels 3-6 from the 5-15 % they were initialised at to ~1 % (measured, docs/results.md).
  std::vector<double> rate_floors;
  // SynOps budget (synops_loss.h): the synaptic operations per input event the network's spikes
  // cause in the window, per sample, paid as synops_weight * (sope / synops_budget - 1)^2 above
  // the budget, or synops_weight * sope / 1000 with budget 0. Per input event, so that a
  // decoder firing as much on sparse input as on busy input pays most on the sparse samples.
  double synops_weight = 0, synops_budget = 0;
  // What the budget counts of each source's operations (empty: all of them): entry 0 the
  // input's, entry k layer k's spikes' (numbered as `spikems segment --stats`), so a budget can
  // spare the layers that carry the camera-motion suppression (docs/training.md). The logged
  // synops_per_event stays the full count.
  std::vector<double> synops_source_weights;
  // [optim]
  double lr = 1e-3, min_lr = 1e-5, weight_decay = 0;
  bool amsgrad = true;
  std::string schedule = "cosine";  // cosine | step | constant (after a linear warm-up)
  int warmup_steps = 50, step_every = 500;
  double step_gamma = 0.5;
  int batch = 8, steps = 2000;
  double clip = 1.0;  // global gradient-norm clip (0: off)
  // Weight averaging (Polyak / EMA, as timm's ModelEmaV2 or PyTorch's AveragedModel): a copy of
  // the weights updated after every step, w_ema = d w_ema + (1 - d) w with
  // d = min(ema_decay, (1 + n) / (10 + n)) after n updates; validation, the checkpointed and
  // saved models are the average. 0: off. Why: successive snapshots of one run swung by 15-30
  // points in the share of a static scene they call moving (docs/results.md).
  double ema_decay = 0;
  // false: the warm-up runs without gradients and backpropagation through time starts at the
  // window (truncated BPTT; SpikeMSNetworkImpl::forward_all_truncated): same forward values,
  // ~2x cheaper steps and a fifth of the memory at 40 ms warm-up + 10 ms window.
  bool warmup_backprop = true;
  // [run]
  uint64_t seed = 1;
  int threads = 0;             // 0: all cores
  std::string device = "cpu";  // cpu | cuda
  // Neuron dynamics: fused kernels (CPU; CUDA where built) or per-step tensor ops (reference).
  std::string neuron_kernels = "fused";  // fused | ops
  std::string kernels =
      "auto";  // auto | sparse | dense: synapse path (train/synapse/sparse_conv.h)
  int log_every = 10, val_every = 100, checkpoint_every = 25, val_samples = 64, prefetch = 4;
  // Threads making samples (0: 1 on the CPU, whose cores train; most cores for a GPU).
  int loader_threads = 0;
  // Whole-sensor validation as `spikems eval` scores it (streaming runtime, continuous state,
  // causal windows) on the first val_full_s seconds of every val sequence; 0: off. When on, the
  // best model is chosen by its IoU at val_full_window_ms: crop scores flatter (docs/results.md).
  double val_full_s = 0, val_full_window_ms = 20;
  // Validation scores P ∩ E (predictions only at pixels with input events; `eval --gate-events`).
  bool gate_events = false;
  // Keep the model of every validation as val-step<N>.safetensors, so that a run can be judged
  // afterwards on data the trainer does not see (a held-out set, a real recording).
  bool keep_val_models = false;

  nlohmann::json source;  // the resolved configuration (every key), as JSON
};

// Reads a TOML file (or a run's config.json, to start a new run like an old one), applies
// `overrides` ("section.key=value", value in TOML syntax; a bare word is taken as a string) and
// validates. Throws Error naming the file and the key.
TrainConfig load_train_config(const std::string& path, const std::vector<std::string>& overrides);
// The same from JSON (a run's saved config.json, for --resume).
TrainConfig train_config_from_json(nlohmann::json j, const std::string& source,
                                   const std::vector<std::string>& overrides);

}  // namespace spikems::train
