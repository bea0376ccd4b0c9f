// The message of the spikems::Error that `f` throws ("" when it throws none): for tests that
// check what an error says, not only that it happens.
#pragma once

#include <functional>
#include <string>

#include "core/util/error.h"

namespace spikems::test {

inline std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

}  // namespace spikems::test
