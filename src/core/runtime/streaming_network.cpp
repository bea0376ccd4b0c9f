#include "core/runtime/streaming_network.h"

#include <algorithm>
#include <chrono>

#include "core/util/error.h"

namespace spikems {

StreamingNetwork::StreamingNetwork(const ModelSpec& m, int height, int width)
    : h_(height), w_(width) {
  m.validate(m.name);
  if (m.layers.front().in_channels != 2)
    fail(m.name, "layer 0",
         "takes " + std::to_string(m.layers.front().in_channels) +
             " channels; the runtime feeds 2 (OFF, ON polarity)");
  int h = height, w = width;
  for (size_t k = 0; k < m.layers.size(); ++k) {
    const auto& l = m.layers[k];
    if (l.output_size(h) <= 0 || l.output_size(w) <= 0)
      fail(m.name, "layer " + std::to_string(k),
           "a " + std::to_string(width) + "x" + std::to_string(height) +
               " input is too small for this network");
    layers_.push_back(StreamingLayer::create(l, m.time_step_ms, h, w));
    layers_.back()->set_scattered_input(k == 0);  // the sensor's events, noise included
    h = layers_.back()->out_height();
    w = layers_.back()->out_width();
    if (size_t(h) * w * l.out_channels >= (size_t(1) << 32))
      fail(m.name, "layer " + std::to_string(k), "layer too large for 32-bit neuron indices");
  }
  emitted_.resize(layers_.size());
  now_.resize(layers_.size());
  ahead_.resize(layers_.size());
  in_spikes_.assign(layers_.size(), 0);
  seconds_.assign(layers_.size(), 0.0);
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

void TaskPool::run(int n, const std::function<void(int)>& task) {
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

const std::vector<uint32_t>& StreamingNetwork::step(const std::vector<uint32_t>& input) {
  const int L = int(layers_.size());
  auto run = [&](int k) {
    const std::vector<uint32_t>& in = k == 0 ? input : now_[size_t(k - 1)];
    ahead_[size_t(k)].clear();
    const auto t0 = std::chrono::steady_clock::now();
    layers_[size_t(k)]->step(t_, in.data(), in.size(), ahead_[size_t(k)]);
    seconds_[size_t(k)] +=
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  };
  if (pool_) {
    // Longest layers first, so that the last task claimed is a short one.
    if (order_.size() != size_t(L) || (t_ & 255) == 0) {
      order_.resize(size_t(L));
      for (int k = 0; k < L; ++k) order_[size_t(k)] = k;
      std::stable_sort(order_.begin(), order_.end(),
                       [&](int a, int b) { return seconds_[size_t(a)] > seconds_[size_t(b)]; });
    }
    pool_->run(L, [&](int i) { run(order_[size_t(i)]); });
  } else
    for (int k = 0; k < L; ++k) run(k);
  for (int k = 0; k < L; ++k)
    in_spikes_[size_t(k)] += (k == 0 ? input : now_[size_t(k - 1)]).size();
  emitted_.swap(now_);  // spikes of t
  now_.swap(ahead_);    // spikes of t+1; ahead_ holds buffers to reuse
  ++t_;
  return emitted_.back();
}

void StreamingNetwork::step_block(const std::vector<uint32_t>* inputs, size_t n) {
  const size_t L = layers_.size();
  block_.resize(L);
  for (auto& b : block_)
    if (b.size() < n + 1) b.resize(n + 1);
  if (pool_) {
    for (size_t j = 0; j < n; ++j) block_[L - 1][j] = step(inputs[j]);
    return;
  }
  for (size_t k = 0; k < L; ++k) {
    // Layer k emits at step t+j what it computed at t+j-1: now_[k] first, then its own output.
    std::vector<std::vector<uint32_t>>& out = block_[k];
    out[0].swap(now_[k]);
    const auto t0 = std::chrono::steady_clock::now();
    for (size_t j = 0; j < n; ++j) {
      const std::vector<uint32_t>& in = k == 0 ? inputs[j] : block_[k - 1][j];
      out[j + 1].clear();
      layers_[k]->step(t_ + int64_t(j), in.data(), in.size(), out[j + 1]);
      in_spikes_[k] += in.size();
    }
    seconds_[k] += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  for (size_t k = 0; k < L; ++k) {
    if (n > 0) emitted_[k] = block_[k][n - 1];
    now_[k].swap(block_[k][n]);
  }
  t_ += int64_t(n);
}

std::vector<LayerStats> StreamingNetwork::stats() const {
  std::vector<LayerStats> s(layers_.size());
  for (size_t k = 0; k < layers_.size(); ++k) {
    s[k].synops = layers_[k]->synops();
    s[k].in_spikes = in_spikes_[k];
    s[k].out_spikes = layers_[k]->spikes();
    s[k].neurons = layers_[k]->out_neurons();
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
