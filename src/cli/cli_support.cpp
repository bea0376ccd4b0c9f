// What every subcommand shares: the registry they add themselves to and the options and checks
// several of them use. Linked into both programs (spikems and its LibTorch helper, see
// torch_helper.h).
#include <fstream>
#include <string>

#include "cli/command.h"
#include "core/util/error.h"

namespace spikems::cli {

std::vector<CommandEntry>& command_registry() {
  static std::vector<CommandEntry> r;
  return r;
}

void add_read_flags(CLI::App* cmd, ReadFlags& f) {
  cmd->add_flag("--sort", f.sort, "Accept out-of-order timestamps and sort them (default: error)");
  cmd->add_option("--time-unit", f.time_unit, "Text input: unit of t (auto, s, us)")
      ->check(CLI::IsMember({"auto", "s", "us"}));
  cmd->add_option("--format", f.format, "Force the input format (see `spikems formats`)");
  cmd->add_option("--width", f.width, "Sensor width where the file does not say")
      ->check(CLI::Range(1, 65535));
  cmd->add_option("--height", f.height, "Sensor height where the file does not say")
      ->check(CLI::Range(1, 65535));
}

void check_split(const std::string& split) {
  if (split != "train" && split != "val" && split != "test" && split != "all")
    fail("--split", "", "'" + split + "' is not a split: use train, val, test or all");
}

// The command as typed (for the results' provenance), from /proc where there is one.
std::string invoked_command() {
  std::ifstream f("/proc/self/cmdline", std::ios::binary);
  std::string raw((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  std::string out, arg;
  auto flush = [&] {
    const bool plain = !arg.empty() && arg.find_first_of(" \t'\"\\$`") == std::string::npos;
    std::string q = plain ? arg : "'";
    if (!plain) {
      for (char c : arg) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
      q += "'";
    }
    out += (out.empty() ? "" : " ") + q;
    arg.clear();
  };
  for (char c : raw)
    if (c == 0)
      flush();
    else
      arg += c;
  return out.empty() ? "spikems" : out;
}

}  // namespace spikems::cli
