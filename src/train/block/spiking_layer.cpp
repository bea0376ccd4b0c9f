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
  if (kernels_ != KernelPath::Dense && weight.device().is_cpu() &&
      use_sparse_path(kernels_, x, geom_, spec_.out_channels))
    return sparse_synapse_psp(x, weight, geom_, eps_, ts_);
  return synapse_forward(psp(x, eps_, ts_), weight, geom_);
}

torch::Tensor SpikingLayerImpl::forward(const torch::Tensor& x, torch::Tensor* u) {
  const torch::Tensor v = potential(x);
  if (u) *u = v;
  torch::Tensor s = spike(v, spike_);
  if (delay.defined()) s = axonal_delay(s, delay);
  return s;
}

torch::Tensor SpikingLayerImpl::forward_window(const torch::Tensor& x, int64_t w0,
                                               const torch::Tensor& warm_out,
                                               torch::Tensor* u_out) {
  TORCH_CHECK(!delay.defined(), "a truncated warm-up needs layers without axonal delays");
  const int64_t T = x.size(0), tw = T - w0;
  TORCH_CHECK(w0 > 0 && tw > 0 && warm_out.size(0) == w0,
              "forward_window: needs 0 < w0 < T and w0 steps of warm-up spikes");
  // psp is a causal filter over time: the window's values need the warm-up's input, which is
  // a constant here; the synapse then runs on the window's frames alone.
  const torch::Tensor p = psp(x, eps_, ts_).narrow(0, w0, tw);
  const torch::Tensor u = synapse_forward(p, weight, geom_);
  // The refractory responses of the warm-up's spikes reach into the window: add them as a
  // constant (the spike function adds the window's own spikes' responses as it goes).
  torch::Tensor offset;
  {
    torch::NoGradGuard ng;
    const auto& k = spike_.refractory;
    torch::Tensor sp = torch::cat({warm_out.detach(), torch::zeros_like(u)}, 0);
    sp = sp.reshape({T, -1}).contiguous();
    const torch::Tensor r = fused_kernel_exists(sp, k)
                                ? apply_temporal_kernel_fused(sp, k, ts_, false)
                                : apply_temporal_kernel_ops(sp, k, ts_, false);
    offset = r.narrow(0, w0, tw).reshape(u.sizes());
  }
  if (u_out) *u_out = u + offset;
  return spike(u + offset, spike_);
}

LayerSpec SpikingLayerImpl::to_spec() const {
  LayerSpec l = spec_;
  store_weight(l, weight);
  store_delay(l, delay);
  return l;
}

}  // namespace spikems::train
