// Synaptic operations (SynOps) of a spiking SpikeMS network, counted in the training graph as
// the streaming runtime counts them (StreamingLayer::synops): every (input spike, output neuron
// it reaches) pair, borders included. The runtime's work is mostly these additions, so a
// penalty on them (loss.synops_weight, docs/training.md "SynOps budget") trains for speed the
// way Sinabs' SynOps penalty does, where a firing-rate penalty would weigh a spike of a
// 16-channel full-resolution layer like one of a 64-channel transposed layer.
//
// Counted per input event (input spike): a network whose decoder fires as much on a sparse
// input as on a busy one pays most on the sparse one, which is where the shipped model wastes
// its work (docs/performance.md, "What the network's cost depends on").
#pragma once

#include <torch/torch.h>

#include <vector>

#include "core/model/model_file.h"

namespace spikems::train {

class SynopsCounter {
 public:
  explicit SynopsCounter(const ModelSpec& spec);

  // Per sample [B]: the weight additions caused by `input` (into layer 0) and by each layer's
  // spikes (into its successor and its skip consumers), over the steps given. input: [T, B, C,
  // H, W] (values 1/ts; it may be smaller than the padded size the network runs on: padding
  // holds no spikes); layers[k]: layer k's spikes [T, B, C_k, H_k, W_k] over the same steps
  // (SpikeMSNetwork::forward_all). Differentiable in the spikes (a weighted sum of them).
  // source_weights (empty: all 1) scales the operations of each source: entry 0 the input's,
  // entry k layer k's spikes' (layers numbered from 1, as `spikems segment --stats` does).
  torch::Tensor per_sample(const torch::Tensor& input, const std::vector<torch::Tensor>& layers,
                           double ts, const std::vector<double>& source_weights = {}) const;

  // How many entries source_weights has: the input and each layer.
  size_t sources() const { return consumers_.size(); }

  // How many (output position, tap) pairs input coordinate i in [0, in) reaches along one axis
  // of a layer with an output of `out` positions. Conv: out = (in + 2p - k) / s + 1 and in = o s
  // - p + tap; transposed: o = i s - p + tap.
  static std::vector<double> reach(int64_t in, int64_t out, int kernel, int stride, int padding,
                                   bool transposed);

 private:
  struct Consumer {
    size_t layer;  // the consuming layer
    int kernel, stride, padding, out_channels;
    bool transposed;
  };
  // consumers_[0]: the input's (layer 0); consumers_[k + 1]: layer k's spikes'.
  std::vector<std::vector<Consumer>> consumers_;
};

// The mean over samples of the SynOps penalty for `sope` [B] (SynOps per input event):
// w (sope / budget - 1)^2 where above the budget, or, with budget 0, w sope / 1000.
torch::Tensor synops_penalty(const torch::Tensor& sope, double weight, double budget);

}  // namespace spikems::train
