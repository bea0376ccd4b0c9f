#include "train/neuron/psp.h"

namespace spikems::train {

using torch::autograd::AutogradContext;
using torch::autograd::variable_list;

void save_kernel(AutogradContext* ctx, const std::string& p, const TemporalKernel& k) {
  ctx->saved_data[p + "form"] = int64_t(k.form);
  ctx->saved_data[p + "decay"] = k.decay;
  ctx->saved_data[p + "gain"] = k.gain;
  ctx->saved_data[p + "taps"] = std::vector<double>(k.taps.begin(), k.taps.end());
}

TemporalKernel load_kernel(AutogradContext* ctx, const std::string& p) {
  TemporalKernel k;
  k.form = TemporalKernel::Form(ctx->saved_data[p + "form"].toInt());
  k.decay = ctx->saved_data[p + "decay"].toDouble();
  k.gain = ctx->saved_data[p + "gain"].toDouble();
  for (double v : ctx->saved_data[p + "taps"].toDoubleVector()) k.taps.push_back(float(v));
  return k;
}

namespace {

class PspFunction : public torch::autograd::Function<PspFunction> {
 public:
  static torch::Tensor forward(AutogradContext* ctx, torch::Tensor x2d, const TemporalKernel& k,
                               double ts) {
    save_kernel(ctx, "k", k);
    ctx->saved_data["ts"] = ts;
    return apply_temporal_kernel_fused(x2d, k, ts, false);
  }
  static variable_list backward(AutogradContext* ctx, variable_list g) {
    TemporalKernel k = load_kernel(ctx, "k");
    double ts = ctx->saved_data["ts"].toDouble();
    return {apply_temporal_kernel_fused(g[0], k, ts, true), torch::Tensor(), torch::Tensor()};
  }
};

}  // namespace

torch::Tensor psp(const torch::Tensor& x, const TemporalKernel& eps, double ts) {
  TORCH_CHECK(x.dim() >= 1, "psp: input needs a leading time axis");
  if (!fused_temporal_kernel_for(x, eps)) return apply_temporal_kernel_ops(x, eps, ts, false);
  const int64_t T = x.size(0);
  torch::Tensor y = PspFunction::apply(x.reshape({T, -1}), eps, ts);
  return y.view(x.sizes());
}

}  // namespace spikems::train
