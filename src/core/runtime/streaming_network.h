// The event-driven network: a chain of StreamingLayer, advanced one time step at a time.
// At step t, each layer emits its spikes of t (computed during the previous step: its
// potential at t depends on input before t only, since eps[0] = 0), takes the spikes its
// predecessor emits at t as input, and computes its spikes of t+1. Layer k therefore answers
// an input spike k steps later at the earliest.
//
// Skip connections (LayerSpec::skip_from = j): layer k also takes layer j's spikes of the same
// step t, as channels after its predecessor's: (y*W + x)*C_j + c enters as
// (y*W + x)*(C_prev + C_j) + C_prev + c. Every layer emits its spikes of t at step t, so both
// sources are there when layer k runs. A model with skips runs on its fitted input size
// (ModelSpec::fitted_input_size: zeros at the bottom and right), as the LibTorch network does.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "core/model/model_file.h"
#include "core/runtime/streaming_layer.h"
#include "core/util/fast_div.h"

namespace spikems {

struct LayerStats {
  uint64_t synops = 0;      // weight additions actually made (input spike x fan-out reached)
  uint64_t in_spikes = 0;   // spikes that entered the layer
  uint64_t out_spikes = 0;  // spikes the layer emitted
  size_t neurons = 0;   // neurons that run (the padding's do not: StreamingLayer::running_neurons)
  uint64_t visits = 0;  // position visits (state reads and writes of a pixel's C neurons)
  double seconds = 0;   // wall time spent in the layer's steps
};

// Runs n independent tasks on a few threads and waits for them (the caller works too). The
// tasks are claimed in index order, so callers put the longest first. Between runs the
// workers and the caller spin for a while before they sleep on a condition variable: a step
// comes every millisecond or so, and a futex wake-up costs tens of microseconds on a VM.
class TaskPool {
 public:
  explicit TaskPool(int threads);
  ~TaskPool();
  void run(int n, const std::function<void(int)>& task) {
    start(n, task);
    wait();
  }
  // run() in two halves: start() sets the workers going and returns (task must live until
  // wait()); wait() has the caller claim what is left, then waits for every task to finish.
  void start(int n, const std::function<void(int)>& task);
  void wait();
  int threads() const { return int(workers_.size()) + 1; }

 private:
  void work();
  std::vector<std::thread> workers_;
  std::mutex mu_;
  std::condition_variable start_cv_, done_cv_;
  const std::function<void(int)>* task_ = nullptr;
  int ntasks_ = 0;
  std::atomic<int> remaining_{0};
  std::atomic<uint64_t> generation_{0};
  std::atomic<bool> stop_{false};
  std::atomic<int> next_{0};
  int spins_ = 0;  // pauses before sleeping (0 with more threads than cores)
};

class StreamingNetwork {
 public:
  // The input is [2, height, width] (channel = polarity). Throws Error when the model cannot
  // run on that size or holds something the runtime does not support. A model with skips is
  // built on model.fitted_input_size(height, width); the input indices stay in the caller's
  // geometry (below) and are moved to the wider rows when the widths differ.
  // Only the neurons that can reach an output pixel inside the sensor run: padding's are never
  // driven, so the output there stays silent (every output inside is exact). `whole` runs
  // every neuron of the fitted size, as the LibTorch network does (tools comparing all of it).
  StreamingNetwork(const ModelSpec& model, int height, int width, bool whole = false);

