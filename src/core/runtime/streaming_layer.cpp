#include "core/runtime/streaming_layer.h"

#include <algorithm>

#include "core/runtime/fir_streaming_layer.h"
#include "core/runtime/iir_streaming_layer.h"
#include "core/util/error.h"

namespace spikems {

namespace {
// Which outputs input row/column i reaches through tap kk, as (output, kk) pairs, output
// ascending, outputs below n_out only:
//   conv:  s*o - p + kk = i  ->  o = (i + p - kk) / s when divisible
//   convT: o = s*i - p + kk
std::vector<std::pair<int32_t, int32_t>> reach(const LayerSpec& l, int i, int n_out) {
  const int k = l.kernel, s = l.stride, p = l.padding;
  std::vector<std::pair<int32_t, int32_t>> r;
  for (int kk = 0; kk < k; ++kk) {
    int o;
    if (l.kind == LayerKind::Conv) {
      const int num = i + p - kk;
      if (num < 0 || num % s != 0) continue;
      o = num / s;
    } else {
      o = s * i - p + kk;
    }
    if (o >= 0 && o < n_out) r.push_back({o, kk});
  }
  std::sort(r.begin(), r.end());
  return r;
}
}  // namespace

int StreamingLayer::needed_inputs(const LayerSpec& l, int n_in, int n_needed) {
  const int need = std::clamp(n_needed, 0, std::max(0, l.output_size(n_in)));
  int n = 0;
  for (int i = 0; i < n_in; ++i)
    if (!reach(l, i, need).empty()) n = i + 1;
  return n;
}

StreamingLayer::StreamingLayer(const LayerSpec& l, int hin, int win, int need_h, int need_w)
    : cin_(l.in_channels),
      hin_(hin),
      win_(win),
      cout_(l.out_channels),
      hout_(l.output_size(hin)),
      wout_(l.output_size(win)),
      k_(l.kernel),
      need_h_(need_h < 0 ? hout_ : std::min(need_h, hout_)),
      need_w_(need_w < 0 ? wout_ : std::min(need_w, wout_)),
      theta_(l.neuron.theta),
      div_cin_(uint32_t(l.in_channels)),
      div_win_(uint32_t(win)) {
  if (hout_ <= 0 || wout_ <= 0) fail("runtime", "", "input too small for the layer");
  same_step_ = l.neuron.srm_onset == SrmOnset::SameStep;
  if (same_step_ && l.neuron.discretisation == Discretisation::FIR)
    fail("runtime", "", "srm_onset \"same_step\" needs IIR neurons");
  if (!l.delay.empty())
    fail("runtime", "", "axonal delays are not supported by the streaming runtime");
  if (k_ < 1 || k_ > 32) fail("runtime", "", "kernels larger than 32 are not supported");
  const int k = k_;
  // weight(ci, co, ky, kx) in the file's layout
  auto weight = [&](int ci, int co, int ky, int kx) {
    return l.kind == LayerKind::Conv ? l.weight[((size_t(co) * cin_ + ci) * k + ky) * k + kx]
                                     : l.weight[((size_t(ci) * cout_ + co) * k + ky) * k + kx];
  };
  row_begin_.assign(size_t(hin_) + 1, 0);
  for (int i = 0; i < hin_; ++i) {
    row_begin_[size_t(i)] = int32_t(row_taps_.size());
    for (auto rt : reach(l, i, need_h_)) row_taps_.push_back(rt);
  }
  row_begin_[size_t(hin_)] = int32_t(row_taps_.size());
  for (int i = 0; i < hin_; ++i)
    max_rows_ = std::max(max_rows_, row_begin_[size_t(i) + 1] - row_begin_[size_t(i)]);
  // Columns: one weight block per distinct sequence of kx (a few: stride phases, borders).
  std::vector<std::vector<int32_t>> kx_seqs;
  std::vector<size_t> seq_of(static_cast<size_t>(win_));
  col_run_.assign(size_t(win_), {});
  for (int x = 0; x < win_; ++x) {
    auto r = reach(l, x, need_w_);
    std::vector<int32_t> kxs;
    for (size_t j = 0; j < r.size(); ++j) {
      if (j > 0 && r[j].first != r[j - 1].first + 1)
        fail("runtime", "", "internal: the outputs of an input column are not consecutive");
      kxs.push_back(r[j].second);
    }
    col_run_[size_t(x)].first = r.empty() ? 0 : r.front().first;
    col_run_[size_t(x)].len = int32_t(r.size());
    auto it = std::find(kx_seqs.begin(), kx_seqs.end(), kxs);
    seq_of[size_t(x)] = size_t(it - kx_seqs.begin());
    if (it == kx_seqs.end()) kx_seqs.push_back(kxs);
  }
  seg_ky_stride_ = (size_t(k) * size_t(cout_) + 15) / 16 * 16;
  seg_ci_stride_ = size_t(k) * seg_ky_stride_;
  const size_t block = size_t(cin_) * seg_ci_stride_;
  wseg_.assign(kx_seqs.size() * block, 0.f);
  for (size_t q = 0; q < kx_seqs.size(); ++q)
    for (int ci = 0; ci < cin_; ++ci)
      for (int ky = 0; ky < k; ++ky)
        for (size_t j = 0; j < kx_seqs[q].size(); ++j)
          for (int co = 0; co < cout_; ++co)
            wseg_[q * block + size_t(ci) * seg_ci_stride_ + size_t(ky) * seg_ky_stride_ +
                  j * size_t(cout_) + size_t(co)] = weight(ci, co, ky, kx_seqs[q][j]);
  for (int x = 0; x < win_; ++x) col_run_[size_t(x)].weights = seq_of[size_t(x)] * block;
  const size_t npos = size_t(hout_) * wout_;
  touched_bits_.assign((npos + 63) / 64 + 1, 0);  // + the spare word of mark_reached()
}

void StreamingLayer::prepare_unit_weights(int unit_shift) {
  const int per_unit = 1 << unit_shift, C = cout_;
  if (per_unit * C != 16 || k_ * C > 16)
    fail("runtime", "", "internal: unit drive needs 16 lanes per unit and k*C <= 16");
  // Lanes a run can reach: from its shift in the unit to the end of its len <= k positions.
  unit_blocks_ = ((per_unit - 1) * C + k_ * C + 15) / 16;
  // Lane j of block b takes lane b*16 + j - shift*C of the run's weights, or zero.
  unit_shift_idx_.assign(size_t(per_unit) * size_t(unit_blocks_) * 16, 0);
  for (int sh = 0; sh < per_unit; ++sh)
    for (int b = 0; b < unit_blocks_; ++b)
      for (int j = 0; j < 16; ++j) {
        const int src = b * 16 + j - sh * C;
        unit_shift_idx_[size_t((sh * unit_blocks_ + b) * 16 + j)] = src >= 0 && src < 16 ? src : 16;
      }
}

void StreamingLayer::fire(int64_t t, std::vector<uint32_t>& out) {
  (void)t;
  out.insert(out.end(), pending_.begin(), pending_.end());
}

void StreamingLayer::drive(int64_t t, const uint32_t* spikes, size_t n) {
  pending_.clear();
  step(t, spikes, n, pending_);
}

std::unique_ptr<StreamingLayer> StreamingLayer::create(const LayerSpec& l, double ts, int hin,
                                                       int win, int need_h, int need_w) {
  // A FIR layer with the sampled kernels runs as the IIR recursions with expiry (5-10x faster,
  // iir_streaming_layer.h); other kernels keep the ring of future potentials.
  if (l.neuron.discretisation == Discretisation::FIR && !IirStreamingLayer::runs_fir(l, ts))
    return std::make_unique<FirStreamingLayer>(l, hin, win, need_h, need_w);
  return std::make_unique<IirStreamingLayer>(l, ts, hin, win, need_h, need_w);
}

}  // namespace spikems
