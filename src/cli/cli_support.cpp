// What every subcommand shares: the registry they add themselves to and the options and checks
// several of them use. Linked into both programs (spikems and its LibTorch helper, see
// torch_helper.h).
#include <cstdio>
#include <fstream>
#include <string>

#include "cli/command.h"
#include "core/model/model_scale.h"
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

int ScaleFlags::factor() const {
  return parse_downsample(downsample, "--downsample");
}

std::pair<int, int> ScaleFlags::grid() const {
  if (train_grid.empty()) return {0, 0};
  int w = 0, h = 0;
  char x = 0, extra = 0;
  if (std::sscanf(train_grid.c_str(), "%d%c%d%c", &w, &x, &h, &extra) != 3 || x != 'x' || w < 1 ||
      h < 1 || w > 65535 || h > 65535)
    fail("--train-grid", train_grid, "give the training grid as WIDTHxHEIGHT, e.g. 173x130");
  return {w, h};
}

void add_scale_flags(CLI::App* cmd, ScaleFlags& f) {
  cmd->add_option("--downsample", f.downsample,
                  "auto, 1, 2, 4 or 8: the network sees each sequence at 1/N resolution and is "
                  "scored on that grid (G from the events at its pixels); auto (default): the N "
                  "that brings the sensor nearest the grid the model was trained on (1 for "
                  "models that record none). docs/runtime.md, \"Pixel scale\"")
      ->capture_default_str();
  cmd->add_option("--train-grid", f.train_grid,
                  "WIDTHxHEIGHT: the grid a model was trained on, for models that record none "
                  "(e.g. imported with import-slayer), e.g. 173x130 for 346x260 rooms "
                  "downsampled 2x; used by --downsample auto");
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
