#include "train/block/spiking_layer.h"

#include "train/axon/delay.h"
#include "train/model_io.h"
#include "train/neuron/psp.h"

namespace spikems::train {

SpikingLayerImpl::SpikingLayerImpl(const LayerSpec& spec, double ts, SpikeGradient gradient)
    : spec_(spec),
      ts_(ts),
      eps_(TemporalKernel::srm(spec, ts)),
      spike_(SpikeParams::from_layer(spec, ts, gradient)),
      geom_(SynapseGeometry::of(spec)) {
  weight = register_parameter("weight", weight_tensor(spec));
  if (!spec.delay.empty()) delay = register_parameter("delay", delay_tensor(spec));
  spec_.weight.clear();
  spec_.delay.clear();
}

void SpikingLayerImpl::enable_delay(bool on) {
  if (on && !delay.defined())
    delay = register_parameter("delay", torch::zeros({spec_.out_channels}, weight.options()));
}

torch::Tensor SpikingLayerImpl::potential(const torch::Tensor& x) {
  if (kernels_ != KernelPath::Dense && weight.device().is_cpu() && use_sparse_path(kernels_, x))
    return sparse_synapse_psp(x, weight, geom_, eps_, ts_);
  return synapse_forward(psp(x, eps_, ts_), weight, geom_);
}

torch::Tensor SpikingLayerImpl::forward(const torch::Tensor& x) {
  torch::Tensor s = spike(potential(x), spike_);
  if (delay.defined()) s = axonal_delay(s, delay);
  return s;
}

LayerSpec SpikingLayerImpl::to_spec() const {
  LayerSpec l = spec_;
  store_weight(l, weight);
  store_delay(l, delay);
  return l;
}

}  // namespace spikems::train
