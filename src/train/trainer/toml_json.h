// A TOML node as JSON, the form every training configuration and recipe is checked and stored
// in (train_config.cpp, cli/cmd_train_recipe.cpp).
#pragma once

#include <toml++/toml.h>

#include <nlohmann/json.hpp>

namespace spikems::train {

// Tables, arrays, strings, integers, floats and booleans; dates and times become null (no key
// takes them, so the type check of the key names it).
nlohmann::json toml_to_json(const toml::node& n);

}  // namespace spikems::train
