// One spiking block (psp -> conv / transposed conv -> spike) advanced one time step at a time,
// touching only the neurons that matter. Since psp and the synaptic op are linear, an input
// spike of neuron j at step t scatters its weights into the drive I_i[t] of its fan-out, and
// the psp shape applies to the output neuron: u_i[t] = sum_k eps[k] I_i[t-k] + refractory.
//
// Neurons are indexed channels-last, (y*W + x)*C + c, so the C neurons of one pixel ("a
// position") are contiguous and every state update is a short vector loop (compiled per
// instruction set, util/simd.h, and specialised for the usual channel counts).
//
// The two kinds (fir_streaming_layer.h, iir_streaming_layer.h) differ in how they keep the
// psp state; both use scatter() below for the synaptic drive.
#pragma once

#include <algorithm>
#include <bit>
#include <cstdint>
#include <memory>
#include <type_traits>
#include <utility>
#include <vector>

#include "core/model/model_file.h"
#include "core/util/fast_div.h"
#include "core/util/huge_buffer.h"
#include "core/util/simd.h"

namespace spikems {

class StreamingLayer {
 public:
  StreamingLayer(const LayerSpec& spec, int in_height, int in_width);
  virtual ~StreamingLayer() = default;

  // One step: takes the input spikes of step t (input neuron indices, channels-last, each at
  // most once; they reach u from t+1 on), then appends to `next` the output neurons that
  // spike at step t+1, whose potential is final once step t's input is in. Nothing spikes at
  // the first step (u is 0 before any input). Call with t increasing by one.
  virtual void step(int64_t t, const uint32_t* spikes, size_t n, std::vector<uint32_t>& next) = 0;

  // The same as a pair of calls per step, for tests and tools: fire(t) appends the spikes of
  // step t (computed by the previous drive()), drive(t) takes the input of step t.
  void fire(int64_t t, std::vector<uint32_t>& out);
  void drive(int64_t t, const uint32_t* spikes, size_t n);

  // Makes potential() exact for the neurons evaluated at the current step as well (it costs a
  // store per evaluated neuron, so it is off unless a test or tool asks).
  virtual void record_potentials(bool on) { (void)on; }
  // u[t] of an output neuron at the current step t (after fire(t)): the value compared with
  // theta. For tests and tools; see record_potentials().
  virtual float potential(int64_t t, uint32_t neuron) const = 0;
  // Positions currently holding state that may still make a neuron fire.
  virtual size_t busy_positions() const = 0;

  int in_channels() const { return cin_; }
  int in_height() const { return hin_; }
  int in_width() const { return win_; }
  int out_channels() const { return cout_; }
  int out_height() const { return hout_; }
  int out_width() const { return wout_; }
  size_t out_neurons() const { return size_t(hout_) * wout_ * cout_; }
  // Synaptic operations so far: every (input spike, output neuron) pair a weight was added for.
  uint64_t synops() const { return synops_; }
  // Position visits so far: each time a position's state was read and written (an output
  // position holds the layer's C neurons). The measure of the update work besides SynOps.
  uint64_t visits() const { return visits_; }
  // Spikes emitted up to the current step (those step() computed ahead are not counted yet).
  uint64_t spikes() const { return spikes_ - ahead_; }

  static std::unique_ptr<StreamingLayer> create(const LayerSpec& spec, double time_step_ms,
                                                int in_height, int in_width);

