// The `spikems` executable: one program, one subcommand per task (see `spikems --help`).
#include <algorithm>
#include <cstdio>
#include <fstream>
#include <iostream>

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

int main(int argc, char** argv) {
  using namespace spikems::cli;
  CLI::App app{
      "spikems: motion segmentation of event-camera streams with a spiking neural network"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "spikems " SPIKEMS_VERSION);  // project() version (CMake)
  auto& reg = command_registry();
  std::sort(reg.begin(), reg.end(), [](const CommandEntry& a, const CommandEntry& b) {
    return a.order != b.order ? a.order < b.order : a.name < b.name;
  });
  for (const auto& c : reg) c.add(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const spikems::Error& e) {
    std::fflush(stdout);
    std::cerr << "spikems: error: " << e.what() << "\n";
    return 1;
  } catch (const std::bad_alloc&) {
    std::cerr << "spikems: error: out of memory\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "spikems: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
