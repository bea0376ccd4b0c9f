#include "core/sim/event_stats.h"

#include <algorithm>
#include <cstdio>
#include <numeric>

namespace spikems::sim {

EventStats compute_event_stats(const EventStream& ev, double gap_ms) {
  EventStats s;
  s.edge_gap_ms = gap_ms;
  const size_t n = ev.size();
  s.events = double(n);
  if (n == 0 || !ev.sensor.known()) return s;
  s.duration_s = std::max(1e-6, double(ev.t.back() - ev.t.front()) * 1e-6);
  const double npix = double(ev.sensor.width) * ev.sensor.height;
  s.rate_mev_s = s.events / s.duration_s * 1e-6;
  s.rate_per_pixel_hz = s.events / s.duration_s / npix;
  size_t on = 0;
  for (auto p : ev.p) on += p;
  s.on_fraction = double(on) / s.events;
  // Group by pixel, keeping time order within a pixel (stable sort of the indices).
  std::vector<uint32_t> idx(n);
  std::iota(idx.begin(), idx.end(), 0u);
  auto pix = [&](uint32_t i) { return uint32_t(ev.y[i]) * uint32_t(ev.sensor.width) + ev.x[i]; };
  std::stable_sort(idx.begin(), idx.end(), [&](uint32_t a, uint32_t b) { return pix(a) < pix(b); });
  std::vector<double> isi;
  isi.reserve(n);
  size_t active = 0, pairs = 0, same = 0, runs = 0, run_events = 0;
  for (size_t k = 0; k < n;) {
    size_t e = k;
    while (e < n && pix(idx[e]) == pix(idx[k])) ++e;
    ++active;
    size_t run = 1;
    for (size_t j = k + 1; j < e; ++j) {
      uint32_t a = idx[j - 1], b = idx[j];
      double d = double(ev.t[b] - ev.t[a]) * 1e-3;
      isi.push_back(d);
      ++pairs;
      bool sp = ev.p[a] == ev.p[b];
      same += sp;
      if (sp && d < gap_ms) {
        ++run;
      } else {
        ++runs, run_events += run;
        run = 1;
      }
    }
    ++runs, run_events += run;
    k = e;
  }
  s.active_pixel_fraction = double(active) / npix;
  s.rate_per_active_pixel_hz = s.events / s.duration_s / double(active);
  s.same_polarity_fraction = pairs ? double(same) / double(pairs) : 0;
  s.edge_width = runs ? double(run_events) / double(runs) : 0;
  if (!isi.empty()) {
    auto q = [&](double f) {
      size_t i = std::min(isi.size() - 1, size_t(f * double(isi.size())));
      std::nth_element(isi.begin(), isi.begin() + long(i), isi.end());
      return isi[i];
    };
    s.isi_p10_ms = q(0.1);
    s.isi_median_ms = q(0.5);
    s.isi_p90_ms = q(0.9);
  }
  return s;
}

std::string stats_table(const std::vector<std::pair<std::string, EventStats>>& cols) {
  std::string out = "| statistic |";
  for (const auto& c : cols) out += " " + c.first + " |";
  out += "\n|---|";
  for (size_t i = 0; i < cols.size(); ++i) out += "---|";
  out += "\n";
  auto row = [&](const std::string& name, auto get, const char* fmt) {
    out += "| " + name + " |";
    for (const auto& c : cols) {
      char buf[64];
      std::snprintf(buf, sizeof buf, fmt, get(c.second));
      out += " " + std::string(buf) + " |";
    }
    out += "\n";
  };
  row(
      "events", [](const EventStats& s) { return s.events; }, "%.0f");
  row(
      "duration (s)", [](const EventStats& s) { return s.duration_s; }, "%.3f");
  row(
      "rate (Mev/s)", [](const EventStats& s) { return s.rate_mev_s; }, "%.3f");
  row(
      "rate per pixel (Hz)", [](const EventStats& s) { return s.rate_per_pixel_hz; }, "%.2f");
  row(
      "active pixels (%)", [](const EventStats& s) { return 100 * s.active_pixel_fraction; },
      "%.1f");
  row(
      "rate per active pixel (Hz)", [](const EventStats& s) { return s.rate_per_active_pixel_hz; },
      "%.2f");
  row(
      "ON events (%)", [](const EventStats& s) { return 100 * s.on_fraction; }, "%.1f");
  row(
      "inter-event interval p10 (ms)", [](const EventStats& s) { return s.isi_p10_ms; }, "%.3f");
  row(
      "inter-event interval median (ms)", [](const EventStats& s) { return s.isi_median_ms; },
      "%.3f");
  row(
      "inter-event interval p90 (ms)", [](const EventStats& s) { return s.isi_p90_ms; }, "%.1f");
  row(
      "same polarity as previous at pixel (%)",
      [](const EventStats& s) { return 100 * s.same_polarity_fraction; }, "%.1f");
  row(
      "edge width (same-polarity run, gaps < " +
          std::to_string(int(cols.empty() ? kEdgeGapMs : cols[0].second.edge_gap_ms)) + " ms)",
      [](const EventStats& s) { return s.edge_width; }, "%.2f");
  return out;
}

}  // namespace spikems::sim
