// Plain-text events, one per line: "t x y p [label]" (spaces, tabs or commas between fields).
//   - A CSV column-header row (4-5 non-numeric fields, e.g. "t,x,y,p") before the first
//     event is skipped.
//   - '#' starts a comment line. Two comments are understood anywhere before the first event:
//     "# sensor W H" (sensor size) and "# time_unit s|us".
//   - t: seconds (decimal) or microseconds (integer). Unit rule, first match wins:
//     ReadOptions::time_unit if not "auto"; the "# time_unit" comment; seconds if any t among
//     the first 1000 events contains '.', 'e' or 'E'; else microseconds.
//   - p: 1/+1 = ON, 0/-1 = OFF. The optional 5th column is the object label (0..65535).
//   - Sensor size: ReadOptions::sensor, else the "# sensor" comment, else max(x)+1 x max(y)+1.
// Streams with bounded memory; "-" reads standard input and writes standard output.
#pragma once

#include <memory>
#include <string>

#include "core/events/io.h"

namespace spikems {

std::unique_ptr<EventReader> open_text_reader(std::unique_ptr<ByteSource> src,
                                              const ReadOptions& opt);
FormatInfo text_format();

}  // namespace spikems
