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
  // Spikes emitted up to the current step (those step() computed ahead are not counted yet).
  uint64_t spikes() const { return spikes_ - ahead_; }

  static std::unique_ptr<StreamingLayer> create(const LayerSpec& spec, double time_step_ms,
                                                int in_height, int in_width);

 protected:
  // The synaptic drive of one step: for each input spike and each output position it
  // reaches, drive_[position] += the weights of that tap, and the position is marked in
  // touched_bits_. drive_ is all zeros outside the marked positions: whoever consumes a
  // marked position's drive zeroes it and clears the mark. CT is the channel count when known
  // at compile time (0: cout_).
  //
  // The output columns one input column reaches are consecutive (o = (x + p - kx) / s for a
  // convolution, s*x - p + kx for a transposed one), so per output row an input spike adds
  // one contiguous run of len*C weights (laid out in that order in wseg_) to len
  // consecutive positions: one vector loop and one or two bitmap words per row.
  template <int CT>
  SPIKEMS_INLINE void scatter_drive(const uint32_t* spikes, size_t n) {
    const int C = CT ? CT : cout_;
    uint64_t taps = 0;
    for (size_t i = 0; i < n; ++i) {
      const uint32_t pos = div_cin_(spikes[i]);
      const uint32_t ci = spikes[i] - pos * uint32_t(cin_);
      const uint32_t y = div_win_(pos), x = pos - y * uint32_t(win_);
      const ColumnRun& run = col_run_[x];
      const int len = run.len;
      if (len == 0) continue;
      const int r0 = row_begin_[y], r1 = row_begin_[y + 1];
      taps += uint64_t(r1 - r0) * uint64_t(len);
      const float* wci = &wseg_[run.weights + size_t(ci) * seg_ci_stride_];
      const uint64_t run_bits = (uint64_t(1) << len) - 1;  // len <= kernel <= 32
      for (int ry = r0; ry < r1; ++ry) {
        const auto [oy, ky] = row_taps_[size_t(ry)];
        const uint32_t op = uint32_t(oy) * uint32_t(wout_) + uint32_t(run.first);
        touched_bits_[op >> 6] |= run_bits << (op & 63);
        if ((op & 63) + uint32_t(len) > 64)
          touched_bits_[(op >> 6) + 1] |= run_bits >> (64 - (op & 63));
        float* __restrict d = &drive_[size_t(op) * C];
        const float* __restrict w = wci + size_t(ky) * seg_ky_stride_;
        // Whole blocks of 16: the weights are zero-padded, so the positions past the run get
        // +0 (drive_ has 16 spare floats at its end).
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
  HugeBuffer<float> drive_;  // [position][C] (+16 spare), zero except at marked positions
  std::vector<uint64_t> touched_bits_;  // one bit per output position
  uint64_t synops_ = 0;
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
