// Weight initialisation for training from scratch. Spiking layers stay silent (and get no
// surrogate gradient) when their potential never nears the threshold, so the scale of each
// layer's weights is chosen on data: layer by layer, a normal initialisation is scaled until the
// layer fires at a target rate (spikes per neuron per step) on a batch of real samples
// (data-driven, as LSUV does for ANNs; SLAYER instead multiplies all weights by a fixed scale).
#pragma once

#include <torch/torch.h>

#include <vector>

#include "train/network/spikems_network.h"

namespace spikems::train {

// Returns each layer's reached rate. `input` [T, B, 2, H, W] (spikes 1/ts); `rates` one
// target per layer; ts the time step in ms.
std::vector<double> init_weights_from_data(SpikeMSNetwork& net, const torch::Tensor& input,
                                           const std::vector<double>& rates, double ts,
                                           uint64_t seed);

// Mean spikes per neuron per step of a spike tensor (values 1/Ts).
double firing_rate(const torch::Tensor& spikes, double ts);

}  // namespace spikems::train
