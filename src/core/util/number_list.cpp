#include "core/util/number_list.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "core/util/error.h"

namespace spikems {

std::vector<ListedNumber> parse_number_list(const std::string& list, const std::string& what,
                                            const std::string& example) {
  std::vector<ListedNumber> out;
  size_t start = 0;
  while (start <= list.size()) {
    const size_t end = std::min(list.find(',', start), list.size());
    ListedNumber n{list.substr(start, end - start), NAN};
    char* stop = nullptr;
    if (!n.text.empty()) n.value = std::strtod(n.text.c_str(), &stop);
    if (n.text.empty() || stop != n.text.c_str() + n.text.size() || !std::isfinite(n.value))
      fail(what, "", "'" + n.text + "' is not a number: give " + example);
    if (std::any_of(out.begin(), out.end(),
                    [&](const ListedNumber& o) { return o.value == n.value; }))
      fail(what, "", "'" + n.text + "' is given twice");
    out.push_back(std::move(n));
    start = end + 1;
  }
  return out;
}

}  // namespace spikems
