// Errors that reach the user: every message names the input, the position and the reason,
// so a bad file can be found and fixed without a debugger.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>

namespace spikems {

class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message) : std::runtime_error(message) {}
};

// "FILE: at POSITION: REASON" (position omitted when empty).
std::string format_error(const std::string& source, const std::string& position,
                         const std::string& reason);

[[noreturn]] void fail(const std::string& source, const std::string& position,
                       const std::string& reason);
[[noreturn]] void fail_at_byte(const std::string& source, uint64_t offset,
                               const std::string& reason);
[[noreturn]] void fail_at_line(const std::string& source, uint64_t line, const std::string& reason);
[[noreturn]] void fail_at_event(const std::string& source, uint64_t index,
                                const std::string& reason);

}  // namespace spikems
