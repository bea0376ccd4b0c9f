// Data-parallel training across processes and machines on LibTorch's own distributed layer
// (c10d): a TCPStore hosted by rank 0 for the rendezvous, a ProcessGroupGloo for the
// collectives (docs/training.md, "Data-parallel training").
//
// Launch like PyTorch's torchrun: MASTER_ADDR, MASTER_PORT, RANK, WORLD_SIZE (or the flags of
// the same names, which win). World size 1 is the plain single-process path: no store, no
// process group, every call below a no-op.
//
// Every collective is bounded by the timeout. A failed one (a peer died: its sockets close at
// once; or hung: the timeout expires) becomes a spikems::Error naming the rank that went
// missing, read from the step numbers the ranks post in the store, e.g.
//   rank 0: at step 3: rank 1 did not answer within 10 s (last seen at step 1): <c10d's words>
// The c10d types stay in distributed.cpp, so trainer.cpp needs none of its headers.
#pragma once

#include <torch/torch.h>

#include <memory>
#include <string>
#include <vector>

namespace spikems::train {

struct DistOptions {
  int rank = 0, world_size = 1;
  std::string master_addr;
  int master_port = 29500;  // torchrun's default
  double timeout_s = 300;   // bounds the rendezvous and every collective
};

// What the command line gave (unset: negative / empty), completed from the environment
// (MASTER_ADDR, MASTER_PORT, RANK, WORLD_SIZE). Throws Error for a bad or missing value.
struct DistFlags {
  int rank = -1, world_size = -1, master_port = -1;
  std::string master_addr;
  double timeout_s = -1;
};
DistOptions resolve_dist_options(const DistFlags& flags);

// True where this build has Gloo's headers (Debian: libgloo-dev). Without them world size 1
// works and more is refused with a message.
bool distributed_available();

class Distributed {
 public:
  // World size > 1: rendezvous through the store (rank 0 hosts it) and the Gloo process group.
  // Throws Error when a peer does not turn up within the timeout.
  explicit Distributed(const DistOptions& o);
  ~Distributed();
  Distributed(const Distributed&) = delete;
  Distributed& operator=(const Distributed&) = delete;

  int rank() const { return opt_.rank; }
  int world_size() const { return opt_.world_size; }
  bool active() const { return opt_.world_size > 1; }
  bool is_root() const { return opt_.rank == 0; }

  // Rank 0's parameters and buffers to every rank (the same starting point everywhere).
  void broadcast_module(torch::nn::Module& m);
  // Gradients summed over the ranks and divided by the world size: one all-reduce of one flat
  // tensor (every parameter with a gradient, in parameter order).
  void average_gradients(torch::nn::Module& m);
  // Every rank's `local` (same length everywhere) concatenated in rank order.
  std::vector<double> all_gather(const std::vector<double>& local);
  // Rank 0 finishes a task of its own (initialisation, validation) with root_done(name); the others
  // wait for it in wait_for_root(name), up to max(timeout, 1 h): a validation may outlast the
  // timeout, and a rank 0 that dies meanwhile is noticed at once (its store closes).
  void root_done(const std::string& name);
  void wait_for_root(const std::string& name);
  // The step this rank is working on, posted in the store so a failure can name who is behind.
  void set_step(int64_t step);
  // Posts this rank's error for the others' messages (best effort; the store may be gone).
  void report_failure(const std::string& message) noexcept;

 private:
  struct Impl;
  DistOptions opt_;
  int64_t step_ = 0;
  std::unique_ptr<Impl> impl_;
  [[noreturn]] void fail_collective(const std::string& what, const std::exception& e);
};

}  // namespace spikems::train
