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
// psp state; both use mark_reached() and add_drive() below for the synaptic drive.
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
  // need_height x need_width: the top-left output region anything downstream uses (-1: all
  // of it). Input spikes add no drive beyond it, so the neurons there never run (the padding
  // a model with skips works on: StreamingNetwork). The neurons inside are exact.
  StreamingLayer(const LayerSpec& spec, int in_height, int in_width, int need_height = -1,
                 int need_width = -1);
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
  // Says that the input spikes land anywhere, as the sensor's events do (noise): an IIR layer
  // then requests the drive lines of each input position a few positions ahead. In later
  // layers the spikes are clustered, the lines mostly in cache, and the requests cost more
  // than they save (measured: docs/performance.md).
  void set_scattered_input(bool on) { scattered_input_ = on; }
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
  uint64_t spikes() const { return same_step_ ? spikes_ : spikes_ - ahead_; }
  // A layer of SrmOnset::SameStep neurons: what step(t) computes is the layer's output of step
  // t itself (the kernel is the NextStep one a step ahead, so the arithmetic is the same and
  // only the step the spikes belong to changes; potential(t + 1, n) is then u at step t).
  bool same_step() const { return same_step_; }

  static std::unique_ptr<StreamingLayer> create(const LayerSpec& spec, double time_step_ms,
                                                int in_height, int in_width, int need_height = -1,
                                                int need_width = -1);
  // How many leading input rows (or columns) of n_in reach one of the first n_needed outputs:
  // the region of its input a layer needs for that region of its output.
  static int needed_inputs(const LayerSpec& spec, int n_in, int n_needed);
  // The output region that runs (the constructor's need_*, clamped to the output).
  int need_height() const { return need_h_; }
  int need_width() const { return need_w_; }
  // The neurons of that region: those that can fire (the firing rates' denominator).
  size_t running_neurons() const { return size_t(need_h_) * need_w_ * cout_; }

 protected:
  // The synaptic input of one step, in two passes so that the layer can fetch the state of
  // everything reached, in address order and many units ahead, between them:
  //
  // mark_reached() groups the spikes by input position (groups_: the channels of one input
  // position, adjacent in sorted input, reach the same outputs, so the index arithmetic is
  // done once per group) and sets in touched_bits_ the bit of every unit of 2^unit_shift
  // consecutive output positions they reach. It touches no neuron state.
  //
  // add_drive() then adds, for each group of the last mark_reached() and each output position
  // it reaches, the weights of that tap: at(op)[j*C .. +C) += w for the run's positions op+j
  // (at(op) gives where the run's first position's C floats are; the run's positions follow
  // contiguously). CT is the channel count when known at compile time (0: cout_); a target
  // needs 16 spare floats after its last position.
  //
  // The output columns one input column reaches are consecutive (o = (x + p - kx) / s for a
  // convolution, s*x - p + kx for a transposed one), so per output row an input spike adds
  // one contiguous run of len*C weights (laid out in that order in wseg_) to len
  // consecutive positions: one vector loop and one or two bitmap words per row.
  SPIKEMS_INLINE void group_spikes(const uint32_t* spikes, size_t n) {
    // Branch-free grouping: every spike writes the slot of the next group, which only a
    // spike of a new position keeps (the first spike always starts a group).
    // Grown, never shrunk: a resize per step would value-initialise the elements each time.
    if (groups_.size() < n + 1) groups_.resize(n + 1);
    Group* __restrict gr = groups_.data();
    size_t ng = 0;
    uint32_t prev = ~uint32_t(0);
    for (size_t i = 0; i < n; ++i) {
      const uint32_t pos = div_cin_(spikes[i]);
      gr[ng] = {pos, uint32_t(i)};
      ng += pos != prev;
      prev = pos;
    }
    gr[ng] = {0, uint32_t(n)};
    ngroups_ = ng;
  }
  struct Group;
  struct ColumnRun;
  struct Geo;  // below
  // Sets the bits of the units of 2^unit_shift positions that a run of len positions from op
  // reaches. len <= kernel <= 32: a run covers at most two bitmap words of positions, or its
  // first and last unit and (for kernels wider than a unit) any between. The first two are
  // marked without a branch; touched_bits_ has a spare word.
  static SPIKEMS_INLINE void mark_run(const Geo& geo, uint32_t op, uint32_t len, int unit_shift) {
    uint64_t* __restrict tb = geo.tb;
    if (unit_shift == 0) {
      const uint64_t run_bits = (uint64_t(1) << len) - 1;
      tb[op >> 6] |= run_bits << (op & 63);
      tb[(op >> 6) + 1] |= (run_bits >> 1) >> (63 - (op & 63));
    } else {
      const uint32_t u0 = op >> unit_shift, u1 = (op + len - 1) >> unit_shift;
      tb[u0 >> 6] |= uint64_t(1) << (u0 & 63);
      tb[u1 >> 6] |= uint64_t(1) << (u1 & 63);
      for (uint32_t u = u0 + 1; u < u1; ++u) tb[u >> 6] |= uint64_t(1) << (u & 63);
    }
  }
  SPIKEMS_INLINE void mark_reached(const uint32_t* spikes, size_t n, int unit_shift) {
    group_spikes(spikes, n);
    const Geo geo = geometry();
    each_run(geo, [&](size_t, size_t, uint32_t, const ColumnRun& run, int, uint32_t op)
                      SPIKEMS_INLINE_LAMBDA { mark_run(geo, op, uint32_t(run.len), unit_shift); });
  }

  template <int CT, bool kMark = false, int kAhead = 0, class At, class A = std::nullptr_t>
  SPIKEMS_INLINE void add_drive(const uint32_t* spikes, At&& at, A&& ahead = nullptr) {
    const int C = CT ? CT : cout_;
    const Geo geo = geometry();
    uint64_t taps = 0;
    each_run<kAhead>(
        geo,
        [&](size_t i, size_t e, uint32_t base, const ColumnRun& run, int ky, uint32_t op)
            SPIKEMS_INLINE_LAMBDA {
              if constexpr (kMark) mark_run(geo, op, uint32_t(run.len), 0);
              taps += uint64_t(run.len) * uint64_t(e - i);
              float* __restrict d = at(op);
              const float* wrow = &geo.wseg[run.weights + size_t(ky) * geo.ky_stride];
              // Whole blocks of 16: the weights are zero-padded, so the floats past the
              // run get +0, which changes nothing (targets have 16 spare floats at their
              // end). Each block is summed over the group's spikes in a register, in
              // spike order.
              const int nj = run.len * C;
              const float* w0 = wrow + size_t(spikes[i] - base) * geo.ci_stride;
              if (e - i == 1) {
                for (int j = 0; j < nj; j += 16)
                  simd::store(d + j, simd::load(d + j) + simd::load(w0 + j));
              } else {
                if constexpr (CT > 0 && CT % 16 == 0) {
                  if (run.len <= 3) {
                    // Runs of 1-3 positions of whole vectors: each block of the run in a
                    // register of its own while the spikes are summed. With the blocks inside
                    // the loop over spikes, their chains are independent and that loop's exit
                    // is mispredicted once per run, not once per block (perf: with the blocks
                    // outside, a quarter of the step's samples sat on that add, 1.9 M ev/s).
                    constexpr int B = CT / 16;
                    if (run.len == 1)
                      sum_spike_blocks<B>(d, wrow, spikes, i, e, base, geo.ci_stride);
                    else if (run.len == 2)
                      sum_spike_blocks<2 * B>(d, wrow, spikes, i, e, base, geo.ci_stride);
                    else
                      sum_spike_blocks<3 * B>(d, wrow, spikes, i, e, base, geo.ci_stride);
                    return;  // this run is done (the lambda is called once per run)
                  }
                }
                for (int j = 0; j < nj; j += 16) {
                  simd::F16 acc = simd::load(d + j);
                  for (size_t k = i; k < e; ++k)
                    acc += simd::load(wrow + size_t(spikes[k] - base) * geo.ci_stride + size_t(j));
                  simd::store(d + j, acc);
                }
              }
            },
        ahead);
    synops_ += taps * uint64_t(C);
  }

  // d[0 .. 16 NB) += the weights of spikes [i, e) (w + (spike - base) * ci_stride each), summed
  // per block in spike order onto d's value: the same float operations, in the same order, as
  // one block after another (so spikes do not depend on which loop ran).
  template <int NB>
  static SPIKEMS_INLINE void sum_spike_blocks(float* __restrict d, const float* wrow,
                                              const uint32_t* spikes, size_t i, size_t e,
                                              uint32_t base, size_t ci_stride) {
    simd::F16 acc[NB];
#pragma GCC unroll 12
    for (int b = 0; b < NB; ++b) acc[b] = simd::load(d + 16 * b);
    for (size_t k = i; k < e; ++k) {
      const float* w = wrow + size_t(spikes[k] - base) * ci_stride;
#pragma GCC unroll 12
      for (int b = 0; b < NB; ++b) acc[b] += simd::load(w + 16 * b);
    }
#pragma GCC unroll 12
    for (int b = 0; b < NB; ++b) simd::store(d + 16 * b, acc[b]);
  }

  // add_drive() for a target laid out in units of P = 2^unit_shift positions of C < 16
  // channels, P*C = 16 lanes per unit, at_unit(u) giving unit u's lanes (the units a run
  // reaches must follow contiguously, with 16*unit_blocks_ spare floats after the last).
  // Needs k*C <= 16, so that a run's weights fit one vector: they are summed over the group's
  // spikes in a register, then moved to the run's lanes in its unit by one permutation
  // (unit_shift_idx_, made by prepare_unit_weights()) and added as whole, aligned blocks of
  // 16 lanes. Small runs (2-6 floats for the 2-channel output layer) then cost one or two
  // aligned vector adds with no partial overlaps between neighbouring runs, which would
  // defeat store-to-load forwarding. The lanes outside the run add +0, which changes no value
  // (also in units that may not be marked).
  void prepare_unit_weights(int unit_shift);
  template <int CT, bool kMark = false, class AtUnit>
  SPIKEMS_INLINE void add_drive_units(const uint32_t* spikes, AtUnit&& at_unit) {
    const int C = CT ? CT : cout_;
    const int nblk = unit_blocks_, ushift = std::countr_zero(unsigned(16 / C));
    const uint32_t pmask = uint32_t(16 / C - 1);
    if (kMark && nblk == 2 && max_rows_ <= kCombineRows) {
      add_drive_units_combined<CT>(spikes, at_unit);
      return;
    }
    const Geo geo = geometry();
    uint64_t taps = 0;
    each_run(geo, [&](size_t i, size_t e, uint32_t base, const ColumnRun& run, int ky,
                      uint32_t op) SPIKEMS_INLINE_LAMBDA {
      if constexpr (kMark) mark_run(geo, op, uint32_t(run.len), ushift);
      taps += uint64_t(run.len) * uint64_t(e - i);
      const float* wrow = &geo.wseg[run.weights + size_t(ky) * geo.ky_stride];
      simd::F16 w = simd::load(wrow + size_t(spikes[i] - base) * geo.ci_stride);
      for (size_t k = i + 1; k < e; ++k)
        w += simd::load(wrow + size_t(spikes[k] - base) * geo.ci_stride);
      float* __restrict d = at_unit(op >> ushift);
      const int32_t* ix = &geo.shift_idx[size_t(op & pmask) * size_t(nblk) * 16];
      const simd::F16 zero = {};
      for (int b = 0; b < nblk; ++b)
        simd::store(d + 16 * b,
                    simd::load(d + 16 * b) + __builtin_shuffle(w, zero, simd::load(ix + 16 * b)));
    });
    synops_ += taps * uint64_t(C);
  }

  // add_drive_units() with marks, for runs spanning at most two units, combining in registers
  // the runs that land on the same unit one after the other. The groups of one input row
  // reach the same output rows, and neighbouring groups (input columns) the same or the next
  // unit of each: adding each run to memory would chain every add to the previous one through
  // store-to-load forwarding (~12 cycles a link). So per output row r of the input row (at
  // most kCombineRows) two blocks are held, for a unit and the next, and written out (and
  // their units marked) only when a run moves past them.
  static constexpr int kCombineRows = 3;
  template <int CT, class AtUnit>
  SPIKEMS_INLINE void add_drive_units_combined(const uint32_t* spikes, AtUnit&& at_unit) {
    using simd::F16;
    const int C = CT ? CT : cout_;
    const int ushift = std::countr_zero(unsigned(16 / C));
    const uint32_t pmask = uint32_t(16 / C - 1), per_unit = pmask + 1;
    constexpr uint32_t kNone = ~uint32_t(0) - 1;  // no unit held (kNone + 1 is no unit either)
    const Geo geo = geometry();
    uint64_t* __restrict tb = geo.tb;
    auto flush = [&](uint32_t u, F16 v) SPIKEMS_INLINE_LAMBDA {
      float* __restrict d = at_unit(u);
      simd::store(d, simd::load(d) + v);
      tb[u >> 6] |= uint64_t(1) << (u & 63);
    };
    F16 lo[kCombineRows] = {}, hi[kCombineRows] = {};
    uint32_t held[kCombineRows];
    bool hi_used[kCombineRows];
    for (int r = 0; r < kCombineRows; ++r) {
      held[r] = kNone;
      hi_used[r] = false;
    }
    const F16 zero = {};
    uint64_t taps = 0;
    each_group(geo, [&](size_t i, size_t e, uint32_t base, const ColumnRun& run, int r0,
                        int nrows) SPIKEMS_INLINE_LAMBDA {
      if (nrows == 0) return;  // an input row that reaches no output row
      taps += uint64_t(run.len) * uint64_t(e - i) * uint64_t(nrows);
      // The weights of every row, summed over the group's spikes in one loop (one loop exit
      // to mispredict per group, not per row). Rows past nrows repeat the last one's (unused).
      const float* wrows[kCombineRows];
      F16 ws[kCombineRows];
#pragma GCC unroll 3
      for (int r = 0; r < kCombineRows; ++r) {
        const int ky = geo.row_taps[size_t(r0 + std::min(r, nrows - 1))].second;
        wrows[r] = &geo.wseg[run.weights + size_t(ky) * geo.ky_stride];
        ws[r] = simd::load(wrows[r] + size_t(spikes[i] - base) * geo.ci_stride);
      }
      for (size_t k = i + 1; k < e; ++k) {
        const size_t o = size_t(spikes[k] - base) * geo.ci_stride;
#pragma GCC unroll 3
        for (int r = 0; r < kCombineRows; ++r) ws[r] += simd::load(wrows[r] + o);
      }
#pragma GCC unroll 3
      for (int r = 0; r < kCombineRows; ++r) {
        if (r >= nrows) break;
        const int32_t oy = geo.row_taps[size_t(r0 + r)].first;
        const F16 w = ws[r];
        const uint32_t op = uint32_t(oy) * geo.wout + uint32_t(run.first);
        const uint32_t u = op >> ushift, sh = op & pmask;  // rows need not start a unit
        const bool cross = sh + uint32_t(run.len) > per_unit;
        const int32_t* ix = &geo.shift_idx[size_t(sh) * 32];
        const F16 p0 = __builtin_shuffle(w, zero, simd::I16(simd::load(ix))),
                  p1 = __builtin_shuffle(w, zero, simd::I16(simd::load(ix + 16)));
        if (u == held[r]) {
          lo[r] += p0;
          hi[r] += p1;
          hi_used[r] |= cross;
        } else if (u == held[r] + 1) {
          flush(held[r], lo[r]);
          lo[r] = hi[r] + p0;
          hi[r] = p1;
          held[r] = u;
          hi_used[r] = cross;
        } else {
          if (held[r] != kNone) {
            flush(held[r], lo[r]);
            if (hi_used[r]) flush(held[r] + 1, hi[r]);
          }
          lo[r] = p0;
          hi[r] = p1;
          held[r] = u;
          hi_used[r] = cross;
        }
      }
    });
    for (int r = 0; r < kCombineRows; ++r)
      if (held[r] != kNone) {
        flush(held[r], lo[r]);
        if (hi_used[r]) flush(held[r] + 1, hi[r]);
      }
    synops_ += taps * uint64_t(C);
  }

  // Calls f(first spike, end spike, first input neuron of the position, run, ky, first
  // output position) for each group of the last mark_reached() and each output row it
  // reaches: the run is the group's len consecutive output positions in that row.
  template <int kAhead = 0, class F, class A = std::nullptr_t>
  SPIKEMS_INLINE void each_run(const Geo& geo, F&& f, A&& ahead = nullptr) {
    each_group<kAhead>(
        geo,
        [&](size_t i, size_t e, uint32_t base, const ColumnRun& run, int r0, int nrows)
            SPIKEMS_INLINE_LAMBDA {
              for (int ry = r0; ry < r0 + nrows; ++ry) {
                const auto [oy, ky] = geo.row_taps[size_t(ry)];
                f(i, e, base, run, int(ky), uint32_t(oy) * geo.wout + uint32_t(run.first));
              }
            },
        ahead);
  }
  // Calls f(first spike, end spike, first input neuron of the position, run, first row tap,
  // row taps) for each group that reaches any output: its rows are geo.row_taps[first ..).
  // With kAhead > 0, first calls ahead(first output position, len) for each run of the group
  // kAhead groups on, for the caller to request the lines it will touch there.
  template <int kAhead = 0, class F, class A = std::nullptr_t>
  SPIKEMS_INLINE void each_group(const Geo& geo, F&& f, A&& ahead = nullptr) {
    const size_t ng = geo.ngroups;
    const Group* gr = geo.groups;
    for (size_t g = 0; g < ng; ++g) {
      if constexpr (kAhead > 0) {
        const size_t ga = std::min(g + kAhead, ng);  // the end marker has no runs
        const uint32_t pos = gr[ga].pos;
        const uint32_t y = geo.div_win(pos), x = pos - y * geo.win;
        const ColumnRun& run = geo.cols[x];
        if (ga < ng)
          for (int ry = geo.row_begin[y]; ry < geo.row_begin[y + 1]; ++ry)
            ahead(uint32_t(geo.row_taps[size_t(ry)].first) * geo.wout + uint32_t(run.first),
                  uint32_t(run.len));
      }
      const uint32_t pos = gr[g].pos;
      const uint32_t y = geo.div_win(pos), x = pos - y * geo.win;
      const ColumnRun& run = geo.cols[x];
      if (run.len == 0) continue;
      f(size_t(gr[g].first), size_t(gr[g + 1].first), pos * geo.cin, run, geo.row_begin[y],
        geo.row_begin[y + 1] - geo.row_begin[y]);
    }
  }

  int cin_, hin_, win_, cout_, hout_, wout_, k_;
  int need_h_, need_w_;
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
    size_t weights = 0;  // offset in wseg_
  };
  std::vector<ColumnRun> col_run_;
  std::vector<float> wseg_;
  // add_drive_units(): the lane indices moving a run's weights to each shift in its unit,
  // [shift][block][16] (16 selects zero), and how many 16-lane blocks a run can span.
  std::vector<int32_t> unit_shift_idx_;
  int unit_blocks_ = 0;
  int max_rows_ = 0;  // the most output rows one input row reaches
  bool scattered_input_ = false;
  bool same_step_ = false;
  size_t seg_ky_stride_ = 0, seg_ci_stride_ = 0;
  std::vector<uint64_t> touched_bits_;  // one bit per output unit: reached this step
  struct Group {
    uint32_t pos, first;  // an input position and its first spike in the step's list
  };
  std::vector<Group> groups_;  // the first ngroups_ + 1 (an end marker) are this step's
  size_t ngroups_ = 0;
  // The members the drive loops read, copied into a local: the loops' vector stores may alias
  // anything, so members would be reloaded for every run; a local stays in registers.
  struct Geo {
    const Group* groups;
    size_t ngroups;
    FastDiv div_win;
    uint32_t win, wout, cin;
    const ColumnRun* cols;
    const int32_t* row_begin;
    const std::pair<int32_t, int32_t>* row_taps;
    const float* wseg;
    size_t ky_stride, ci_stride;
    const int32_t* shift_idx;
    uint64_t* tb;
  };
  SPIKEMS_INLINE Geo geometry() {
    return Geo{groups_.data(),
               ngroups_,
               div_win_,
               uint32_t(win_),
               uint32_t(wout_),
               uint32_t(cin_),
               col_run_.data(),
               row_begin_.data(),
               row_taps_.data(),
               wseg_.data(),
               seg_ky_stride_,
               seg_ci_stride_,
               unit_shift_idx_.data(),
               touched_bits_.data()};
  }
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
