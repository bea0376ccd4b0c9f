#include "core/dataset/sequence.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "core/events/io.h"
#include "core/events/labels.h"
#include "core/util/error.h"
#include "core/util/progress.h"

namespace spikems {

namespace fs = std::filesystem;

std::vector<std::string> sequence_files(const DatasetSource& src) {
  std::error_code ec;
  if (!fs::exists(src.path, ec)) fail(src.path, "", "no such file or folder");
  const fs::path manifest = fs::path(src.path) / "manifest.json";
  if (!fs::is_directory(src.path, ec) || !fs::exists(manifest, ec))
    return {src.path};  // one recording (a file, or a dataset folder such as EV-IMO's)
  nlohmann::json m;
  try {
    std::ifstream in(manifest);
    m = nlohmann::json::parse(in);
  } catch (const std::exception& e) {
    fail(manifest.string(), "", std::string("not valid JSON: ") + e.what());
  }
  if (!m.contains("splits") || !m["splits"].is_object())
    fail(manifest.string(), "", "no \"splits\" object: not a `spikems simulate` manifest");
  std::vector<std::string> names;
  if (src.split == "all") {
    for (const char* k : {"train", "val", "test"})
      if (m["splits"].contains(k))
        for (const auto& f : m["splits"][k]) names.push_back(f.get<std::string>());
  } else {
    if (!m["splits"].contains(src.split))
      fail(manifest.string(), "",
           "unknown split \"" + src.split + "\" (use train, val, test or all)");
    for (const auto& f : m["splits"][src.split]) names.push_back(f.get<std::string>());
  }
  if (names.empty())
    fail(manifest.string(), "", "the split \"" + src.split + "\" lists no sequences");
  std::sort(names.begin(), names.end());
  std::vector<std::string> files;
  for (const auto& n : names) files.push_back((fs::path(src.path) / n).string());
  return files;
}

LabelledSequence load_sequence(const std::string& path, int mask_dilation, bool require_labels) {
  Recording rec = read_recording(path);
  LabelledSequence s;
  s.name = path;
  s.events = std::move(rec.events);
  if (!s.events.sensor.known()) fail(path, "", "the sensor size is unknown");
  const auto& ids = rec.moving_ids;
  auto moving = [&](uint16_t id) {
    return id != 0 && (ids.empty() || std::find(ids.begin(), ids.end(), id) != ids.end());
  };
  if (s.events.has_labels()) {
    for (auto& l : s.events.label) l = moving(l) ? 1 : 0;
  } else if (!rec.masks.empty()) {
    LabelOptions lo;
    lo.dilation = mask_dilation;
    lo.moving_ids = ids;
    label_from_masks(s.events, rec.masks, lo);
    for (auto& l : s.events.label) l = l != 0 ? 1 : 0;
  } else if (require_labels) {
    fail(path, "",
         "no labels: training and evaluation need per-event labels (object ids) or mask frames, "
         "e.g. from `spikems simulate`");
  }
  return s;
}

std::vector<LabelledSequence> load_sequences(const DatasetSource& src, bool progress) {
  const auto files = sequence_files(src);
  std::vector<LabelledSequence> out;
  ProgressBar bar("load " + fs::path(src.path).filename().string(), files.size(), "seq", progress);
  for (const auto& f : files) {
    out.push_back(load_sequence(f, src.mask_dilation));
    bar.add(1);
  }
  bar.finish();
  return out;
}

}  // namespace spikems
