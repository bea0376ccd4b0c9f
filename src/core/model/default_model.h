// The model spikems ships (models/spikems-default.safetensors, card in models/README.md), used
// by `segment` and `eval` when no --model is given.
#pragma once

#include <string>

namespace spikems {

inline constexpr const char* kDefaultModelName = "spikems-default.safetensors";

// $SPIKEMS_MODEL when set; else the first that exists of <executable dir>/../models/ (the source
// tree, with the build in build/); <executable dir>/../share/spikems/models/ (an installed tree).
// "" when none does.
std::string find_default_model();

// The same, or Error saying where it looked and what to do.
std::string default_model_or_fail();

// A --model argument: "" = the default model (default_model_or_fail); a bare name without '/'
// or '.' that is not a file ("fast", "default") = models/spikems-<name>.safetensors in the
// shipped models' folders (as above, $SPIKEMS_MODEL aside), or Error listing what is there;
// anything else is a path, returned as given.
std::string resolve_model(const std::string& arg);

}  // namespace spikems
