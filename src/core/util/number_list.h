// Comma-separated lists of numbers on the command line ("1,1.1,1.2"): one parser for every
// option that takes one, so they refuse the same mistakes with the same words.
#pragma once

#include <string>
#include <vector>

namespace spikems {

struct ListedNumber {
  std::string text;  // the item as given, for messages
  double value = 0;
};

// Splits `list` at commas and parses each item; throws Error naming `what` for an empty item or
// one that is not a finite number (the message shows `example`), or a value given twice.
std::vector<ListedNumber> parse_number_list(const std::string& list, const std::string& what,
                                            const std::string& example);

}  // namespace spikems
