#include "train/neuron/neuron_cuda_torch.h"

#include "core/util/error.h"
#include "train/neuron/neuron_cuda.h"

#ifdef SPIKEMS_WITH_CUDA
#include <ATen/cuda/CUDAContext.h>
#include <c10/cuda/CUDAGuard.h>
#include <c10/cuda/CUDAStream.h>
#endif

namespace spikems::train {

namespace {

#ifdef SPIKEMS_WITH_CUDA
cuda::KernelDesc describe(const TemporalKernel& k) {
  cuda::KernelDesc d;
  d.form = int(k.form);
  d.taps = int(k.taps.size());
  for (int i = 0; i < d.taps && i < cuda::kMaxTaps; ++i) d.tap[i] = k.taps[size_t(i)];
  d.decay = k.decay;
  d.gain = k.gain;
  return d;
}

cuda::SpikeDesc describe(const SpikeParams& p) {
  cuda::SpikeDesc d;
  d.theta = p.theta;
  d.ts = p.ts;
  d.refractory = describe(p.refractory);
  d.pdf_scale = p.pdf_scale();
  d.pdf_tau = p.pdf_tau();
  return d;
}

void check(const torch::Tensor& t, const char* what) {
  if (!t.is_cuda() || !t.is_contiguous() || t.dim() != 2 ||
      (t.scalar_type() != torch::kFloat && t.scalar_type() != torch::kDouble))
    throw Error(std::string(what) + ": needs a contiguous float/double CUDA tensor [T, N]");
}

void* stream_of(const torch::Tensor& t) {
  return c10::cuda::getCurrentCUDAStream(t.device().index()).stream();
}
#else
[[noreturn]] void no_cuda() {
  throw Error("this spikems was built without its CUDA kernels (CMake option SPIKEMS_CUDA)");
}
#endif

}  // namespace

std::string cuda_device_name() {
#ifdef SPIKEMS_WITH_CUDA
  if (torch::cuda::is_available()) return at::cuda::getCurrentDeviceProperties()->name;
#endif
  return "";
}

bool cuda_kernel_fits(const TemporalKernel& k) {
  return k.form != TemporalKernel::Form::FIR || int(k.taps.size()) <= cuda::kMaxTaps;
}

#ifdef SPIKEMS_WITH_CUDA

torch::Tensor cuda_temporal_filter(const torch::Tensor& x, const TemporalKernel& k, double scale,
                                   bool reverse) {
  check(x, "cuda_temporal_filter");
  const c10::cuda::CUDAGuard guard(x.device());
  torch::Tensor y = torch::empty_like(x);
  cuda::temporal_filter(x.data_ptr(), y.data_ptr(), x.scalar_type() == torch::kDouble, x.size(0),
                        x.size(1), describe(k), scale, reverse, stream_of(x));
  return y;
}

std::pair<torch::Tensor, torch::Tensor> cuda_spike_forward(const torch::Tensor& u,
                                                           const SpikeParams& p) {
  check(u, "cuda_spike_forward");
  const c10::cuda::CUDAGuard guard(u.device());
  torch::Tensor ur = u.clone(), s = torch::empty_like(u);
  cuda::spike_forward(ur.data_ptr(), s.data_ptr(), u.scalar_type() == torch::kDouble, u.size(0),
                      u.size(1), describe(p), stream_of(u));
  return {s, ur};
}

torch::Tensor cuda_spike_backward(const torch::Tensor& gs, const torch::Tensor& ur,
                                  const SpikeParams& p) {
  check(gs, "cuda_spike_backward");
  check(ur, "cuda_spike_backward");
  const c10::cuda::CUDAGuard guard(gs.device());
  torch::Tensor gu = torch::empty_like(gs);
  cuda::spike_backward(gs.data_ptr(), ur.data_ptr(), gu.data_ptr(),
                       gs.scalar_type() == torch::kDouble, gs.size(0), gs.size(1), describe(p),
                       p.gradient == SpikeGradient::Exact, stream_of(gs));
  return gu;
}

#else

torch::Tensor cuda_temporal_filter(const torch::Tensor&, const TemporalKernel&, double, bool) {
  no_cuda();
}
std::pair<torch::Tensor, torch::Tensor> cuda_spike_forward(const torch::Tensor&,
                                                           const SpikeParams&) {
  no_cuda();
}
torch::Tensor cuda_spike_backward(const torch::Tensor&, const torch::Tensor&, const SpikeParams&) {
  no_cuda();
}

#endif

}  // namespace spikems::train
