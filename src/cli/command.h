// Subcommands register themselves: each src/cli/cmd_<name>.cpp defines a function that adds
// its CLI11 subcommand, and registers it with SPIKEMS_COMMAND. Files named cmd_train_*.cpp
// need LibTorch and are left out of builds without it.
#pragma once

#include <CLI/CLI.hpp>
#include <functional>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

namespace spikems::cli {

using Registrar = void (*)(CLI::App& app);

struct CommandEntry {
  std::string name;
  int order;  // position in `spikems --help`
  Registrar add;
};

std::vector<CommandEntry>& command_registry();

struct CommandRegistration {
  CommandRegistration(const char* name, int order, Registrar r) {
    command_registry().push_back({name, order, r});
  }
};

// Options shared by commands that read event files.
struct ReadFlags {
  bool sort = false;
  std::string time_unit = "auto";
  std::string format;
  int width = 0, height = 0;
};
void add_read_flags(CLI::App* cmd, ReadFlags& f);

// Throws Error naming --split unless `split` is train, val, test or all.
void check_split(const std::string& split);

// The --downsample and --train-grid options of eval and calibrate (model_scale.h): the factor
// (0 = auto) and a training grid for models that record none (0 x 0 = as recorded).
struct ScaleFlags {
  std::string downsample = "auto";
  std::string train_grid;
  int factor() const;                // throws Error naming --downsample
  std::pair<int, int> grid() const;  // "WxH"; throws Error naming --train-grid
};
void add_scale_flags(CLI::App* cmd, ScaleFlags& f);

// The command line as typed (shell-quoted, from /proc/self/cmdline), for provenance records.
std::string invoked_command();

}  // namespace spikems::cli

#define SPIKEMS_COMMAND(name, order, fn) \
  static ::spikems::cli::CommandRegistration spikems_cmd_reg_##name(#name, order, fn)
