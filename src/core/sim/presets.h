// The simulator presets. Each is the text of configs/sim/<name>.toml, compiled in so the
// binary works anywhere (a test checks the two stay identical).
#pragma once

#include <string>
#include <vector>

#include "core/sim/sim_config.h"

namespace spikems::sim {

std::vector<std::string> preset_names();  // the names of configs/sim/*.toml, mod first
// TOML text of a preset; throws Error listing the names when unknown.
const std::string& preset_toml(const std::string& name);
SimConfig preset_config(const std::string& name);

}  // namespace spikems::sim
