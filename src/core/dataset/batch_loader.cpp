#include "core/dataset/batch_loader.h"

#include <algorithm>

namespace spikems {

BatchLoader::BatchLoader(std::vector<const LabelledSequence*> seqs, std::vector<double> weights,
                         SampleOptions opt, int batch, uint64_t seed, int64_t first_step,
                         int prefetch, int threads, int first_sample)
    : seqs_(std::move(seqs)),
      weights_(std::move(weights)),
      opt_(opt),
      batch_(batch),
      first_sample_(first_sample),
      seed_(seed),
      prefetch_(std::max(1, prefetch)),
      next_claim_(first_step),
      next_take_(first_step) {
  for (int i = 0; i < std::max(1, threads); ++i) workers_.emplace_back([this] { work(); });
}

BatchLoader::~BatchLoader() {
  {
    std::lock_guard<std::mutex> l(mu_);
    stop_ = true;
  }
  cv_.notify_all();
  for (auto& w : workers_) w.join();
}

Batch BatchLoader::make(const std::vector<const LabelledSequence*>& seqs,
                        const std::vector<double>& weights, const SampleOptions& opt, int batch,
                        uint64_t seed, int64_t step, int first_sample) {
  Batch b;
  b.step = step;
  // Whole-sensor samples of one batch must share a size (the network takes one tensor): where
  // the sequences come from several sensors, the global batch's first sample picks the size
  // (its sequence is the first draw of its own generator, which every rank can repeat) and the
  // others are drawn among the sequences of that size, by their weights. A sequence's share
  // of all samples is then what its weight gives, as without grouping.
  std::vector<double> same_size;
  if (opt.crop == 0 && !seqs.empty() &&
      std::any_of(seqs.begin(), seqs.end(), [&](const LabelledSequence* q) {
        return q->events.sensor.width != seqs[0]->events.sensor.width ||
               q->events.sensor.height != seqs[0]->events.sensor.height;
      })) {
    std::mt19937_64 first(mix_seed(seed, uint64_t(step), 0));
    const SensorSize z =
        seqs[std::discrete_distribution<size_t>(weights.begin(), weights.end())(first)]
            ->events.sensor;
    same_size = weights;
    for (size_t i = 0; i < seqs.size(); ++i)
      if (seqs[i]->events.sensor.width != z.width || seqs[i]->events.sensor.height != z.height)
        same_size[i] = 0;
  }
  for (int j = first_sample; j < first_sample + batch; ++j) {
    std::mt19937_64 rng(mix_seed(seed, uint64_t(step), uint64_t(j)));
    SampleSpec s = draw_sample(seqs, j == 0 || same_size.empty() ? weights : same_size, opt, rng);
    b.samples.push_back(extract_sample(*seqs[s.sequence], s, opt));
  }
  return b;
}

void BatchLoader::work() {
  while (true) {
    int64_t step;
    {
      std::unique_lock<std::mutex> l(mu_);
      cv_.wait(l, [&] { return stop_ || next_claim_ < next_take_ + prefetch_; });
      if (stop_) return;
      step = next_claim_++;
    }
    Batch b;
    std::exception_ptr err;
    try {
      b = make(seqs_, weights_, opt_, batch_, seed_, step, first_sample_);
    } catch (...) {
      err = std::current_exception();
    }
    {
      std::lock_guard<std::mutex> l(mu_);
      if (err && !error_) error_ = err;
      ready_[step] = std::move(b);
    }
    cv_.notify_all();
  }
}

Batch BatchLoader::next() {
  std::unique_lock<std::mutex> l(mu_);
  cv_.wait(l, [&] { return error_ || ready_.count(next_take_); });
  if (error_) std::rethrow_exception(error_);
  Batch b = std::move(ready_[next_take_]);
  ready_.erase(next_take_++);
  l.unlock();
  cv_.notify_all();
  return b;
}

std::vector<Sample> validation_samples(const std::vector<const LabelledSequence*>& seqs,
                                       const SampleOptions& opt, int count, uint64_t seed) {
  SampleOptions o = opt;
  o.flip_x = o.flip_y = o.polarity_swap = o.drop_max = o.threshold_jitter = o.noise_hz_max = 0;
  o.speed_max = 1;
  const std::vector<double> weights(seqs.size(), 1.0);
  std::vector<Sample> out;
  for (int i = 0; i < count; ++i) {
    std::mt19937_64 rng(mix_seed(seed, 0x7A11DA7Eull, uint64_t(i)));
    SampleSpec s = draw_sample(seqs, weights, o, rng);
    out.push_back(extract_sample(*seqs[s.sequence], s, o));
  }
  // Sensors of several sizes: samples of one size side by side, so that validation batches
  // hold one size where they can (to_tensors pads the rest); one size keeps the draw order.
  std::stable_sort(out.begin(), out.end(), [](const Sample& a, const Sample& b) {
    return std::pair{a.H, a.W} < std::pair{b.H, b.W};
  });
  return out;
}

}  // namespace spikems
