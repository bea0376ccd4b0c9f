// Summary statistics of an event stream, to compare simulated data with real recordings:
// rates, ON/OFF balance, per-pixel inter-event intervals, and burst sizes (runs of
// same-polarity events at a pixel less than 1 ms apart, about |dL| / C for one edge).
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
  double on_fraction = 0;
  double isi_p10_ms = 0, isi_median_ms = 0, isi_p90_ms = 0;  // per-pixel inter-event intervals
  double same_polarity_fraction = 0;  // consecutive events at a pixel with equal polarity
  double burst_mean = 0;              // mean run length of same-polarity events < 1 ms apart
};

EventStats compute_event_stats(const EventStream& ev);
// Markdown table, one column per named stats.
std::string stats_table(const std::vector<std::pair<std::string, EventStats>>& cols);

}  // namespace spikems::sim
