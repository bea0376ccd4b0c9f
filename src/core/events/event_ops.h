// Operations on event streams that keep them events: geometry (crop/flip/downsample), crops
// centred on the moving object (the SpikeMS authors train on 128x128 crops around it), and two
// classic denoising filters.
#pragma once

#include <cstdint>
#include <vector>

#include "core/events/binning.h"
#include "core/events/event_stream.h"

namespace spikems {

// Events mapped through the geometry of `cfg` (crop, flip, downsample, exactly as bin_events
// does; step_us is ignored); events outside the crop are dropped, labels kept, and the sensor
// becomes the binned size. Duplicates created by downsampling are kept.
EventStream remap_events(const EventStream& ev, const BinningConfig& cfg);

// A w x h crop of `base` centred as near as possible on (cx, cy), pixel coordinates like event
// x, y: the pixel nearest (cx, cy) becomes the crop's pixel (w/2, h/2), then the crop is shifted
// to lie inside the sensor. Throws when w or h exceed the sensor.
BinningConfig centred_crop(SensorSize sensor, double cx, double cy, int w, int h,
                           const BinningConfig& base = {});

// Centroid of the foreground events (label in moving_ids; empty: any non-zero) with t in
// [t0, t1); false when there are none (or the stream has no labels).
bool foreground_centroid(const EventStream& ev, int64_t t0, int64_t t1,
                         const std::vector<uint16_t>& moving_ids, double& cx, double& cy);

// Keeps each event with probability `keep` (0 < keep <= 1), independently, as a sensor that
// gives fewer events would (a higher contrast threshold, slower motion): the draw for event i
// depends only on (seed, i), so the result is the same on every machine and run. Labels and
// the sensor are kept. Throws Error for keep outside (0, 1].
EventStream thin_events(const EventStream& ev, double keep, uint64_t seed = 0);

// Refractory filter: drops an event when the same pixel (either polarity) had a KEPT event
// less than period_us before it. Needs a known sensor size. The class keeps its per-pixel state
// between chunks, so a stream filtered chunk by chunk gives the same result as in one piece.
class RefractoryFilter {
 public:
  RefractoryFilter(SensorSize sensor, int64_t period_us);
  EventStream apply(const EventStream& chunk);

 private:
  SensorSize sensor_;
  int64_t period_;
  std::vector<int64_t> last_;
};
EventStream refractory_filter(const EventStream& ev, int64_t period_us);

// Background-activity filter (the classic nearest-neighbour denoiser): keeps an event when one
// of its 8 neighbouring pixels (not the pixel itself) had an event at most dt_us before it;
// every event, kept or not, updates its pixel's last time. Isolated noise events are dropped,
// edges of moving things survive. Needs a known sensor size. Chunk by chunk like above.
class BackgroundActivityFilter {
 public:
  BackgroundActivityFilter(SensorSize sensor, int64_t dt_us);
  EventStream apply(const EventStream& chunk);

 private:
  SensorSize sensor_;
  int64_t dt_;
  std::vector<int64_t> last_;
};
EventStream background_activity_filter(const EventStream& ev, int64_t dt_us);

}  // namespace spikems
