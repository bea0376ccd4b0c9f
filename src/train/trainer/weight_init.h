// Weight initialisation for training from scratch. Spiking layers stay silent (and get no
// surrogate gradient) when their potential never nears the threshold, so the scale of each
// layer's weights is chosen on data: layer by layer, a normal initialisation is scaled until the
// layer fires at a target rate (spikes per neuron per step) on a batch of real samples
// (data-driven, as LSUV does for ANNs; SLAYER instead multiplies all weights by a fixed scale).
#pragma once

#include <torch/torch.h>

#include <vector>

#include <string>

#include "core/model/model_file.h"
#include "train/network/spikems_network.h"

namespace spikems::train {

// Returns each layer's reached rate. `input` [T, B, 2, H, W] (spikes 1/ts); `rates` one
// target per layer; ts the time step in ms.
// `directions` (optional, one per layer, the weights' shapes): the patterns to scale instead of
// the random draws (ann_weight_directions).
std::vector<double> init_weights_from_data(SpikeMSNetwork& net, const torch::Tensor& input,
                                           const std::vector<double>& rates, double ts,
                                           uint64_t seed,
                                           const std::vector<torch::Tensor>& directions = {});

// ANN-to-SNN weight transfer (beyond the paper; the starting point of hybrid conversion +
// surrogate-gradient training, Rathi et al., ICLR 2020): each layer's weights taken from an
// ANN-2D model of the same hourglass (model_file.h, ann2d_architecture), to be scaled on data by
// init_weights_from_data. Mapping, per layer of `snn`:
//   - the first layer: the ANN reads 4 features per pixel (ann_features.h), the SNN 2 polarities;
//     one spike of polarity c in a one-step frame gives the features ln 2 (count) and 1/2 (mean
//     time) in channels c and c + 2, so the SNN's weight is ln 2 W[:, c] + 1/2 W[:, c + 2]
//     (an ANN with past frames: those of the window's own frame; the SNN's state holds the past);
//   - a decoder layer with a skip input: all the ANN's weights when the ANN has the same skip;
//     from an ANN without it, its weights for the predecessor's channels and zero for the
//     skip's (the network starts as the ANN, without skips, and learns to use them);
//   - the output layer: the ANN's one logit channel in each of the SNN's output channels;
//   - the biases are dropped (the spiking layer's threshold plays their part, one per layer).
// Throws Error naming `source` and the layer when the geometries differ.
std::vector<torch::Tensor> ann_weight_directions(const ModelSpec& ann, const ModelSpec& snn,
                                                 const std::string& source);

// Mean spikes per neuron per step of a spike tensor (values 1/Ts).
double firing_rate(const torch::Tensor& spikes, double ts);

}  // namespace spikems::train
