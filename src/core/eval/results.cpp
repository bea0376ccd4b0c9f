#include "core/eval/results.h"

#include <algorithm>
#include <cmath>
#include <ctime>
#include <filesystem>

#include "core/util/atomic_file.h"
#include "core/util/error.h"
#include "core/util/text_format.h"

namespace spikems {

namespace fs = std::filesystem;

WindowSummary summarize(int64_t window_us, const std::vector<const WindowScores*>& parts,
                        const std::vector<const EventCounts*>& events,
                        const std::vector<double>& band_edges_pct) {
  WindowSummary s;
  s.window_us = window_us;
  s.sequences = parts.size();
  s.has_events = !events.empty();
  for (const EventCounts* e : events) s.events += *e;
  double sum = 0, detections = 0;
  for (const WindowScores* p : parts) {
    s.windows += p->windows();
    s.skipped += p->skipped();
    s.filtered += p->filtered();
    for (double v : p->ious()) sum += v;
    // WindowScores keeps the rate only; rate * windows is the integer count it came from.
    detections += std::round(p->detection_rate() * double(p->windows()));
  }
  if (s.windows == 0) return s;
  const double n = double(s.windows), mean = sum / n;
  double var = 0;
  for (const WindowScores* p : parts)
    for (double v : p->ious()) var += (v - mean) * (v - mean);
  s.iou_mean = 100 * mean;
  s.iou_std = 100 * std::sqrt(var / n);
  s.detection_rate = 100 * detections / n;

  bool known = false;
  for (const WindowScores* p : parts)
    for (double v : p->moving_shares()) known = known || !std::isnan(v);
  if (!known || band_edges_pct.empty()) return s;
  s.bands = bands_of(band_edges_pct);
  // Each window's band, found once: [edge_{b-1}, edge_b), the last one up to 100 inclusive.
  auto band_of = [&](double share) {
    return size_t(std::upper_bound(band_edges_pct.begin(), band_edges_pct.end(), 100 * share) -
                  band_edges_pct.begin());
  };
  std::vector<double> bsum(s.bands.size(), 0), bdet(s.bands.size(), 0);
  for (const WindowScores* p : parts)
    for (size_t w = 0; w < p->windows(); ++w)
      if (const double share = p->moving_shares()[w]; !std::isnan(share)) {
        const size_t b = band_of(share);
        ++s.bands[b].windows;
        bsum[b] += p->ious()[w];
        bdet[b] += p->detections()[w];
      }
  std::vector<double> bvar(s.bands.size(), 0);
  for (const WindowScores* p : parts)
    for (size_t w = 0; w < p->windows(); ++w)
      if (const double share = p->moving_shares()[w]; !std::isnan(share)) {
        const size_t b = band_of(share);
        const double d = p->ious()[w] - bsum[b] / double(s.bands[b].windows);
        bvar[b] += d * d;
      }
  for (size_t b = 0; b < s.bands.size(); ++b) {
    const double bn = double(s.bands[b].windows);
    if (bn == 0) continue;
    s.bands[b].iou_mean = 100 * (bsum[b] / bn);  // as the whole row: 100 x the mean
    s.bands[b].iou_std = 100 * std::sqrt(bvar[b] / bn);
    s.bands[b].detection_rate = 100 * bdet[b] / bn;
  }
  return s;
}

std::string band_name(const BandSummary& b) {
  if (b.lo_pct <= 0) return "< " + fmt("%g", b.hi_pct) + " %";
  if (b.hi_pct >= 100) return "≥ " + fmt("%g", b.lo_pct) + " %";
  return fmt("%g", b.lo_pct) + "-" + fmt("%g", b.hi_pct) + " %";
}

void check_band_edges(const std::vector<double>& e, const std::string& source) {
  for (size_t i = 0; i < e.size(); ++i) {
    if (!(e[i] > 0 && e[i] < 100))
      fail(source, "",
           "each edge must lie between 0 and 100 percent (exclusive), got " + fmt("%g", e[i]));
    if (i > 0 && !(e[i] > e[i - 1]))
      fail(source, "",
           "the edges must increase (e.g. 2,10), got " + fmt("%g", e[i - 1]) + " then " +
               fmt("%g", e[i]));
  }
}

std::vector<BandSummary> bands_of(const std::vector<double>& e) {
  check_band_edges(e);
  std::vector<BandSummary> bands(e.size() + 1);
  for (size_t b = 0; b < bands.size(); ++b) {
    bands[b].lo_pct = b == 0 ? 0 : e[b - 1];
    bands[b].hi_pct = b == e.size() ? 100 : e[b];
  }
  return bands;
}

DatasetResult dataset_result(std::string data, std::string split,
                             const std::vector<SequenceScore>& sequences,
                             const std::vector<double>& band_edges_pct) {
  DatasetResult d;
  d.data = std::move(data);
  d.split = std::move(split);
  if (sequences.empty()) return d;
  const auto& windows = sequences.front().windows_us;
  const auto& kalman = sequences.front().kalman_us;
  const size_t rows = windows.size() + kalman.size();
  for (const auto& s : sequences) {
    if (s.windows_us != windows || s.kalman_us != kalman || s.scores.size() != rows)
      fail(s.name, "", "scored with other window lengths than the dataset's other sequences");
    if (!s.events_pr.empty() && s.events_pr.size() != windows.size())
      fail(s.name, "", "event counts for other window lengths than its scores");
  }
  // Row i: window length i, or Kalman length i - windows.size().
  auto row = [&](size_t i, const std::vector<const SequenceScore*>& seqs) {
    std::vector<const WindowScores*> parts;
    std::vector<const EventCounts*> events;
    const bool plain = i < windows.size();
    bool all_events = plain;
    for (const SequenceScore* s : seqs) {
      parts.push_back(&s->scores[i]);
      if (plain && !s->events_pr.empty())
        events.push_back(&s->events_pr[i]);
      else
        all_events = false;
    }
    WindowSummary w =
        summarize(plain ? windows[i] : kalman[i - windows.size()], parts,
                  all_events ? events : std::vector<const EventCounts*>{}, band_edges_pct);
    w.kalman = !plain;
    return w;
  };
  std::vector<const SequenceScore*> all;
  for (const auto& s : sequences) {
    SequenceResult r;
    r.name = s.name;
    r.events = s.events;
    r.duration_s = double(s.span_us) * 1e-6;
    for (size_t i = 0; i < rows; ++i) r.windows.push_back(row(i, {&s}));
    d.events += s.events;
    d.sequences.push_back(std::move(r));
    all.push_back(&s);
  }
  for (size_t i = 0; i < rows; ++i) d.windows.push_back(row(i, all));
  return d;
}

std::string utc_now_iso8601() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char b[32];
  std::strftime(b, sizeof b, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return b;
}

namespace {

double window_ms(int64_t us) {
  return double(us) / 1000.0;
}

nlohmann::ordered_json row_json(const WindowSummary& w, bool with_sequences) {
  nlohmann::ordered_json j;
  j["window_ms"] = window_ms(w.window_us);
  const bool any = w.windows > 0;
  j["iou_mean"] = any ? nlohmann::ordered_json(w.iou_mean) : nlohmann::ordered_json(nullptr);
  j["iou_std"] = any ? nlohmann::ordered_json(w.iou_std) : nlohmann::ordered_json(nullptr);
  j["detection_rate"] =
      any ? nlohmann::ordered_json(w.detection_rate) : nlohmann::ordered_json(nullptr);
  j["windows"] = w.windows;
  j["skipped_windows"] = w.skipped;
  j["filtered_windows"] = w.filtered;
  if (with_sequences) j["sequences"] = w.sequences;
  j["filter"] = w.kalman ? nlohmann::ordered_json("kalman") : nlohmann::ordered_json(nullptr);
  const EventCounts& e = w.events;
  auto pct = [](bool defined, double v) {
    return defined ? nlohmann::ordered_json(100 * v) : nlohmann::ordered_json(nullptr);
  };
  j["event_precision"] = pct(w.has_events && e.has_precision(), e.precision());
  j["event_recall"] = pct(w.has_events && e.has_recall(), e.recall());
  j["moving_share"] = pct(w.has_events && e.total() > 0, e.moving_share());
  if (w.has_events)
    j["event_counts"] = {{"tp", e.tp}, {"fp", e.fp}, {"fn", e.fn}, {"tn", e.tn}};
  else
    j["event_counts"] = nullptr;
  if (w.bands.empty()) {
    j["share_bands"] = nullptr;
  } else {
    j["share_bands"] = nlohmann::ordered_json::array();
    for (const BandSummary& b : w.bands) {
      const bool some = b.windows > 0;
      auto val = [&](double v) {
        return some ? nlohmann::ordered_json(v) : nlohmann::ordered_json(nullptr);
      };
      j["share_bands"].push_back({{"share_min_pct", b.lo_pct},
                                  {"share_max_pct", b.hi_pct},
                                  {"windows", b.windows},
                                  {"iou_mean", val(b.iou_mean)},
                                  {"iou_std", val(b.iou_std)},
                                  {"detection_rate", val(b.detection_rate)}});
    }
  }
  return j;
}

std::string csv_field(const std::string& s) {
  if (s.find_first_of(",\"\n\r") == std::string::npos) return s;
  std::string q = "\"";
  for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}

std::string csv_row(const std::string& level, const ModelResult& m, const DatasetResult& d,
                    const std::string& sequence, const WindowSummary& w) {
  const bool any = w.windows > 0;
  std::string r = level + "," + csv_field(m.path) + "," + csv_field(d.data) + "," +
                  csv_field(d.split) + "," + csv_field(sequence) + "," +
                  fmt("%g", window_ms(w.window_us)) + ",";
  r += any ? fmt("%.4f", w.iou_mean) + "," + fmt("%.4f", w.iou_std) + "," +
                 fmt("%.4f", w.detection_rate)
           : std::string(",,");
  r += "," + std::to_string(w.windows) + "," + std::to_string(w.skipped) + "," +
       std::to_string(w.sequences) + "," + (w.kalman ? "kalman" : "") + ",";
  const EventCounts& e = w.events;
  r += w.has_events && e.has_precision() ? fmt("%.4f", 100 * e.precision()) : "";
  r += ",";
  r += w.has_events && e.has_recall() ? fmt("%.4f", 100 * e.recall()) : "";
  if (w.has_events)
    r += "," + std::to_string(e.tp) + "," + std::to_string(e.fp) + "," + std::to_string(e.fn) +
         "," + std::to_string(e.tn);
  else
    r += ",,,,";
  r += ",";
  if (w.has_events && e.total() > 0) r += fmt("%.4f", 100 * e.moving_share());
  return r + "," + fmt("%g", m.output_threshold) + "," +
         fmt("%g", m.output_gate_steps * m.time_step_ms) + "," + std::to_string(w.filtered) + "\n";
}

// Display width of UTF-8 text (code points; the tables use ±, Δ and –).
size_t width(const std::string& s) {
  size_t n = 0;
  for (unsigned char c : s) n += (c & 0xC0) != 0x80;
  return n;
}

// A Markdown table whose columns line up in a terminal too.
std::string markdown_table(const std::vector<std::string>& head,
                           const std::vector<std::vector<std::string>>& rows) {
  std::vector<size_t> w(head.size(), 3);
  for (size_t c = 0; c < head.size(); ++c) w[c] = std::max(w[c], width(head[c]));
  for (const auto& r : rows)
    for (size_t c = 0; c < r.size(); ++c) w[c] = std::max(w[c], width(r[c]));
  auto line = [&](const std::vector<std::string>& cells) {
    std::string s = "|";
    for (size_t c = 0; c < cells.size(); ++c)
      s += " " + cells[c] + std::string(w[c] - width(cells[c]), ' ') + " |";
    return s + "\n";
  };
  std::string out = line(head) + "|";
  for (size_t c = 0; c < head.size(); ++c) out += std::string(w[c] + 2, '-') + "|";
  out += "\n";
  for (const auto& r : rows) out += line(r);
  return out;
}

std::vector<std::string> score_cells(const WindowSummary& w) {
  const EventCounts& e = w.events;
  std::string p = w.has_events && e.has_precision() ? fmt("%.1f", 100 * e.precision()) : "–";
  std::string rc = w.has_events && e.has_recall() ? fmt("%.1f", 100 * e.recall()) : "–";
  std::string mv = w.has_events && e.total() > 0 ? fmt("%.1f", 100 * e.moving_share()) : "–";
  if (w.windows == 0) return {"–", "–", p, rc, mv};
  return {fmt("%.1f", w.iou_mean) + " ± " + fmt("%.1f", w.iou_std), fmt("%.1f", w.detection_rate),
          p, rc, mv};
}

// "10", or "3 filtered" for a Kalman row.
std::string window_cell(const WindowSummary& w) {
  return fmt("%g", double(w.window_us) / 1000.0) + (w.kalman ? " filtered" : "");
}

std::string file_name(const std::string& path) {
  const std::string f = fs::path(path).filename().string();
  return f.empty() ? path : f;
}

}  // namespace

nlohmann::ordered_json results_json(const EvalResults& r) {
  nlohmann::ordered_json j;
  j["format"] = "spikems-eval-results";
  j["version"] = 1;
  j["command"] = r.command_line;
  j["date"] = r.date;
  j["working_directory"] = r.working_directory;
  nlohmann::ordered_json wins = nlohmann::ordered_json::array();
  for (int64_t w : r.windows_us) wins.push_back(window_ms(w));
  j["windows_ms"] = wins;
  nlohmann::ordered_json kal = nlohmann::ordered_json::array();
  for (int64_t w : r.kalman_us) kal.push_back(window_ms(w));
  j["kalman_ms"] = kal;
  j["max_seconds"] =
      r.max_seconds > 0 ? nlohmann::ordered_json(r.max_seconds) : nlohmann::ordered_json(nullptr);
  j["interrupted"] = r.interrupted;
  j["gate_events"] = r.gate_events;
  j["boxes"] = r.boxes.empty() ? nlohmann::ordered_json(nullptr) : nlohmann::ordered_json(r.boxes);
  j["static_scene"] = r.static_scene;
  j["share_bands_pct"] = r.share_bands_pct;
  j["min_moving_share_pct"] = r.min_moving_share_pct > 0
                                  ? nlohmann::ordered_json(r.min_moving_share_pct)
                                  : nlohmann::ordered_json(nullptr);
  j["group_windows"] = r.group_windows;
  j["keep_events"] = r.keep_events;
  j["protocol"] = {
      {"window_start", "first event of each sequence"},
      {"partial_last_window", "dropped"},
      {"prediction", r.gate_events
                         ? "pixels with input events in the window and an output spike at a step "
                           "whose start lies in the window (gate_events)"
                         : "pixels with an output spike at a step whose start lies in the window"},
      {"truth", r.static_scene ? "none: every event is background (static_scene)"
                : r.boxes.empty()
                    ? "pixels with input events labelled moving (label != 0) in the window"
                    : "pixels inside the boxes (file `boxes`) valid at some time in the window; "
                      "an event is truly moving when it lies in a box valid at its time"},
      {"iou", r.group_windows > 1
                  ? "|P and G| / |P or G| per group of group_windows consecutive windows, P and "
                    "G the unions over the group's scored windows (the SpikeMS authors' test); "
                    "each group counts once per scored window in the mean and population std"
                  : "|P and G| / |P or G| per window; mean and population std over windows"},
      {"detection", "0-MMS: |P and G| > 0.5 |G| and |P and G| > |P - G|"},
      {"skipped", "windows whose G is empty are not scored, only counted"},
      {"filtered",
       "with min_moving_share_pct: windows whose G is not empty but fewer than that percent of "
       "whose input events are truly moving are not scored, only counted (filtered_windows; "
       "the SpikeMS authors' test filter); the event counts still cover every window"},
      {"units",
       "iou, detection_rate, event_precision, event_recall and moving_share in percent (0-100)"},
      {"moving_share", "the share of all events the runtime labels moving"},
      {"share_bands",
       "the scored windows split by the share of their input events that are truly moving "
       "(edges share_bands_pct; a band is [share_min_pct, share_max_pct), the last one up to "
       "100 inclusive); null where no window was scored, where that share is unknown (boxes as "
       "truth) or with no edges"},
      {"events",
       "an event is predicted moving when the runtime labels it so (an output spike at its "
       "pixel within the label window: latency + " +
           std::to_string(r.label_tolerance_steps) +
           " steps), truly moving when its label != 0; counted over the whole windows of "
           "each length (scored and skipped)"},
      {"kalman",
       "filter = kalman rows: the predictions of successive windows of that length through a "
       "constant-velocity Kalman filter per blob; P = input-event pixels inside the filtered "
       "boxes"}};
  nlohmann::ordered_json models = nlohmann::ordered_json::array();
  for (const auto& m : r.models) {
    nlohmann::ordered_json jm;
    jm["model"] = m.path;
    jm["name"] = m.name;
    jm["time_step_ms"] = m.time_step_ms;
    jm["iir"] = m.iir;
    jm["time_step_scaled"] = m.time_step_scaled;
    jm["downsample"] = m.downsample;
    jm["output_threshold_scale"] = m.output_threshold;
    jm["output_gate_ms"] = m.output_gate_steps * m.time_step_ms;
    nlohmann::ordered_json ds = nlohmann::ordered_json::array();
    for (const auto& d : m.datasets) {
      nlohmann::ordered_json jd;
      jd["data"] = d.data;
      jd["split"] =
          d.split.empty() ? nlohmann::ordered_json(nullptr) : nlohmann::ordered_json(d.split);
      jd["sequences"] = d.sequences.size();
      jd["events"] = d.events;
      jd["windows"] = nlohmann::ordered_json::array();
      for (const auto& w : d.windows) jd["windows"].push_back(row_json(w, true));
      jd["per_sequence"] = nlohmann::ordered_json::array();
      for (const auto& s : d.sequences) {
        nlohmann::ordered_json js;
        js["sequence"] = s.name;
        js["events"] = s.events;
        js["duration_s"] = s.duration_s;
        js["windows"] = nlohmann::ordered_json::array();
        for (const auto& w : s.windows) js["windows"].push_back(row_json(w, false));
        jd["per_sequence"].push_back(std::move(js));
      }
      ds.push_back(std::move(jd));
    }
    jm["datasets"] = std::move(ds);
    models.push_back(std::move(jm));
  }
  j["models"] = std::move(models);
  return j;
}

std::string results_csv(const EvalResults& r) {
  std::string out =
      "level,model,data,split,sequence,window_ms,iou_mean,iou_std,detection_rate,windows,"
      "skipped_windows,sequences,filter,event_precision,event_recall,events_tp,events_fp,"
      "events_fn,events_tn,moving_share,output_threshold_scale,output_gate_ms,filtered_windows\n";
  for (const auto& m : r.models)
    for (const auto& d : m.datasets) {
      for (const auto& w : d.windows) out += csv_row("dataset", m, d, "", w);
      for (const auto& s : d.sequences)
        for (const auto& w : s.windows) out += csv_row("sequence", m, d, s.name, w);
    }
  return out;
}

std::string model_file_label(const EvalResults& r, const std::string& path) {
  for (const auto& o : r.models)
    if (o.path != path && file_name(o.path) == file_name(path)) return path;
  return file_name(path);
}

std::string model_label(const EvalResults& r, const ModelResult& m) {
  const std::string name =
      model_file_label(r, m.path) +
      (m.time_step_scaled ? " at " + fmt("%g", m.time_step_ms) + " ms steps" : "") +
      (m.downsample > 1    ? " at 1/" + std::to_string(m.downsample) + " resolution"
       : m.downsample == 0 ? " at mixed resolutions"
                           : "");
  const std::string gate = m.output_gate_steps > 0
                               ? " gate " + fmt("%g", m.output_gate_steps * m.time_step_ms) + " ms"
                               : "";
  return (m.output_threshold == 1 ? name : name + " θ×" + fmt("%g", m.output_threshold)) + gate;
}

TextTable summary_table(const EvalResults& r) {
  TextTable t;
  const bool filter = r.min_moving_share_pct > 0;
  t.header = {"model",       "data",      "split",     "Δt ms",    "IoU % (mean ± std)",
              "detection %", "event P %", "event R %", "moving %", "windows",
              "skipped",     "sequences"};
  if (filter) t.header.insert(t.header.end() - 1, "filtered");
  for (const auto& m : r.models)
    for (const auto& d : m.datasets)
      for (const auto& w : d.windows) {
        auto sc = score_cells(w);
        std::vector<std::string> row = {model_label(r, m),
                                        d.data,
                                        d.split.empty() ? "–" : d.split,
                                        window_cell(w),
                                        sc[0],
                                        sc[1],
                                        sc[2],
                                        sc[3],
                                        sc[4],
                                        std::to_string(w.windows),
                                        std::to_string(w.skipped),
                                        std::to_string(w.sequences)};
        if (filter) row.insert(row.end() - 1, std::to_string(w.filtered));
        t.rows.push_back(std::move(row));
      }
  return t;
}

TextTable sequence_table(const EvalResults& r) {
  TextTable t;
  t.header = {"model",       "sequence",  "Δt ms",     "IoU % (mean ± std)",
              "detection %", "event P %", "event R %", "moving %",
              "windows",     "skipped"};
  for (const auto& m : r.models)
    for (const auto& d : m.datasets)
      for (const auto& s : d.sequences)
        for (const auto& w : s.windows) {
          auto sc = score_cells(w);
          t.rows.push_back({model_label(r, m), file_name(s.name), window_cell(w), sc[0], sc[1],
                            sc[2], sc[3], sc[4], std::to_string(w.windows),
                            std::to_string(w.skipped)});
        }
  return t;
}

TextTable band_table(const EvalResults& r) {
  TextTable t;
  bool any = false;
  for (const auto& m : r.models)
    for (const auto& d : m.datasets)
      for (const auto& w : d.windows) any = any || !w.bands.empty();
  if (!any) return t;
  t.header = {"model", "data", "split", "Δt ms"};
  for (const BandSummary& band : bands_of(r.share_bands_pct))
    t.header.push_back(band_name(band) + ": IoU % (detection %, windows)");
  for (const auto& m : r.models)
    for (const auto& d : m.datasets)
      for (const auto& w : d.windows) {
        if (w.bands.empty()) continue;
        std::vector<std::string> row = {model_label(r, m), d.data, d.split.empty() ? "–" : d.split,
                                        window_cell(w)};
        for (const BandSummary& b : w.bands)
          row.push_back(b.windows == 0
                            ? "– (–, 0)"
                            : fmt("%.1f", b.iou_mean) + " (" + fmt("%.1f", b.detection_rate) +
                                  ", " + std::to_string(b.windows) + ")");
        t.rows.push_back(std::move(row));
      }
  return t;
}

std::string results_table(const EvalResults& r) {
  const TextTable t = summary_table(r);
  return markdown_table(t.header, t.rows);
}

std::string band_results_table(const EvalResults& r) {
  const TextTable t = band_table(r);
  return t.rows.empty() ? std::string() : markdown_table(t.header, t.rows);
}

std::string results_markdown(const EvalResults& r) {
  std::string out = "# spikems eval\n\n";
  out += "- command: `" + r.command_line + "`\n";
  out += "- date: " + r.date + "\n";
  for (const auto& m : r.models)
    out +=
        "- model: `" + m.path + "` (" + m.name + ", time step " + fmt("%g", m.time_step_ms) +
        " ms" + (m.time_step_scaled ? " (time constants scaled with it)" : "") +
        (m.iir ? ", FIR layers run as IIR" : "") +
        (m.downsample > 1 ? ", the network sees the sensor at 1/" + std::to_string(m.downsample) +
                                " resolution and is scored on that grid"
         : m.downsample == 0 ? ", downsampled differently per sensor size (auto)"
                             : "") +
        (m.output_threshold != 1 ? ", output θ × " + fmt("%g", m.output_threshold) : "") +
        (m.output_gate_steps > 0
             ? ", output gate " + fmt("%g", m.output_gate_steps * m.time_step_ms) + " ms"
             : "") +
        ")\n";
  if (r.max_seconds > 0) out += "- first " + fmt("%g", r.max_seconds) + " s of each sequence\n";
  if (r.gate_events)
    out +=
        "- gated by events: P = pixels with an output spike *and* an input event in the window\n";
  if (r.static_scene)
    out +=
        "- static scene: every event is background; the score is `moving %`, the share of "
        "events labelled moving (IoU and detection are undefined)\n";
  if (!r.boxes.empty())
    out += "- ground truth from boxes (`" + r.boxes +
           "`): G = the pixels inside the boxes valid in the window\n";
  if (r.min_moving_share_pct > 0)
    out += "- only windows in which at least " + fmt("%g", r.min_moving_share_pct) +
           " % of the input events are truly moving are scored (the SpikeMS authors' test "
           "filter; the others are counted as `filtered`)\n";
  if (r.keep_events < 1)
    out += "- every sequence thinned first: each event kept with probability " +
           fmt("%g", r.keep_events) + " (seed 0), labels and all\n";
  if (r.group_windows > 1)
    out += "- windows scored in groups of " + std::to_string(r.group_windows) +
           " consecutive ones: IoU and detection of the unions of P and G over a group's "
           "scored windows, counted once per window (the SpikeMS authors' test)\n";
  if (r.interrupted) out += "- **interrupted**: the sequences finished before Ctrl-C only\n";
  const std::string g = r.boxes.empty() ? "pixels with moving-object events"
                                        : "pixels inside the boxes valid in the window";
  out += "\nIoU of the pixels with output spikes (steps starting in the window) against the " + g +
         ", per window from each sequence's first event (the partial last window dropped); mean ± "
         "std over all scored windows of a dataset; detection = 0-MMS. Windows without moving "
         "objects are skipped (counted). See docs/evaluation.md.\n\n";
  out += results_table(r);
  const std::string bands = band_results_table(r);
  if (!bands.empty()) {
    out +=
        "\n## By the moving share of a window's events\n\nThe scored windows split by the "
        "share of their input events that are truly moving (small objects or dense "
        "texture: a low share). See docs/evaluation.md, \"Size bands\".\n\n";
    out += bands;
  }
  out += "\n## Per sequence\n\n";
  const TextTable t = sequence_table(r);
  out += markdown_table(t.header, t.rows);
  return out;
}

void write_results(const EvalResults& r, const std::string& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) fail(dir, "", "cannot create the output folder: " + ec.message());
  write_file_atomic((fs::path(dir) / "results.json").string(), results_json(r).dump(2) + "\n");
  write_file_atomic((fs::path(dir) / "results.csv").string(), results_csv(r));
  write_file_atomic((fs::path(dir) / "results.md").string(), results_markdown(r));
}

}  // namespace spikems
