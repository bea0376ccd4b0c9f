// The list of event formats spikems knows. Each format lives in its own file under formats/
// and exposes one `FormatInfo xxx_format()` function; add it here to make it available to
// every command (detection, info, convert, render, segment).
#include <vector>

#include "core/events/io.h"

namespace spikems {

// Declarations of the per-format factories (defined in formats/<name>.cpp).
// FORMAT-DECLARATIONS (keep one per line)

std::vector<FormatInfo> make_format_list() {
  std::vector<FormatInfo> v;
  // FORMAT-LIST (keep one per line)
  return v;
}

}  // namespace spikems
