// The commands that need LibTorch (train, forward) are built into a second program,
// spikems-torch, so that every other command starts without loading LibTorch: linked into
// `spikems` it cost each start ~0.8 s (290 shared libraries to map and relocate, measured with
// `spikems --version`). `spikems train ...` replaces itself with that program, arguments
// unchanged; users still type one command (docs/cli.md, "Programs").
#pragma once

#include <CLI/CLI.hpp>
#include <string>

namespace spikems::cli {

// In `order` order (main() merges them into the sorted list of the other commands).
struct TorchCommand {
  const char* name;
  int order;  // position in `spikems --help`
  const char* description;
};

inline constexpr TorchCommand kTorchCommands[] = {
    {"train", 60, "Train the SpikeMS network on labelled event data (simulated or recorded)"},
    {"forward", 62,
     "Dense forward pass of a model on a spike tensor stored in npz (N, C, H, W, T); writes "
     "every layer's spikes (layer1 ... layerL, same layout, float32) to an npz"},
};

// The entry of kTorchCommands named `name`; throws if there is none (a programming error).
const TorchCommand& torch_command(const std::string& name);

// True when `name` is one of kTorchCommands.
bool is_torch_command(const char* name);

// Where the helper program is: beside this executable (the build tree) or in
// <exe dir>/../lib/spikems/ (an installed tree). Empty when neither exists; `looked` gets the
// places tried.
std::string find_torch_helper(std::string& looked);

// Replaces this process with the helper, same arguments. Returns only on failure, after throwing
// an Error that says where it looked and how to build it.
[[noreturn]] void exec_torch_helper(char** argv);

}  // namespace spikems::cli
