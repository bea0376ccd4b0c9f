#include "core/events/formats/label_column.h"

#include <algorithm>

#include "core/events/formats/npy.h"
#include "core/events/io.h"
#include "core/util/error.h"

namespace spikems {

LabelColumnWriter::LabelColumnWriter(const std::string& path) : file_(path) {
  const std::string e = lower_extension(path);
  if (e == ".npy")
    layout_ = Layout::kNpy;
  else if (e == ".txt")
    layout_ = Layout::kText;
  else
    fail(path, "",
         "a label column is written as .npy (uint8, one per event) or .txt (one per line), not '" +
             e + "'");
  if (layout_ == Layout::kNpy) file_.write(std::string(kNpyHeader1d, ' '));  // rewritten at close
}

void LabelColumnWriter::write(const EventStream& ev) {
  const size_t n = ev.size();
  if (n == 0) return;
  buf_.resize(layout_ == Layout::kNpy ? n : 2 * n);
  char* o = buf_.data();
  if (!ev.has_labels()) {
    if (layout_ == Layout::kNpy)
      std::fill(o, o + n, '\0');
    else
      for (size_t i = 0; i < n; ++i) o[2 * i] = '0', o[2 * i + 1] = '\n';
  } else {
    const uint16_t* l = ev.label.data();
    uint16_t hi = 0;
    for (size_t i = 0; i < n; ++i) hi = std::max(hi, l[i]);
    if (layout_ == Layout::kNpy) {
      if (hi > 255)
        fail(file_.target(), "event " + std::to_string(n_ + (std::max_element(l, l + n) - l)),
             "label " + std::to_string(hi) +
                 " does not fit the uint8 column; write a .txt column or the events with their "
                 "labels (--out) instead");
      for (size_t i = 0; i < n; ++i) o[i] = char(l[i]);
    } else if (hi <= 9) {  // segment's 0/1: two bytes per event, no formatting
      for (size_t i = 0; i < n; ++i) o[2 * i] = char('0' + l[i]), o[2 * i + 1] = '\n';
    } else {
      buf_.clear();
      for (size_t i = 0; i < n; ++i) (buf_ += std::to_string(l[i])) += '\n';
    }
  }
  file_.write(buf_.data(), buf_.size());
  n_ += n;
}

void LabelColumnWriter::close() {
  if (file_.committed()) return;
  if (layout_ == Layout::kNpy) {
    const std::vector<uint8_t> h = npy_header(npy_descr_of<uint8_t>(), {int64_t(n_)});
    if (h.size() != kNpyHeader1d) fail(file_.target(), "", "internal: npy header is not 128 bytes");
    file_.overwrite(0, h.data(), h.size());
  }
  file_.commit();
}

}  // namespace spikems
