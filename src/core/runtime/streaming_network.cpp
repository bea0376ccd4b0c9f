#include "core/runtime/streaming_network.h"

#include "core/util/error.h"

namespace spikems {

StreamingNetwork::StreamingNetwork(const ModelSpec& m, int height, int width)
    : h_(height), w_(width) {
  m.validate(m.name);
  if (m.layers.front().in_channels != 2)
    fail(m.name, "layer 0",
         "takes " + std::to_string(m.layers.front().in_channels) +
             " channels; the runtime feeds 2 (OFF, ON polarity)");
  int h = height, w = width;
  for (size_t k = 0; k < m.layers.size(); ++k) {
    const auto& l = m.layers[k];
    if (l.output_size(h) <= 0 || l.output_size(w) <= 0)
      fail(m.name, "layer " + std::to_string(k),
           "a " + std::to_string(width) + "x" + std::to_string(height) +
               " input is too small for this network");
    layers_.push_back(StreamingLayer::create(l, m.time_step_ms, h, w));
    h = layers_.back()->out_height();
    w = layers_.back()->out_width();
    if (size_t(h) * w * l.out_channels >= (size_t(1) << 32))
      fail(m.name, "layer " + std::to_string(k), "layer too large for 32-bit neuron indices");
  }
  out_.resize(layers_.size());
  in_spikes_.assign(layers_.size(), 0);
}

const std::vector<uint32_t>& StreamingNetwork::step(const std::vector<uint32_t>& input) {
  const std::vector<uint32_t>* in = &input;
  for (size_t k = 0; k < layers_.size(); ++k) {
    out_[k].clear();
    layers_[k]->fire(t_, out_[k]);
    in_spikes_[k] += in->size();
    layers_[k]->drive(t_, in->data(), in->size());
    in = &out_[k];
  }
  ++t_;
  return out_.back();
}

std::vector<LayerStats> StreamingNetwork::stats() const {
  std::vector<LayerStats> s(layers_.size());
  for (size_t k = 0; k < layers_.size(); ++k) {
    s[k].synops = layers_[k]->synops();
    s[k].in_spikes = in_spikes_[k];
    s[k].out_spikes = layers_[k]->spikes();
    s[k].neurons = layers_[k]->out_neurons();
  }
  return s;
}

uint64_t StreamingNetwork::total_synops() const {
  uint64_t n = 0;
  for (const auto& l : layers_) n += l->synops();
  return n;
}

}  // namespace spikems
