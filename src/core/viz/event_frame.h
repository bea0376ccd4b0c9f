// Pictures of events and masks: what a person looks at to check data, labels and predictions.
// Colours: white background, ON events red, OFF blue, both polarities at a pixel purple,
// ground-truth outline green (1-pixel contour of the moving-object regions, drawn on top).
#pragma once

#include <cstdint>
#include <vector>

#include "core/events/binning.h"
#include "core/events/event_stream.h"
#include "core/events/recording.h"
#include "core/viz/image.h"

namespace spikems {

struct Rgb {
  uint8_t r, g, b;
};
inline constexpr Rgb kBackground{255, 255, 255};
inline constexpr Rgb kOnColor{255, 0, 0};
inline constexpr Rgb kOffColor{0, 0, 255};
inline constexpr Rgb kBothColor{160, 0, 160};
inline constexpr Rgb kOutlineColor{0, 170, 0};
inline constexpr Rgb kMaskColor{40, 40, 40};

// Colour of an object id for label tints (never red, blue, purple or the outline green).
Rgb label_color(uint16_t id);

struct RenderOptions {
  int scale = 1;             // integer enlargement (nearest neighbour)
  bool outline_mask = true;  // draw the mask's contour when a mask is given
  bool show_labels = false;  // events with a non-zero label take their object's colour
};

// Events with t in [t0, t1) (time-sorted stream). `mask` (optional) is outlined: every non-zero
// id counts as a region (filter it to the moving ids first, see filter_mask_ids). The outline is
// drawn over the events; at scale >= 2 it is a 1-pixel line along the block sides that face
// outside the region, so the events inside stay visible.
Image render_events(const EventStream& ev, int64_t t0, int64_t t1, SensorSize sensor,
                    const MaskFrame* mask = nullptr, const RenderOptions& = {});

// 1 on the inner border of the non-zero regions of a w x h id map: a region pixel with a
// 4-neighbour (inside the image) that is outside the region.
std::vector<uint8_t> mask_contour(const std::vector<uint16_t>& ids, int w, int h);

// A binary mask (e.g. a prediction, 1 = foreground) in dark grey on white, optionally with the
// ground truth's contour in green.
Image render_mask(const std::vector<uint8_t>& mask, int w, int h, const MaskFrame* truth = nullptr,
                  const RenderOptions& = {});

// Prediction against truth, both binary w x h: true positives green, false positives orange,
// false negatives blue, true negatives white.
inline constexpr Rgb kTruePositive{0, 170, 0};
inline constexpr Rgb kFalsePositive{255, 140, 0};
inline constexpr Rgb kFalseNegative{0, 90, 255};
Image render_comparison(const std::vector<uint8_t>& predicted, const std::vector<uint8_t>& truth,
                        int w, int h, int scale = 1);

// A spike tensor collapsed over time: a pixel is red if it spiked ON in any step, blue for OFF,
// purple for both.
Image render_spikes(const SpikeTensor& s, int scale = 1);

}  // namespace spikems
