#include "core/runtime/streaming_network.h"

#include <algorithm>
#include <bit>
#include <chrono>
#include <tuple>

#include "core/util/error.h"

namespace spikems {

StreamingNetwork::StreamingNetwork(const ModelSpec& m, int height, int width, bool whole)
    : h_(height), w_(width), nh_(height), nw_(width) {
  m.validate(m.name);
  if (m.type != ModelType::SNN)
    fail(m.name, "",
         "is an ANN-2D baseline model: it works on whole event frames, not event by event; "
         "score it with `spikems eval`");
  if (m.layers.front().in_channels != 2)
    fail(m.name, "layer 0",
         "takes " + std::to_string(m.layers.front().in_channels) +
             " channels; the runtime feeds 2 (OFF, ON polarity)");
  if (m.has_skips() && height > 0 && width > 0) {
    // As the LibTorch network: padded at the bottom and right to the smallest size whose
    // skips meet their layers (check_input_size says why when none does).
    std::tie(nh_, nw_) = m.fitted_input_size(height, width);
    m.check_input_size(nh_, nw_, m.name);
  }
  // validate() has checked that every layer has the same onset.
  same_step_ = m.layers.front().neuron.srm_onset == SrmOnset::SameStep;
  // Every layer's input size, then (last layer first) the region of its output that can
  // reach an output pixel inside the sensor: the padding's neurons never run (unless asked).
  const size_t nl = m.layers.size();
  std::vector<int> hin(nl), win(nl);
  int h = nh_, w = nw_;
  for (size_t k = 0; k < nl; ++k) {
    const auto& l = m.layers[k];
    hin[k] = h;
    win[k] = w;
    if (l.output_size(h) <= 0 || l.output_size(w) <= 0)
      fail(m.name, "layer " + std::to_string(k),
           "a " + std::to_string(width) + "x" + std::to_string(height) +
               " input is too small for this network");
    h = l.output_size(h);
    w = l.output_size(w);
  }
  // Output pixel (y, x) is sensor pixel (y, x) when the strides cancel (the U-Net); another
  // scale keeps every output.
  double scale = 1;
  for (const auto& l : m.layers)
    scale = l.kind == LayerKind::Conv ? scale / l.stride : scale * l.stride;
  std::vector<int> need_h(nl, 0), need_w(nl, 0);
  need_h[nl - 1] = scale == 1 ? std::min(h, height) : h;
  need_w[nl - 1] = scale == 1 ? std::min(w, width) : w;
  for (size_t k = nl; k-- > 1;) {
    const auto& l = m.layers[k];
    const int nh = StreamingLayer::needed_inputs(l, hin[k], need_h[k]);
    const int nw = StreamingLayer::needed_inputs(l, win[k], need_w[k]);
    for (const int src : {int(k) - 1, l.skip_from}) {
      if (src < 0) continue;
      need_h[size_t(src)] = std::max(need_h[size_t(src)], nh);
      need_w[size_t(src)] = std::max(need_w[size_t(src)], nw);
    }
  }
  for (size_t k = 0; k < nl; ++k) {
    const auto& l = m.layers[k];
    layers_.push_back(StreamingLayer::create(l, m.time_step_ms, hin[k], win[k],
                                             whole ? -1 : need_h[k], whole ? -1 : need_w[k]));
    layers_.back()->set_scattered_input(k == 0);  // the sensor's events, noise included
    if (size_t(layers_.back()->out_height()) * layers_.back()->out_width() * l.out_channels >=
            (size_t(1) << 32) ||
        size_t(hin[k]) * win[k] * l.in_channels >=
            (size_t(1) << 32))  // the input, skip channels included
      fail(m.name, "layer " + std::to_string(k), "layer too large for 32-bit neuron indices");
  }
  const size_t L = layers_.size();
  map_.resize(L);
  depth_.assign(L, 2);
  for (size_t k = 1; k < L; ++k) {
    InputMap& im = map_[k];
    im.skip = m.layers[k].skip_from;
    if (im.skip < 0) continue;
    im.c_prev = uint32_t(m.layers[k - 1].out_channels);
    im.c_skip = uint32_t(m.layers[size_t(im.skip)].out_channels);
    im.div_prev = FastDiv(im.c_prev);
    im.div_skip = FastDiv(im.c_skip);
    depth_[size_t(im.skip)] = std::max(depth_[size_t(im.skip)], int64_t(k) - im.skip + 1);
  }
  remap_input_ = nw_ != w_;
  div_w_ = FastDiv(uint32_t(std::max(1, w_)));
  scratch_.resize(L);
  emitted_.resize(L);
  now_.resize(L);
  ahead_.resize(L);
  in_spikes_.assign(L, 0);
  seconds_.assign(L, 0.0);
  gate_ = m.output_gate_steps;
  if (gate_ > 0) {
    gate_div_c_ = FastDiv(uint32_t(out_channels()));
    // Far enough back that no step is within K of it.
    gate_last_.assign(size_t(out_height()) * size_t(out_width()),
                      -int64_t(kMaxOutputGateSteps) - 1);
  }
}

void StreamingNetwork::gate_record(const std::vector<uint32_t>* inputs, size_t n) {
  if (gate_ <= 0) return;
  const uint32_t w = uint32_t(w_), ho = uint32_t(out_height()), wo = uint32_t(out_width());
  for (size_t j = 0; j < n; ++j) {
    std::vector<uint32_t> px;
    if (!gate_spare_.empty()) {
      px.swap(gate_spare_.back());
      gate_spare_.pop_back();
    }
    px.clear();
    for (const uint32_t i : inputs[j]) {
      const uint32_t pos = i >> 1, y = div_w_(pos), x = pos - y * w;
      if (y < ho && x < wo) px.push_back(y * wo + x);
    }
    gate_pending_.emplace_back(taken_ + int64_t(j), std::move(px));
  }
}

void StreamingNetwork::gate_outputs(std::vector<uint32_t>* outputs, size_t n) {
  if (gate_ <= 0) return;
  for (size_t j = 0; j < n; ++j) {
    const int64_t s = t_ + int64_t(j);
    while (!gate_pending_.empty() && gate_pending_.front().first <= s) {
      for (const uint32_t p : gate_pending_.front().second)
        gate_last_[p] = gate_pending_.front().first;
      gate_spare_.push_back(std::move(gate_pending_.front().second));
      gate_pending_.pop_front();
    }
    std::vector<uint32_t>& o = outputs[j];
    size_t kept = 0;
    for (const uint32_t i : o)
      if (s - gate_last_[gate_div_c_(i)] < gate_) o[kept++] = i;
    gate_kept_ += kept;
    gate_removed_ += o.size() - kept;
    o.resize(kept);
  }
}

const std::vector<uint32_t>& StreamingNetwork::input_of(size_t k, const std::vector<uint32_t>& a,
                                                        const std::vector<uint32_t>* b,
                                                        std::vector<uint32_t>& buf) const {
  if (k == 0) {
    if (!remap_input_) return a;
    // (y*w + x)*2 + p -> (y*nw + x)*2 + p: monotone, so the order is kept.
    buf.resize(a.size());
    const uint32_t w = uint32_t(w_), nw = uint32_t(nw_);
    for (size_t i = 0; i < a.size(); ++i) {
      const uint32_t pos = a[i] >> 1, y = div_w_(pos);
      buf[i] = ((y * nw + (pos - y * w)) << 1) | (a[i] & 1u);
    }
    return buf;
  }
  const InputMap& im = map_[k];
  if (im.skip < 0) return a;
  // Concatenated channels: (pos*C_prev + c) -> pos*C + c and (pos*C_skip + c) ->
  // pos*C + C_prev + c, C = C_prev + C_skip. The layers group the spikes of a position, and
  // sum them in list order, so the result is kept ascending: a merge by position when both
  // sources are ascending (the IIR layers' output), else a sort (the FIR ring's output comes
  // in its timing wheel's order).
  const uint32_t cp = im.c_prev, cs = im.c_skip, c = cp + cs;
  buf.resize(a.size() + b->size());
  auto from_a = [&](uint32_t n) {
    const uint32_t pos = im.div_prev(n);
    return pos * c + (n - pos * cp);
  };
  auto from_b = [&](uint32_t n) {
    const uint32_t pos = im.div_skip(n);
    return pos * c + cp + (n - pos * cs);
  };
  if (std::is_sorted(a.begin(), a.end()) && std::is_sorted(b->begin(), b->end())) {
    // Both lists mapped first (independent operations), then merged branch-free with a
    // sentinel ending each: which list comes next is a coin toss for the predictor, and
    // mapping inside the merge put a division on its serial chain (measured: the branching
    // merge was ~10 % of the runtime of a six-level model at 1.9 M ev/s).
    const size_t na = a.size(), nb = b->size();
    thread_local std::vector<uint32_t> ma, mb;  // per thread: layers may run in parallel
    ma.resize(na + 1);
    mb.resize(nb + 1);
    for (size_t i = 0; i < na; ++i) ma[i] = from_a(a[i]);
    for (size_t j = 0; j < nb; ++j) mb[j] = from_b((*b)[j]);
    ma[na] = mb[nb] = ~uint32_t(0);  // above every neuron index (they are < 2^32 - 1)
    const uint32_t* __restrict pa = ma.data();
    const uint32_t* __restrict pb = mb.data();
    uint32_t* __restrict out = buf.data();
    size_t i = 0, j = 0;
    for (size_t o = 0; o < na + nb; ++o) {
      const uint32_t x = pa[i], y = pb[j];
      const bool take_a = x < y;
      out[o] = take_a ? x : y;
      i += take_a;
      j += !take_a;
    }
  } else {
    for (size_t i = 0; i < a.size(); ++i) buf[i] = from_a(a[i]);
    for (size_t j = 0; j < b->size(); ++j) buf[a.size() + j] = from_b((*b)[j]);
    std::sort(buf.begin(), buf.end());
  }
  return buf;
}

void StreamingNetwork::layer_input(size_t k, const std::vector<uint32_t>& net_input,
                                   std::vector<uint32_t>& out) const {
  const int skip = map_[k].skip;
  const std::vector<uint32_t>& in = input_of(k, k == 0 ? net_input : emitted_[k - 1],
                                             skip >= 0 ? &emitted_[size_t(skip)] : nullptr, out);
  if (&in != &out) out = in;
}

namespace {
// About 0.2-0.5 ms of spinning (a pause is ~10-60 cycles) before a thread sleeps.
constexpr int kSpins = 20000;
inline void cpu_relax() {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_ia32_pause();
#endif
}
}  // namespace

TaskPool::TaskPool(int threads) {
  // Spinning only pays when every thread has a core of its own; otherwise a spinning thread
  // takes the core of the one it waits for.
  const unsigned cores = std::thread::hardware_concurrency();
  spins_ = cores == 0 || unsigned(threads) <= cores ? kSpins : 0;
  for (int i = 1; i < threads; ++i)
    workers_.emplace_back([this] {
      uint64_t seen = 0;
      while (true) {
        for (int s = 0; s < spins_ && generation_.load(std::memory_order_acquire) == seen &&
                        !stop_.load(std::memory_order_relaxed);
             ++s)
          cpu_relax();
        if (generation_.load(std::memory_order_acquire) == seen) {
          std::unique_lock<std::mutex> lk(mu_);
          start_cv_.wait(lk, [&] {
            return stop_.load(std::memory_order_relaxed) ||
                   generation_.load(std::memory_order_acquire) != seen;
          });
        }
        if (stop_.load(std::memory_order_relaxed)) return;
        seen = generation_.load(std::memory_order_acquire);
        work();
        if (remaining_.fetch_sub(1, std::memory_order_acq_rel) == 1) {
          std::lock_guard<std::mutex> lk(mu_);  // the caller checks under the lock: no lost wake-up
          done_cv_.notify_one();
        }
      }
    });
}

TaskPool::~TaskPool() {
  {
    std::lock_guard<std::mutex> lk(mu_);
    stop_ = true;
  }
  start_cv_.notify_all();
  for (auto& t : workers_) t.join();
}

void TaskPool::work() {
  for (int i = next_.fetch_add(1); i < ntasks_; i = next_.fetch_add(1)) (*task_)(i);
}

void TaskPool::start(int n, const std::function<void(int)>& task) {
  task_ = &task;
  ntasks_ = n;
  next_ = 0;
  remaining_.store(int(workers_.size()), std::memory_order_relaxed);
  {
    // Under the lock, so that a worker between its check and its wait cannot miss it; the
    // release publishes the task to the spinning workers.
    std::lock_guard<std::mutex> lk(mu_);
    generation_.fetch_add(1, std::memory_order_release);
  }
  start_cv_.notify_all();
}

void TaskPool::wait() {
  work();
  for (int s = 0; s < spins_ && remaining_.load(std::memory_order_acquire) != 0; ++s) cpu_relax();
  if (remaining_.load(std::memory_order_acquire) != 0) {
    std::unique_lock<std::mutex> lk(mu_);
    done_cv_.wait(lk, [&] { return remaining_.load(std::memory_order_acquire) == 0; });
  }
}

void StreamingNetwork::set_threads(int n) {
  n = std::max(1, std::min(n, int(layers_.size())));
  if (n == 1)
    pool_.reset();
  else
    pool_ = std::make_unique<TaskPool>(n);
}

void StreamingNetwork::sort_layers() {
  // Longest layers first (by their time so far), so that the last task claimed is a short
  // one; sorted again after 1, 2, 4, ... runs, then every 1024.
  const int L = int(layers_.size());
  if (order_.size() != size_t(L) || std::has_single_bit(pool_runs_) || pool_runs_ % 1024 == 0) {
    order_.resize(size_t(L));
    for (int k = 0; k < L; ++k) order_[size_t(k)] = k;
    std::stable_sort(order_.begin(), order_.end(),
                     [&](int a, int b) { return seconds_[size_t(a)] > seconds_[size_t(b)]; });
  }
  ++pool_runs_;
}

const std::vector<uint32_t>& StreamingNetwork::step(const std::vector<uint32_t>& input) {
  if (in_flight()) fail("streaming network", "", "step() while blocks are in flight");
  gate_record(&input, 1);
  const int L = int(layers_.size());
  // Layer k from its sources' spikes `from` (of step t) into `to`.
  auto run = [&](int k, const std::vector<std::vector<uint32_t>>& from, std::vector<uint32_t>& to) {
    const int skip = map_[size_t(k)].skip;
    const std::vector<uint32_t>& in =
        input_of(size_t(k), k == 0 ? input : from[size_t(k - 1)],
                 skip >= 0 ? &from[size_t(skip)] : nullptr, scratch_[size_t(k)]);
    to.clear();
    const auto t0 = std::chrono::steady_clock::now();
    layers_[size_t(k)]->step(t_, in.data(), in.size(), to);
    seconds_[size_t(k)] +=
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    in_spikes_[size_t(k)] += in.size();
  };
  if (same_step_) {
    // Layer k takes layer k-1's spikes of this very step: one after another, no threads.
    for (int k = 0; k < L; ++k) run(k, emitted_, emitted_[size_t(k)]);
  } else {
    // Each layer reads the spikes of t its sources made the step before (now_) and writes
    // its own of t+1: independent, so the layers may run in parallel.
    if (pool_) {
      sort_layers();
      pool_->run(L,
                 [&](int i) { run(order_[size_t(i)], now_, ahead_[size_t(order_[size_t(i)])]); });
    } else
      for (int k = 0; k < L; ++k) run(k, now_, ahead_[size_t(k)]);
    emitted_.swap(now_);  // spikes of t
    now_.swap(ahead_);    // spikes of t+1; ahead_ holds buffers to reuse
  }
  gate_outputs(&emitted_.back(), 1);
  ++t_;
  ++taken_;
  return emitted_.back();
}

void StreamingNetwork::run_layer_block(size_t k, int64_t t0, const std::vector<uint32_t>* in,
                                       const std::vector<uint32_t>* skip, size_t n,
                                       std::vector<std::vector<uint32_t>>& out) {
  if (out.size() < n) out.resize(n);
  if (n == 0) return;
  // Next-step neurons: out[0] gets the spikes of t0 computed before and step t0 + j writes
  // those of t0 + j + 1 (the last into now_[k]); same-step neurons write those of t0 + j.
  if (!same_step_) out[0].swap(now_[k]);
  const auto c0 = std::chrono::steady_clock::now();
  for (size_t j = 0; j < n; ++j) {
    std::vector<uint32_t>& dst = same_step_ ? out[j] : j + 1 < n ? out[j + 1] : now_[k];
    dst.clear();
    const std::vector<uint32_t>& x = input_of(k, in[j], skip ? &skip[j] : nullptr, scratch_[k]);
    layers_[k]->step(t0 + int64_t(j), x.data(), x.size(), dst);
    in_spikes_[k] += x.size();
  }
  seconds_[k] += std::chrono::duration<double>(std::chrono::steady_clock::now() - c0).count();
  emitted_[k] = out[n - 1];
}

size_t StreamingNetwork::step_block(const std::vector<uint32_t>* inputs, size_t n) {
  const size_t L = layers_.size();
  if (pipelined(n)) {
    start_block(inputs, n);
    return finish_block();
  }
  block_.resize(L);
  if (pool_) {  // one step, layers in parallel
    if (n == 0) return 0;
    block_[L - 1].resize(1);
    block_[L - 1][0] = step(inputs[0]);
  } else {
    gate_record(inputs, n);
    for (size_t k = 0; k < L; ++k) {
      const int skip = map_[k].skip;
      run_layer_block(k, t_, k == 0 ? inputs : block_[k - 1].data(),
                      skip >= 0 ? block_[size_t(skip)].data() : nullptr, n, block_[k]);
    }
    if (gate_ > 0 && n > 0) {
      gate_outputs(block_[L - 1].data(), n);
      emitted_[L - 1] = block_[L - 1][n - 1];
    }
    t_ += int64_t(n);
    taken_ += int64_t(n);
  }
  ready_ = &block_[L - 1];
  return n;
}

void StreamingNetwork::start_block(const std::vector<uint32_t>* inputs, size_t n) {
  if (!pool_ || running_) fail("streaming network", "", "start_block() without threads or twice");
  const int L = int(layers_.size());
  if (pipe_.size() != size_t(L)) {
    pipe_.resize(size_t(L));
    pipe_steps_.resize(size_t(L));
    for (int k = 0; k < L; ++k) {
      pipe_[size_t(k)].resize(size_t(depth_[size_t(k)]));
      pipe_steps_[size_t(k)].resize(size_t(depth_[size_t(k)]));
    }
    layer_t_.resize(size_t(L));
  }
  if (!in_flight()) {
    // A fresh pipeline: every layer at the network's step, no block left from an earlier one.
    for (int k = 0; k < L; ++k) {
      layer_t_[size_t(k)] = t_;
      std::fill(pipe_steps_[size_t(k)].begin(), pipe_steps_[size_t(k)].end(), size_t(0));
    }
  }
  round_in_ = inputs;
  round_n_ = n;
  if (!round_task_)
    round_task_ = [this](int i) {
      // Round r: layer k runs block r - k, on what layer k-1 made of it in round r - 1 (and
      // its skip source j in round r - (k - j)).
      const size_t k = size_t(order_[size_t(i)]);
      const int64_t b = round_ - int64_t(k);
      const size_t nb = k == 0 ? round_n_ : pipe_steps_[k - 1][slot(k - 1, b)];
      const std::vector<uint32_t>* in = k == 0 ? round_in_ : pipe_[k - 1][slot(k - 1, b)].data();
      const int skip = map_[k].skip;
      const std::vector<uint32_t>* sk =
          skip >= 0 ? pipe_[size_t(skip)][slot(size_t(skip), b)].data() : nullptr;
      run_layer_block(k, layer_t_[k], in, sk, nb, pipe_[k][slot(k, b)]);
      pipe_steps_[k][slot(k, b)] = nb;
      layer_t_[k] += int64_t(nb);
    };
  sort_layers();
  gate_record(inputs, n);
  taken_ += int64_t(n);
  running_ = true;
  pool_->start(L, round_task_);
}

size_t StreamingNetwork::finish_block() {
  if (!running_) return 0;
  pool_->wait();
  running_ = false;
  const size_t L = layers_.size();
  // The block the output layer just ran (round r: block r - (L-1)); none while filling.
  const size_t s = slot(L - 1, round_ - int64_t(L - 1));
  ++round_;
  const size_t ready = pipe_steps_[L - 1][s];
  ready_ = &pipe_[L - 1][s];
  if (gate_ > 0 && ready > 0) {
    gate_outputs(pipe_[L - 1][s].data(), ready);
    emitted_[L - 1] = pipe_[L - 1][s][ready - 1];
  }
  t_ += int64_t(ready);
  return ready;
}

std::vector<LayerStats> StreamingNetwork::stats() const {
  std::vector<LayerStats> s(layers_.size());
  for (size_t k = 0; k < layers_.size(); ++k) {
    s[k].synops = layers_[k]->synops();
    s[k].in_spikes = in_spikes_[k];
    s[k].out_spikes = layers_[k]->spikes();
    s[k].neurons = layers_[k]->running_neurons();
    s[k].seconds = seconds_[k];
    s[k].visits = layers_[k]->visits();
  }
  return s;
}

uint64_t StreamingNetwork::total_synops() const {
  uint64_t n = 0;
  for (const auto& l : layers_) n += l->synops();
  return n;
}

}  // namespace spikems
