#include "cli/torch_helper.h"

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include "core/util/error.h"

namespace spikems::cli {

namespace fs = std::filesystem;

const TorchCommand& torch_command(const std::string& name) {
  for (const auto& c : kTorchCommands)
    if (name == c.name) return c;
  fail("spikems", "", "internal: '" + name + "' is not a LibTorch command");
}

bool is_torch_command(const char* name) {
  for (const auto& c : kTorchCommands)
    if (std::strcmp(name, c.name) == 0) return true;
  return false;
}

std::string find_torch_helper(std::string& looked) {
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  looked.clear();
  if (ec) {
    looked = "/proc/self/exe (unreadable)";
    return {};
  }
  const fs::path dir = exe.parent_path();
  for (const fs::path& p :
       {dir / "spikems-torch", dir.parent_path() / "lib/spikems/spikems-torch"}) {
    looked += (looked.empty() ? "" : ", ") + p.string();
    if (::access(p.c_str(), X_OK) == 0) return p.string();
  }
  return {};
}

void exec_torch_helper(char** argv) {
  std::string looked;
  const std::string helper = find_torch_helper(looked);
  if (helper.empty())
    fail("spikems " + std::string(argv[1]), "",
         "this command needs LibTorch and runs in the helper program spikems-torch, which is "
         "not installed (looked at: " +
             looked + "); build it with scripts/build (a build with -DSPIKEMS_WITH_TRAIN=ON)");
  std::fflush(nullptr);
  ::execv(helper.c_str(), argv);
  fail(helper, "", std::string("could not start it: ") + std::strerror(errno));
}

}  // namespace spikems::cli
