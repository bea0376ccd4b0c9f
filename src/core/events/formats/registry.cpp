// The list of event formats spikems knows. Each format lives in its own file under formats/
// and exposes one `FormatInfo xxx_format()` function; add it here to make it available to
// every command (detection, info, convert, render, segment).
#include <vector>

#include "core/events/io.h"

namespace spikems {

// Declarations of the per-format factories (defined in formats/<name>.cpp).
// FORMAT-DECLARATIONS (keep one per line)
FormatInfo text_format();
FormatInfo npz_events_format();
FormatInfo evimo1_format();
FormatInfo evimo1_txt_format();
FormatInfo spikems_h5_format();
FormatInfo dsec_format();
FormatInfo evimo2_format();
FormatInfo evt2_format();
FormatInfo evt3_format();
FormatInfo dat_format();
FormatInfo aedat2_format();
FormatInfo aedat3_format();
FormatInfo aedat4_format();
FormatInfo es_format();

std::vector<FormatInfo> make_format_list() {
  std::vector<FormatInfo> v;
  // FORMAT-LIST (keep one per line)
  v.push_back(text_format());
  v.push_back(npz_events_format());
  v.push_back(evimo1_format());
  v.push_back(evimo1_txt_format());
  v.push_back(spikems_h5_format());
  v.push_back(dsec_format());
  v.push_back(evimo2_format());
  v.push_back(evt2_format());
  v.push_back(evt3_format());
  v.push_back(dat_format());
  v.push_back(aedat2_format());
  v.push_back(aedat3_format());
  v.push_back(aedat4_format());
  v.push_back(es_format());
  return v;
}

}  // namespace spikems
