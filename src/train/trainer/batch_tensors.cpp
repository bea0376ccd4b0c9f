#include "train/trainer/batch_tensors.h"

#include <algorithm>
#include <cstring>

#include "core/util/error.h"

namespace spikems::train {

BatchTensors to_tensors(const std::vector<Sample>& samples, double ts, torch::Device device) {
  if (samples.empty()) fail("batch", "", "no samples");
  const Sample& f = samples.front();
  const int64_t B = int64_t(samples.size());
  int H = 0, W = 0;
  for (size_t b = 0; b < samples.size(); ++b) {
    const Sample& s = samples[b];
    if (s.T != f.T || s.warmup_steps != f.warmup_steps)
      fail("batch", "sample " + std::to_string(b), "samples of one batch differ in length");
    if (s.input.size() != size_t(s.T) * 2 * size_t(s.H) * size_t(s.W) ||
        s.fg.size() != size_t(s.T) * size_t(s.H) * size_t(s.W))
      fail("batch", "sample " + std::to_string(b), "sample buffers do not match its size");
    H = std::max(H, s.H);
    W = std::max(W, s.W);
  }
  auto in = torch::zeros({B, f.T, 2, H, W}, torch::kUInt8);
  auto fg = torch::zeros({B, f.T, H, W}, torch::kUInt8);
  for (int64_t b = 0; b < B; ++b) {
    const Sample& s = samples[size_t(b)];
    if (s.H == H && s.W == W) {
      std::memcpy(in[b].data_ptr<uint8_t>(), s.input.data(), s.input.size());
      std::memcpy(fg[b].data_ptr<uint8_t>(), s.fg.data(), s.fg.size());
      continue;
    }
    uint8_t* pi = in[b].data_ptr<uint8_t>();
    uint8_t* pf = fg[b].data_ptr<uint8_t>();
    for (int t = 0; t < s.T; ++t)
      for (int y = 0; y < s.H; ++y) {
        for (int c = 0; c < 2; ++c)
          std::memcpy(pi + ((size_t(t) * 2 + size_t(c)) * size_t(H) + size_t(y)) * size_t(W),
                      &s.input[s.at(t, c, y, 0)], size_t(s.W));
        std::memcpy(pf + (size_t(t) * size_t(H) + size_t(y)) * size_t(W),
                    &s.fg[(size_t(t) * size_t(s.H) + size_t(y)) * size_t(s.W)], size_t(s.W));
      }
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
