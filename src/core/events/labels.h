// Per-event ground truth from mask frames: every event takes the object id that the mask
// frame nearest in time shows at its pixel (docs/events.md, "Labelling policy").
#pragma once

#include <cstdint>
#include <vector>

#include "core/events/event_stream.h"
#include "core/events/recording.h"

namespace spikems {

struct LabelOptions {
  // Odd square size of the dilation, e.g. 5 = 5x5 as the SpikeMS authors dilate; 0/1 = none.
  int dilation = 0;
  // Only these ids are foreground; empty = every non-zero id.
  std::vector<uint16_t> moving_ids;
  // Events farther than this from any mask frame get label 0 (-1 = no limit).
  int64_t max_gap_us = -1;
};

// Sets ev.label for every event:
// - the mask frame nearest in time to the event is used; on a tie (event exactly half-way
//   between two frames) the EARLIER frame wins;
// - ids not in opt.moving_ids become 0 first, then the mask is dilated (dilate_mask);
// - events farther than max_gap_us from the nearest frame get 0.
// Throws spikems::Error when masks is empty, a mask's size differs from a known sensor size,
// or the dilation size is even / negative. Masks need not be sorted.
void label_from_masks(EventStream& ev, const std::vector<MaskFrame>& masks,
                      const LabelOptions& opt);

// Grows every object region by a size x size square (size odd; 0 or 1 returns a copy).
// Non-zero pixels keep their id. A zero pixel takes the id of the NEAREST non-zero pixel within
// its size x size neighbourhood (squared Euclidean distance; ties: the smaller id), so where
// dilated regions overlap, each pixel belongs to the object whose original pixels are closest.
// The neighbourhood is clipped at the sensor border.
MaskFrame dilate_mask(const MaskFrame& mask, int size);

// Keeps only ids in `moving_ids` (empty: keeps every non-zero id), others become 0.
MaskFrame filter_mask_ids(const MaskFrame& mask, const std::vector<uint16_t>& moving_ids);

}  // namespace spikems
