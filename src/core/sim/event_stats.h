// Summary statistics of an event stream, to compare simulated data with real recordings:
// rates, ON/OFF balance, per-pixel inter-event intervals, and the edge width: the mean length
// of the runs of same-polarity events at a pixel whose consecutive gaps are < edge_gap_ms
// (10 ms: an edge crossing a pixel at >= 100 px/s gives one run of about |dL| / C events;
// a polarity change or a longer gap starts a new run; a lone event is a run of 1).
#pragma once

#include <string>
#include <vector>

#include "core/events/event_stream.h"

namespace spikems::sim {

struct EventStats {
  double events = 0, duration_s = 0;
  double rate_mev_s = 0;         // million events per second
  double rate_per_pixel_hz = 0;  // events / s / pixel (all pixels)
  double active_pixel_fraction = 0;
  double rate_per_active_pixel_hz = 0;  // events / s / pixel with at least one event
  double on_fraction = 0;
  double isi_p10_ms = 0, isi_median_ms = 0, isi_p90_ms = 0;  // per-pixel inter-event intervals
  double same_polarity_fraction = 0;  // consecutive events at a pixel with equal polarity
  double edge_gap_ms = 0;             // G of the edge width
  double edge_width = 0;  // mean run length of same-polarity events < G apart at a pixel
};

inline constexpr double kEdgeGapMs = 10.0;
EventStats compute_event_stats(const EventStream& ev, double edge_gap_ms = kEdgeGapMs);
// Markdown table, one column per named stats.
std::string stats_table(const std::vector<std::pair<std::string, EventStats>>& cols);

}  // namespace spikems::sim