 protected:
  // The synaptic input of one step: for each input spike and each output position it
  // reaches, target[position*C .. +C) += the weights of that tap. Marks are kept per unit of
  // 2^unit_shift consecutive positions: each unit reached is marked in touched_bits_, and
  // on_new(unit) is called the first time it is reached in the step, before anything is added
  // to it (the IIR layer brings its state up to date there); on_prefetch(position, len) is
  // called a few groups ahead for the runs to come. target needs 16 spare floats at its end.
  // CT is the channel count when known at compile time (0: cout_).
  //
  // The output columns one input column reaches are consecutive (o = (x + p - kx) / s for a
  // convolution, s*x - p + kx for a transposed one), so per output row an input spike adds
  // one contiguous run of len*C weights (laid out in that order in wseg_) to len
  // consecutive positions: one vector loop and one or two bitmap words per row.
  template <int CT, class OnNew, class OnPrefetch>
  SPIKEMS_INLINE void scatter(const uint32_t* spikes, size_t n, float* target, int unit_shift,
                              OnNew&& on_new, OnPrefetch&& on_prefetch) {
    const int C = CT ? CT : cout_;
    uint64_t taps = 0;
    auto mark = [&](size_t word, uint64_t bits) SPIKEMS_INLINE_LAMBDA {
      uint64_t fresh = bits & ~touched_bits_[word];
      if (fresh == 0) return;
      touched_bits_[word] |= fresh;
      for (; fresh != 0; fresh &= fresh - 1)
        on_new(uint32_t(word * 64 + size_t(std::countr_zero(fresh))));
    };
    // Spikes of one input position (its channels, adjacent in sorted input) reach the same
    // output positions: the index arithmetic and the marks are done once per group.
    groups_.clear();
    for (size_t i = 0; i < n; ++i) {
      const uint32_t pos = div_cin_(spikes[i]);
      if (groups_.empty() || groups_.back().pos != pos) groups_.push_back({pos, uint32_t(i)});
    }
    const size_t ng = groups_.size();
    groups_.push_back({0, uint32_t(n)});
    // The state of the positions a group reaches is often far from the cache (noise events
    // land anywhere): it is requested a few groups early so that the misses overlap.
    constexpr size_t kAhead = 4;
    auto prefetch = [&](uint32_t pos) SPIKEMS_INLINE_LAMBDA {
      const uint32_t y = div_win_(pos), x = pos - y * uint32_t(win_);
      const ColumnRun& run = col_run_[x];
      for (int ry = row_begin_[y], r1 = row_begin_[y + 1]; ry < r1; ++ry) {
        const uint32_t op =
            uint32_t(row_taps_[size_t(ry)].first) * uint32_t(wout_) + uint32_t(run.first);
        __builtin_prefetch(target + size_t(op) * C, 1);
        on_prefetch(op, run.len);
      }
    };
    for (size_t g = 0; g < std::min(ng, kAhead); ++g) prefetch(groups_[g].pos);
    for (size_t g = 0; g < ng; ++g) {
      if (g + kAhead < ng) prefetch(groups_[g + kAhead].pos);
      const uint32_t pos = groups_[g].pos, base = pos * uint32_t(cin_);
      const size_t i = groups_[g].first, e = groups_[g + 1].first;
      const uint32_t y = div_win_(pos), x = pos - y * uint32_t(win_);
      const ColumnRun& run = col_run_[x];
      const int len = run.len;
      const int r0 = row_begin_[y], r1 = row_begin_[y + 1];
      taps += uint64_t(r1 - r0) * uint64_t(len) * uint64_t(e - i);
      const uint64_t run_bits = (uint64_t(1) << len) - 1;  // len <= kernel <= 32
      for (int ry = r0; ry < r1 && len > 0; ++ry) {
        const auto [oy, ky] = row_taps_[size_t(ry)];
        const uint32_t op = uint32_t(oy) * uint32_t(wout_) + uint32_t(run.first);
        if (unit_shift == 0) {
          mark(op >> 6, run_bits << (op & 63));
          if ((op & 63) + uint32_t(len) > 64) mark((op >> 6) + 1, run_bits >> (64 - (op & 63)));
        } else {
          const uint32_t u1 = (op + uint32_t(len) - 1) >> unit_shift;
          for (uint32_t u = op >> unit_shift; u <= u1; ++u) mark(u >> 6, uint64_t(1) << (u & 63));
        }
        float* __restrict d = target + size_t(op) * C;
        const float* wrow = &wseg_[run.weights + size_t(ky) * seg_ky_stride_];
        for (size_t k = i; k < e; ++k) {
          const float* __restrict w = wrow + size_t(spikes[k] - base) * seg_ci_stride_;
          // Whole blocks of 16: the weights are zero-padded, so the positions past the run
          // get +0, which changes nothing (target has 16 spare floats at its end).
          if (CT != 0 && CT % 16 == 0) {
            for (int j = 0; j < len; ++j)
              for (int c = 0; c < CT; ++c) d[j * CT + c] += w[j * CT + c];
          } else {
            const int m = len * C;
            for (int j = 0; j < m; j += 16)
              for (int jj = 0; jj < 16; ++jj) d[j + jj] += w[j + jj];
          }
        }
      }
    }
    synops_ += taps * uint64_t(C);
  }

  int cin_, hin_, win_, cout_, hout_, wout_, k_;
  float theta_;
  FastDiv div_cin_, div_win_;
  // Taps per input row: (output row, ky) pairs.
  std::vector<int32_t> row_begin_;
  std::vector<std::pair<int32_t, int32_t>> row_taps_;
  // Per input column: the first output column it reaches, how many (consecutive), and where
  // its weights start in wseg_, laid out [ci][ky][run position][co], each [ci][ky] block
  // zero-padded to seg_ky_stride_ (a multiple of 16) floats.
  struct ColumnRun {
    int32_t first = 0, len = 0;
    size_t weights = 0;
  };
  std::vector<ColumnRun> col_run_;
  std::vector<float> wseg_;
  size_t seg_ky_stride_ = 0, seg_ci_stride_ = 0;
  std::vector<uint64_t> touched_bits_;  // one bit per output unit: reached this step
  struct Group {
    uint32_t pos, first;  // an input position and its first spike in the step's list
  };
  std::vector<Group> groups_;
  uint64_t synops_ = 0;
  uint64_t visits_ = 0;
  uint64_t spikes_ = 0;  // all computed, including the step ahead
  uint64_t ahead_ = 0;   // spikes computed for the step after the current one

 private:
  std::vector<uint32_t> pending_;  // fire()/drive() view: spikes of the coming step
};

// Runs f(std::integral_constant<int, C>) with C the layer's channel count when it is one of
// the usual ones (so loops over channels have a constant trip count), else with 0.
template <class F>
SPIKEMS_INLINE void with_channels(int c, F&& f) {
  switch (c) {
    case 2:
      f(std::integral_constant<int, 2>{});
      break;
    case 16:
      f(std::integral_constant<int, 16>{});
      break;
    case 32:
      f(std::integral_constant<int, 32>{});
      break;
    case 64:
      f(std::integral_constant<int, 64>{});
      break;
    default:
      f(std::integral_constant<int, 0>{});
      break;
  }
}

}  // namespace spikems