  // Advances one step with the given input spikes, input neuron index (y*W + x)*2 + p with
  // W = in_width(), each at most once (ascending keeps the first layer's scatter in address
  // order). Returns the output layer's spikes of this step, index (y*Wo + x)*Co + c with
  // Wo = out_width().
  const std::vector<uint32_t>& step(const std::vector<uint32_t>& input);
  // Advances n steps (inputs[j]: the input of the j-th) layer by layer: layer k runs all of
  // them before layer k+1 starts. The spikes are those of as many step() calls, but each
  // layer's state stays in the cache for the whole block instead of being evicted by the other
  // layers at every step (the layers' state, megabytes each, is larger than the cache:
  // docs/performance.md). Returns how many steps' outputs are ready, the oldest not returned
  // yet: the output layer's spikes of each are block_output(0 ..), until the next call.
  // On one thread that is this block. With threads (set_threads), the layers work on
  // different blocks at once, layer k on the block of k calls before (a pipeline: no layer
  // waits for another within a call), so outputs come layer_count() - 1 calls later; call with
  // n = 0 while in_flight() to get the rest. A block of one step with nothing in flight is a
  // step() (layers in parallel within the step, no delay).
  size_t step_block(const std::vector<uint32_t>* inputs, size_t n);
  // The pipeline's step_block() in two halves, so that the caller can bin the next block and
  // label the last one while the other threads run the layers: start_block() returns at once
  // (inputs must stay untouched until finish_block()), finish_block() takes its share of the
  // layers, waits, and returns what step_block() would. For a network with threads; the
  // outputs of the previous finish_block() stay valid until the next one.
  bool pipelined(size_t n) const { return pool_ && (n > 1 || in_flight()); }
  void start_block(const std::vector<uint32_t>* inputs, size_t n);
  size_t finish_block();
  bool block_running() const { return running_; }
  const std::vector<uint32_t>& block_output(size_t j) const { return (*ready_)[j]; }
  // Steps taken in whose outputs have not been returned yet (step() needs none).
  bool in_flight() const { return taken_ > t_; }
  // Threads for step(): within a step, each layer reads only its predecessor's (and skip
  // source's) spikes of t (computed the step before) and writes its own of t+1, so the layers
  // run in parallel. Results do not depend on the thread count. A model of SameStep neurons
  // (same_step()) runs its layers one after another within a step (each needs its
  // predecessor's spikes of that step), so there threads help through blocks only.
  void set_threads(int n);
  int threads() const { return pool_ ? pool_->threads() : 1; }

  int64_t steps_done() const { return t_; }  // steps whose output was returned
  // Minimum steps from an input to the output: one per layer, none for SameStep neurons.
  int latency_steps() const { return same_step_ ? 0 : int(layers_.size()); }
  // Every layer's neurons are SrmOnset::SameStep (a model mixing the two is refused).
  bool same_step() const { return same_step_; }
  // The caller's sensor size, the geometry of the input indices.
  int in_height() const { return h_; }
  int in_width() const { return w_; }
  // The size the first layer works on: in_* padded to the fitted size for a model with skips
  // (zeros at the bottom and right), in_* otherwise.
  int net_height() const { return nh_; }
  int net_width() const { return nw_; }
  // The output layer's geometry (of the net_* input): it may be smaller than the sensor
  // (padding 0) or larger (a padded model on a size that is not a multiple of 2^levels, or one
  // with skips). Output pixel (y, x) is sensor pixel (y, x), top-left aligned; the output
  // pixels beyond the sensor do not run (unless built `whole`) and callers ignore them.
  int out_channels() const { return layers_.back()->out_channels(); }
  int out_height() const { return layers_.back()->out_height(); }
  int out_width() const { return layers_.back()->out_width(); }
  size_t layer_count() const { return layers_.size(); }
  StreamingLayer& layer(size_t k) { return *layers_[k]; }
  // The spikes layer k emitted at its last step (with blocks in flight, layers are at
  // different steps: compare once nothing is in flight).
  const std::vector<uint32_t>& layer_spikes(size_t k) const { return emitted_[k]; }
  // The input layer k took at the last step, into `out`, in its own geometry: the network
  // input (`net_input`, what was given to that step) for k = 0, else its predecessor's spikes
  // with its skip source's concatenated. For tools that replay a layer; nothing in flight.
  void layer_input(size_t k, const std::vector<uint32_t>& net_input,
                   std::vector<uint32_t>& out) const;
  std::vector<LayerStats> stats() const;
  uint64_t total_synops() const;
  // The model's output gate (ModelSpec::output_gate_steps, 0 = off): every output returned
  // (step(), block_output(), layer_spikes() of the last layer) keeps a spike of step s only
  // where its pixel had an input event in steps s-K+1 .. s. The last layer's own dynamics are
  // untouched (the gate acts after its neurons), so its stats count the spikes before it.
  int output_gate_steps() const { return gate_; }
  // Output spikes the gate let through and those it removed, so far.
  uint64_t gate_kept() const { return gate_kept_; }
  uint64_t gate_removed() const { return gate_removed_; }

