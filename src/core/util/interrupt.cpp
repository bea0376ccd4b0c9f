#include "core/util/interrupt.h"

#include <unistd.h>

#include <atomic>
#include <csignal>

namespace spikems {
namespace {
std::atomic<int> g_signals{0};
extern "C" void on_signal(int sig) {
  if (g_signals.fetch_add(1) >= 1) _exit(128 + sig);
}
}  // namespace

void install_interrupt_flag() {
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
}
bool interrupted() {
  return g_signals.load(std::memory_order_relaxed) > 0;
}

}  // namespace spikems
