// Labelled sequences for training and evaluation: events whose label is 1 on independently
// moving objects and 0 on the background, from any source the project reads (docs/training.md):
//   - a simulator dataset folder (manifest.json; its train / val / test splits),
//   - an EV-IMO v1 sequence (npz, or a txt folder) or an EVIMO2 v2 folder (labels from the
//     mask frames, dilated as the SpikeMS authors do),
//   - any event file with per-event labels (object ids; 0 = background).
// A source is named by a DatasetSource; load_sequences() reads it whole into memory.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/events/event_stream.h"

namespace spikems {

struct LabelledSequence {
  std::string name;    // file or folder it came from
  EventStream events;  // time-sorted; label: 1 = moving object, 0 = background
};

struct DatasetSource {
  std::string path;
  std::string split = "train";  // simulator folders: train, val, test or all
  double weight = 1.0;          // relative share of samples when datasets are mixed
  int mask_dilation = 5;        // sources labelled from mask frames (EV-IMO): square size
};

// The files of a source (one per sequence). Throws Error naming the path when it is not a
// readable dataset, or a split is unknown or empty.
std::vector<std::string> sequence_files(const DatasetSource& src);

// One sequence, labels reduced to 0/1 (from the recording's labels, else its mask frames).
// Throws Error when the recording carries neither labels nor masks, unless require_labels is
// false (box ground truth, core/eval/boxes.h): then its events come back without labels.
LabelledSequence load_sequence(const std::string& path, int mask_dilation = 5,
                               bool require_labels = true);

// Every sequence of a source (progress on stderr when `progress`).
std::vector<LabelledSequence> load_sequences(const DatasetSource& src, bool progress = false);

}  // namespace spikems
