#include "train/trainer/distributed.h"

#include <cerrno>
#include <csignal>
#include <cstdlib>
#include <limits>

#include "core/util/error.h"

// Debian's LibTorch 1.13 and PyTorch 2.x both ship c10d's headers; Gloo's own headers come
// from libgloo-dev (Debian) or the wheel's include/ folder. ProcessGroupGloo.hpp declares its
// class only under USE_C10D_GLOO, which LibTorch's CMake config does not export.
#if __has_include(<gloo/context.h>) && \
    __has_include(<torch/csrc/distributed/c10d/ProcessGroupGloo.hpp>)
#ifndef USE_C10D_GLOO
#define USE_C10D_GLOO
#endif
#include <torch/csrc/distributed/c10d/PrefixStore.hpp>
#include <torch/csrc/distributed/c10d/ProcessGroupGloo.hpp>
#include <torch/csrc/distributed/c10d/TCPStore.hpp>
#define SPIKEMS_HAVE_GLOO 1
#else
#define SPIKEMS_HAVE_GLOO 0
#endif

namespace spikems::train {

namespace {

// An integer environment variable or flag value; `fallback` when unset.
int env_int(const char* name, int flag, int fallback) {
  if (flag >= 0) return flag;
  const char* v = std::getenv(name);
  if (!v || !*v) return fallback;
  char* end = nullptr;
  errno = 0;
  const long x = std::strtol(v, &end, 10);
  if (*end != '\0' || errno || x < 0 || x > std::numeric_limits<int>::max())
    fail(std::string("environment variable ") + name, "",
         "'" + std::string(v) + "' is not a non-negative integer");
  return int(x);
}

// The first line of an exception's message, without c10's backtrace.
std::string short_message(const std::exception& e) {
  std::string m = e.what();
  if (const auto* ce = dynamic_cast<const c10::Error*>(&e)) m = ce->what_without_backtrace();
  const size_t nl = m.find('\n');
  if (nl != std::string::npos) m.resize(nl);
  return m;
}

bool contains(const std::string& s, const char* part) {
  return s.find(part) != std::string::npos;
}

std::string seconds(double s) {
  char b[32];
  std::snprintf(b, sizeof b, "%g s", s);
  return b;
}

}  // namespace

DistOptions resolve_dist_options(const DistFlags& f) {
  DistOptions o;
  o.world_size = env_int("WORLD_SIZE", f.world_size, 1);
  if (o.world_size < 1) fail("spikems train", "", "the world size must be at least 1");
  o.rank = env_int("RANK", f.rank, o.world_size > 1 ? -1 : 0);
  o.master_port = env_int("MASTER_PORT", f.master_port, 29500);
  o.master_addr = f.master_addr;
  if (o.master_addr.empty() && std::getenv("MASTER_ADDR"))
    o.master_addr = std::getenv("MASTER_ADDR");
  o.timeout_s = f.timeout_s > 0 ? f.timeout_s : 300;
  if (o.rank < 0)
    fail("spikems train", "",
         "world size " + std::to_string(o.world_size) +
             " needs this process's rank: set RANK or --rank (0 .. " +
             std::to_string(o.world_size - 1) + ")");
  if (o.rank >= o.world_size)
    fail("spikems train", "",
         "rank " + std::to_string(o.rank) + " is outside 0 .. " + std::to_string(o.world_size - 1) +
             " for world size " + std::to_string(o.world_size));
  if (o.world_size > 1 && o.master_addr.empty())
    fail("spikems train", "",
         "world size " + std::to_string(o.world_size) +
             " needs rank 0's address: set MASTER_ADDR or --master-addr");
  if (o.master_port < 1 || o.master_port > 65535)
    fail("spikems train", "",
         "the master port " + std::to_string(o.master_port) + " is outside 1 .. 65535");
  if (o.world_size > 1 && !distributed_available())
    fail("spikems train", "",
         "this build has no Gloo headers (install libgloo-dev and rebuild): world size " +
             std::to_string(o.world_size) + " is not available");
  return o;
}

bool distributed_available() {
  return SPIKEMS_HAVE_GLOO;
}

#if SPIKEMS_HAVE_GLOO

struct Distributed::Impl {
  c10::intrusive_ptr<c10d::TCPStore> store;
  c10::intrusive_ptr<c10d::ProcessGroupGloo> pg;
  std::chrono::milliseconds timeout{0};
};

Distributed::Distributed(const DistOptions& o) : opt_(o) {
  if (!active()) return;
  // A peer's closed socket must surface as an error of the write, not kill this process.
  std::signal(SIGPIPE, SIG_IGN);
  impl_ = std::make_unique<Impl>();
  impl_->timeout =
      std::chrono::milliseconds(int64_t(std::llround(std::max(0.001, o.timeout_s) * 1000)));
  const std::string where = o.master_addr + ":" + std::to_string(o.master_port);
  try {
    c10d::TCPStoreOptions so;
    so.port = uint16_t(o.master_port);
    so.isServer = o.rank == 0;
    so.numWorkers = size_t(o.world_size);
    so.waitWorkers = true;  // rank 0 waits until every rank has connected
    so.timeout = impl_->timeout;
    impl_->store = c10::make_intrusive<c10d::TCPStore>(o.master_addr, so);
  } catch (const std::exception& e) {
    fail("rank " + std::to_string(o.rank), "rendezvous",
         (o.rank == 0
              ? "cannot host the store on port " + std::to_string(o.master_port) +
                    ", or not every rank connected within " + seconds(o.timeout_s)
              : "could not reach rank 0's store at " + where + " within " + seconds(o.timeout_s)) +
             ": " + short_message(e));
  }
  try {
    auto po = c10d::ProcessGroupGloo::Options::create(impl_->timeout);
    // GLOO_SOCKET_IFNAME picks the network interface, as in PyTorch.
    const char* ifname = std::getenv("GLOO_SOCKET_IFNAME");
    po->devices.push_back(ifname && *ifname
                              ? c10d::ProcessGroupGloo::createDeviceForInterface(ifname)
                              : c10d::ProcessGroupGloo::createDefaultDevice());
    auto prefixed = c10::make_intrusive<c10d::PrefixStore>("gloo", impl_->store);
    impl_->pg = c10::make_intrusive<c10d::ProcessGroupGloo>(prefixed, o.rank, o.world_size, po);
  } catch (const std::exception& e) {
    fail("rank " + std::to_string(o.rank), "rendezvous",
         "the Gloo process group did not form within " + seconds(o.timeout_s) + ": " +
             short_message(e));
  }
  set_step(0);
}

Distributed::~Distributed() = default;

void Distributed::fail_collective(const std::string& what, const std::exception& e) {
  const std::string raw = short_message(e);
  const bool timed_out = contains(raw, "imed out") || contains(raw, "imeout");
  // Who is behind: ranks that posted an error, or whose posted step is below ours.
  std::string who;
  bool store_gone = false;
  for (int r = 0; r < opt_.world_size && !store_gone; ++r) {
    if (r == opt_.rank) continue;
    try {
      const std::string fk = "spikems/failed/" + std::to_string(r);
      if (impl_->store->check({fk})) {
        const auto v = impl_->store->get(fk);
        who += (who.empty() ? "" : "; ") + ("rank " + std::to_string(r) + " stopped: ") +
               std::string(v.begin(), v.end());
        continue;
      }
      const std::string sk = "spikems/step/" + std::to_string(r);
      int64_t s = -1;  // never posted: it did not reach the first step
      if (impl_->store->check({sk})) {
        const auto v = impl_->store->get(sk);
        s = std::stoll(std::string(v.begin(), v.end()));
      }
      if (s < step_)
        who += (who.empty() ? "" : "; ") +
               ("rank " + std::to_string(r) +
                (timed_out ? " did not answer within " + seconds(opt_.timeout_s)
                           : " is gone (died or was killed)") +
                ", last seen at step " + std::to_string(s));
    } catch (const std::exception&) {
      store_gone = true;  // the store lives in rank 0: it is gone
    }
  }
  if (store_gone && opt_.rank != 0)
    who = "rank 0 (which hosts the store) is gone (died or was killed)";
  if (who.empty())
    who = timed_out ? "a rank did not answer within " + seconds(opt_.timeout_s)
                    : "a rank left (died or was killed)";
  fail("rank " + std::to_string(opt_.rank), "step " + std::to_string(step_),
       who + " [" + what + ": " + raw + "]");
}

void Distributed::broadcast_module(torch::nn::Module& m) {
  if (!active()) return;
  torch::NoGradGuard ng;
  std::vector<torch::Tensor> all = m.parameters();
  for (const auto& b : m.buffers()) all.push_back(b);
  try {
    for (auto& t : all) {
      // A contiguous CPU copy travels; the result is copied back into the live tensor.
      std::vector<at::Tensor> v{t.detach().to(torch::kCPU).contiguous()};
      c10d::BroadcastOptions bo;
      bo.rootRank = 0;
      impl_->pg->broadcast(v, bo)->wait();
      t.copy_(v[0]);
    }
  } catch (const std::exception& e) {
    fail_collective("broadcast of the initial parameters", e);
  }
}

void Distributed::average_gradients(torch::nn::Module& m) {
  if (!active()) return;
  torch::NoGradGuard ng;
  std::vector<torch::Tensor> grads;
  for (const auto& p : m.parameters())
    if (p.grad().defined()) grads.push_back(p.grad());
  if (grads.empty()) return;
  std::vector<torch::Tensor> flat_parts;
  for (const auto& g : grads) flat_parts.push_back(g.reshape(-1).to(torch::kCPU));
  std::vector<at::Tensor> v{torch::cat(flat_parts)};
  try {
    impl_->pg->allreduce(v)->wait();  // sum
  } catch (const std::exception& e) {
    fail_collective("all-reduce of the gradients", e);
  }
  v[0].div_(double(opt_.world_size));
  int64_t off = 0;
  for (auto& g : grads) {
    g.copy_(v[0].narrow(0, off, g.numel()).view(g.sizes()));
    off += g.numel();
  }
}

std::vector<double> Distributed::all_gather(const std::vector<double>& local) {
  if (!active()) return local;
  std::vector<at::Tensor> in{
      torch::from_blob(const_cast<double*>(local.data()), {int64_t(local.size())}, torch::kFloat64)
          .clone()};
  std::vector<std::vector<at::Tensor>> out(1);
  for (int r = 0; r < opt_.world_size; ++r) out[0].push_back(torch::empty_like(in[0]));
  try {
    impl_->pg->allgather(out, in)->wait();
  } catch (const std::exception& e) {
    fail_collective("all-gather of the step's statistics", e);
  }
  std::vector<double> all;
  for (const auto& t : out[0]) {
    const double* p = t.data_ptr<double>();
    all.insert(all.end(), p, p + t.numel());
  }
  return all;
}

void Distributed::root_done(const std::string& name) {
  if (!active() || !is_root()) return;
  try {
    impl_->store->set("spikems/" + name, std::vector<uint8_t>{1});
  } catch (const std::exception& e) {
    fail_collective("store", e);
  }
}

void Distributed::wait_for_root(const std::string& name) {
  if (!active() || is_root()) return;
  const auto wait = std::max(impl_->timeout, std::chrono::milliseconds(3600 * 1000));
  try {
    impl_->store->wait({"spikems/" + name}, wait);
  } catch (const std::exception& e) {
    fail_collective("waiting for rank 0's " + name, e);
  }
}

void Distributed::set_step(int64_t step) {
  step_ = step;
  if (!active()) return;
  const std::string s = std::to_string(step);
  try {
    impl_->store->set("spikems/step/" + std::to_string(opt_.rank),
                      std::vector<uint8_t>(s.begin(), s.end()));
  } catch (const std::exception& e) {
    fail_collective("store", e);
  }
}

void Distributed::report_failure(const std::string& message) noexcept {
  if (!active() || !impl_) return;
  try {
    impl_->store->set("spikems/failed/" + std::to_string(opt_.rank),
                      std::vector<uint8_t>(message.begin(), message.end()));
  } catch (...) {
  }
}

#else  // no Gloo headers: only world size 1 (resolve_dist_options refuses more)

struct Distributed::Impl {};
Distributed::Distributed(const DistOptions& o) : opt_(o) {}
Distributed::~Distributed() = default;
void Distributed::fail_collective(const std::string& what, const std::exception& e) {
  fail("rank " + std::to_string(opt_.rank), what, e.what());
}
void Distributed::broadcast_module(torch::nn::Module&) {}
void Distributed::average_gradients(torch::nn::Module&) {}
std::vector<double> Distributed::all_gather(const std::vector<double>& local) {
  return local;
}
void Distributed::root_done(const std::string&) {}
void Distributed::wait_for_root(const std::string&) {}
void Distributed::set_step(int64_t step) {
  step_ = step;
}
void Distributed::report_failure(const std::string&) noexcept {}

#endif

}  // namespace spikems::train
