#include "train/trainer/batch_tensors.h"

#include "core/util/error.h"

namespace spikems::train {

BatchTensors to_tensors(const std::vector<Sample>& samples, double ts, torch::Device device) {
  if (samples.empty()) fail("batch", "", "no samples");
  const Sample& f = samples.front();
  const int64_t B = int64_t(samples.size());
  auto in = torch::empty({B, f.T, 2, f.H, f.W}, torch::kUInt8);
  auto fg = torch::empty({B, f.T, f.H, f.W}, torch::kUInt8);
  for (int64_t b = 0; b < B; ++b) {
    const Sample& s = samples[size_t(b)];
    if (s.T != f.T || s.H != f.H || s.W != f.W || s.warmup_steps != f.warmup_steps)
      fail("batch", "sample " + std::to_string(b), "samples of one batch differ in size");
    std::memcpy(in[b].data_ptr<uint8_t>(), s.input.data(), s.input.size());
    std::memcpy(fg[b].data_ptr<uint8_t>(), s.fg.data(), s.fg.size());
  }
  BatchTensors t;
  t.warmup_steps = f.warmup_steps;
  // Time-major, and on the device as float (spikes take the value 1/Ts).
  t.input = in.to(device).permute({1, 0, 2, 3, 4}).to(torch::kFloat).mul_(1.0 / ts).contiguous();
  t.fg = fg.to(device).permute({1, 0, 2, 3}).to(torch::kFloat).contiguous();
  return t;
}

std::vector<MaskCounts> window_counts(const torch::Tensor& out_window,
                                      const torch::Tensor& fg_window,
                                      const torch::Tensor& in_window) {
  torch::NoGradGuard ng;
  auto P = out_window.detach().sum(std::vector<int64_t>{0, 2}) > 0;
  if (in_window.defined())
    P = torch::logical_and(P, in_window.detach().sum(std::vector<int64_t>{0, 2}) > 0);
  P = P.to(torch::kUInt8).cpu();
  auto G = (fg_window.detach().sum(0) > 0).to(torch::kUInt8).cpu();
  std::vector<MaskCounts> counts;
  for (int64_t b = 0; b < P.size(0); ++b) {
    auto p = P[b].contiguous(), g = G[b].contiguous();
    std::vector<uint8_t> pv(p.data_ptr<uint8_t>(), p.data_ptr<uint8_t>() + p.numel());
    std::vector<uint8_t> gv(g.data_ptr<uint8_t>(), g.data_ptr<uint8_t>() + g.numel());
    counts.push_back(count_masks(pv, gv));
  }
  return counts;
}

}  // namespace spikems::train
