#include "core/util/error.h"

namespace spikems {

std::string format_error(const std::string& source, const std::string& position,
                         const std::string& reason) {
  std::string m = source.empty() ? std::string("<input>") : source;
  if (!position.empty()) m += ": at " + position;
  m += ": " + reason;
  return m;
}

void fail(const std::string& source, const std::string& position, const std::string& reason) {
  throw Error(format_error(source, position, reason));
}
void fail_at_byte(const std::string& source, uint64_t offset, const std::string& reason) {
  fail(source, "byte " + std::to_string(offset), reason);
}
void fail_at_line(const std::string& source, uint64_t line, const std::string& reason) {
  fail(source, "line " + std::to_string(line), reason);
}
void fail_at_event(const std::string& source, uint64_t index, const std::string& reason) {
  fail(source, "event " + std::to_string(index), reason);
}

}  // namespace spikems
