// The `spikems` executable: one program, one subcommand per task (see `spikems --help`).
// Compiled twice: into `spikems` (every command without LibTorch; the LibTorch ones are handed
// to the helper, torch_helper.h) and, with SPIKEMS_TORCH_HELPER, into `spikems-torch`.
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <string_view>

#include "cli/command.h"
#include "cli/torch_helper.h"
#include "core/util/error.h"
#include "spikems/version.h"

#ifndef SPIKEMS_TORCH_HELPER
#define SPIKEMS_TORCH_HELPER 0  // 1: this is spikems-torch
#endif
#ifndef SPIKEMS_HAS_TORCH_HELPER
#define SPIKEMS_HAS_TORCH_HELPER 0  // 1: spikems, built with the helper beside it
#endif

namespace {

// Runs `body`, turning spikems' errors into "spikems: error: ..." and exit code 1.
template <class F>
int guarded(F&& body) {
  try {
    return body();
  } catch (const spikems::Error& e) {
    std::fflush(stdout);
    std::cerr << "spikems: error: " << e.what() << "\n";
  } catch (const std::bad_alloc&) {
    std::cerr << "spikems: error: out of memory\n";
  } catch (const std::exception& e) {
    std::cerr << "spikems: error: " << e.what() << "\n";
  }
  return 1;
}

// SPIKEMS_PARSE_ONLY=1: parse and check the command line (option names, value types, ranges)
// and exit without running anything. Files named on it need not exist, so that documented
// examples can be checked without their data (tests/docs).
bool parse_only_requested() {
  const char* v = std::getenv("SPIKEMS_PARSE_ONLY");
  return v != nullptr && std::string_view(v) == "1";
}

void make_parse_only(CLI::App& app) {
  for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) {
    sub->callback([] {});
    // CLI11's path checks have no name, only a description: FILE, DIR, PATH(existing).
    for (CLI::Option* opt : sub->get_options([](CLI::Option*) { return true; })) {
      for (int i = 0;; ++i) {
        CLI::Validator* v = nullptr;
        try {
          v = opt->get_validator(i);
        } catch (const CLI::OptionNotFound&) {
          break;
        }
        const std::string d = v->get_description();
        if (d == "FILE" || d == "DIR" || d == "PATH(existing)") v->active(false);
      }
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  using namespace spikems::cli;
#if SPIKEMS_TORCH_HELPER
  CLI::App app{"spikems-torch: the LibTorch commands of spikems (run them as `spikems NAME`)"};
#else
  // No global options take values, so the subcommand is argv[1].
  if (SPIKEMS_HAS_TORCH_HELPER && argc > 1 && is_torch_command(argv[1]))
    return guarded([&]() -> int { exec_torch_helper(argv); });
  CLI::App app{
      "spikems: motion segmentation of event-camera streams with a spiking neural network"};
#endif
  app.require_subcommand(1);
  app.set_version_flag("--version", "spikems " SPIKEMS_VERSION);  // project() version (CMake)
  auto& reg = command_registry();
  std::sort(reg.begin(), reg.end(), [](const CommandEntry& a, const CommandEntry& b) {
    return a.order != b.order ? a.order < b.order : a.name < b.name;
  });
  // `spikems --help` lists the helper's commands in their places, by name and description only
  // (they are never parsed here).
  constexpr bool kStubs = !SPIKEMS_TORCH_HELPER && SPIKEMS_HAS_TORCH_HELPER;
  size_t stub = 0;
  auto add_stubs_before = [&](int order) {
    for (; kStubs && stub < std::size(kTorchCommands) && kTorchCommands[stub].order < order; ++stub)
      app.add_subcommand(kTorchCommands[stub].name, kTorchCommands[stub].description);
  };
  for (const auto& c : reg) {
    add_stubs_before(c.order);
    c.add(app);
  }
  add_stubs_before(1 << 30);
  if (parse_only_requested()) make_parse_only(app);
  return guarded([&]() -> int {
    try {
      app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
      return app.exit(e);
    }
    return 0;
  });
}