 private:
  int h_, w_;                  // the caller's sensor
  int nh_, nw_;                // the first layer's input (fitted for skips)
  int64_t t_ = 0, taken_ = 0;  // steps whose output was returned; steps taken in
  bool same_step_ = false;     // SrmOnset::SameStep: layer k takes layer k-1's spikes of t
  std::vector<std::unique_ptr<StreamingLayer>> layers_;
  // How layer k's input is made from its sources: for layer 0, the sensor rows moved to the
  // network's width (when they differ); for a layer with a skip, the concatenation.
  struct InputMap {
    int skip = -1;                    // skip source layer
    uint32_t c_prev = 0, c_skip = 0;  // channels of the predecessor and the skip source
    FastDiv div_prev, div_skip;       // by c_prev, c_skip (positions of their spikes)
  };
  std::vector<InputMap> map_;
  FastDiv div_w_;                               // by w_ (the input's rows)
  bool remap_input_ = false;                    // nw_ != w_
  std::vector<std::vector<uint32_t>> scratch_;  // per layer: its input of one step, when built
  // Layer k's input of one step from `a` (its predecessor's spikes, or the network input for
  // k = 0) and `b` (its skip source's spikes of the same step, or null): `a` itself when it
  // needs no change, else `buf` filled. Ascending when the sources are.
  const std::vector<uint32_t>& input_of(size_t k, const std::vector<uint32_t>& a,
                                        const std::vector<uint32_t>* b,
                                        std::vector<uint32_t>& buf) const;
  // Per layer: spikes emitted at the last step, spikes of the coming step, and a buffer the
  // layers write the step after that into.
  std::vector<std::vector<uint32_t>> emitted_, now_, ahead_;
  // Layer k's n steps from step t0 on inputs in[0 .. n) (and its skip source's spikes of the
  // same steps, skip[0 .. n), or null): out[j] gets the spikes it emits at step t0+j (out[0]:
  // those computed before, now_[k]); now_[k] then holds those of t0+n.
  void run_layer_block(size_t k, int64_t t0, const std::vector<uint32_t>* in,
                       const std::vector<uint32_t>* skip, size_t n,
                       std::vector<std::vector<uint32_t>>& out);
  // The layer tasks of the running round and its input.
  std::function<void(int)> round_task_;
  const std::vector<uint32_t>* round_in_ = nullptr;
  size_t round_n_ = 0;
  bool running_ = false;
  void sort_layers();  // order_: longest first
  // step_block() on one thread: per layer, the spikes it emits at each step of the block.
  std::vector<std::vector<std::vector<uint32_t>>> block_;
  // The pipeline (threads): per layer, the same for its last depth_[k] blocks (block b in
  // slot b mod depth_[k]), their step counts, and the step each layer is at. Round r: layer k
  // works on block r - k, reading block r - k of layer k-1 (made in round r - 1) and of its
  // skip source j (made in round r - (k - j)); layer j has written k - j blocks more since,
  // so it keeps depth_[j] = k - j + 1 slots (2 for the predecessor alone).
  std::vector<std::vector<std::vector<std::vector<uint32_t>>>> pipe_;
  std::vector<std::vector<size_t>> pipe_steps_;
  std::vector<int64_t> depth_;
  size_t slot(size_t k, int64_t block) const {
    const int64_t d = depth_[k];
    return size_t(((block % d) + d) % d);
  }
  std::vector<int64_t> layer_t_;
  int64_t round_ = 0;
  const std::vector<std::vector<uint32_t>>* ready_ = nullptr;
  std::vector<uint64_t> in_spikes_;
  std::vector<double> seconds_;  // per layer
  std::unique_ptr<TaskPool> pool_;
  std::vector<int> order_;  // layers by decreasing time so far, for the pool
  uint64_t pool_runs_ = 0;
  // The output gate. Outputs come later than their inputs in the pipeline, so the inputs' pixels
  // wait in gate_pending_ (step, output pixels) and enter gate_last_ (per output pixel, the
  // last step with an input event) only when the output of their step is gated.
  int gate_ = 0;
  FastDiv gate_div_c_;  // by the output's channels
  std::vector<int64_t> gate_last_;
  std::deque<std::pair<int64_t, std::vector<uint32_t>>> gate_pending_;
  std::vector<std::vector<uint32_t>> gate_spare_;  // buffers to reuse
  uint64_t gate_kept_ = 0, gate_removed_ = 0;
  void gate_record(const std::vector<uint32_t>* inputs, size_t n);  // steps taken_ ..
  void gate_outputs(std::vector<uint32_t>* outputs, size_t n);      // steps t_ .. t_+n-1
};

}  // namespace spikems
