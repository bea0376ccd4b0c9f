// Batches of samples made on background threads, so the network never waits for data.
// Batch k holds the samples drawn from the seeds (seed, k, 0..B-1) alone (sample.h,
// mix_seed): the data position of a run is just its step number, and a run resumed at step k
// sees the very batches an uninterrupted run sees. A data-parallel rank makes only its share
// of each global batch: samples first_sample .. first_sample + batch - 1. Whole-sensor batches
// (crop 0) of sequences from several sensor sizes hold one size each (batch_loader.cpp).
#pragma once

#include <condition_variable>
#include <cstdint>
#include <map>
#include <mutex>
#include <thread>
#include <vector>

#include "core/dataset/sample.h"

namespace spikems {

struct Batch {
  int64_t step = 0;
  std::vector<Sample> samples;
};

class BatchLoader {
 public:
  // `seqs` must outlive the loader. Workers start at once and stay up to `prefetch` batches
  // ahead of the consumer.
  BatchLoader(std::vector<const LabelledSequence*> seqs, std::vector<double> weights,
              SampleOptions opt, int batch, uint64_t seed, int64_t first_step, int prefetch,
              int threads = 1, int first_sample = 0);
  ~BatchLoader();
  BatchLoader(const BatchLoader&) = delete;
  BatchLoader& operator=(const BatchLoader&) = delete;

  // The next batch in step order (blocks until it is ready). Rethrows a worker's error.
  Batch next();

  // The batch of one step, made on the calling thread (the same as the workers make).
  static Batch make(const std::vector<const LabelledSequence*>& seqs,
                    const std::vector<double>& weights, const SampleOptions& opt, int batch,
                    uint64_t seed, int64_t step, int first_sample = 0);

 private:
  void work();
  std::vector<const LabelledSequence*> seqs_;
  std::vector<double> weights_;
  SampleOptions opt_;
  int batch_, first_sample_;
  uint64_t seed_;
  int prefetch_;
  std::mutex mu_;
  std::condition_variable cv_;
  int64_t next_claim_, next_take_;
  std::map<int64_t, Batch> ready_;
  std::exception_ptr error_;
  bool stop_ = false;
  std::vector<std::thread> workers_;
};

// A fixed validation set: `count` samples drawn without augmentation from (seed, stream
// "validation", i), so every validation pass of a run scores the same windows; ordered by
// size (stable) where the sequences' sensors differ.
std::vector<Sample> validation_samples(const std::vector<const LabelledSequence*>& seqs,
                                       const SampleOptions& opt, int count, uint64_t seed);

}  // namespace spikems
