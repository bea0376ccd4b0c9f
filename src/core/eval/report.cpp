#include "core/eval/report.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>

#include "core/util/error.h"
#include "core/util/text_format.h"
#include "core/viz/event_frame.h"
#include "core/viz/html_report.h"
#include "core/viz/svg_plot.h"

namespace spikems {

namespace fs = std::filesystem;

int64_t example_window_length(const std::vector<int64_t>& windows_us) {
  constexpr int64_t kPreferred = 20000;
  int64_t best = 0;
  for (int64_t w : windows_us) {
    const int64_t d = std::llabs(w - kPreferred), bd = std::llabs(best - kPreferred);
    if (best == 0 || d < bd || (d == bd && w < best)) best = w;
  }
  return best;
}

Image example_image(const ExampleWindow& w) {
  const size_t px = size_t(w.width) * size_t(w.height);
  if (w.width <= 0 || w.height <= 0 || w.truth.size() != px || w.events.width != w.width ||
      w.events.height != w.height)
    fail("report", "", "example window with inconsistent sizes");
  // Small sensors are enlarged so that a window is large enough to see; real ones (346 and
  // 640 pixels wide) stay at 1:1.
  const int scale = std::clamp(256 / w.width, 1, 4);
  std::vector<Image> panels;
  panels.push_back(upscale(w.events, scale));
  RenderOptions ro;
  ro.scale = scale;
  panels.push_back(render_mask(w.truth, w.width, w.height, nullptr, ro));
  for (const auto& p : w.predicted) {
    if (p.size() != px) fail("report", "", "example window with inconsistent sizes");
    panels.push_back(render_comparison(p, w.truth, w.width, w.height, scale));
  }
  return framed_row(panels);
}

namespace {

std::string ms(int64_t us) {
  return fmt("%g", double(us) / 1000.0);
}

// A file-name-safe form of a sequence's name (letters, digits, '-', '_' and '.').
std::string slug(const std::string& s) {
  std::string out;
  for (char c : s)
    out +=
        (std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.') ? c : '_';
  return out.empty() ? "sequence" : out;
}

std::string file_name(const std::string& path) {
  const std::string f = fs::path(path).filename().string();
  return f.empty() ? path : f;
}

// The scored windows of a run on a dataset, as plotted: IoU mean ± std per window length.
// Rows without a scored window are left out of the line (they have no IoU).
PlotSeries iou_series(const std::string& label, const DatasetResult& d) {
  PlotSeries s;
  s.label = label;
  for (const auto& w : d.windows)
    if (w.windows > 0) {
      s.x.push_back(double(w.window_us) / 1000.0);
      s.y.push_back(w.iou_mean);
      s.err.push_back(w.iou_std);
    }
  return s;
}

// The operating points of the runs of one model file with one output gate on a dataset (one per
// output-threshold factor, output_threshold.h), in factor order, from the first window length's
// event counts: event precision against recall, or on a static scene the share labelled moving
// against the factor. Fewer than two points: no series (a single point is no curve).
PlotSeries operating_points(const EvalResults& r, const std::string& path, int gate, size_t d,
                            bool static_scene) {
  std::vector<std::pair<double, const WindowSummary*>> pts;
  const ModelResult* any = nullptr;
  for (const auto& m : r.models)
    if (m.path == path && m.output_gate_steps == gate && d < m.datasets.size() &&
        !m.datasets[d].windows.empty() && m.datasets[d].windows[0].has_events)
      pts.push_back({m.output_threshold, &m.datasets[d].windows[0]}), any = &m;
  std::sort(pts.begin(), pts.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  PlotSeries s;
  s.label = model_file_label(r, path);
  if (gate > 0 && any) s.label += " gate " + fmt("%g", gate * any->time_step_ms) + " ms";
  for (const auto& [scale, w] : pts) {
    const EventCounts& e = w->events;
    if (static_scene) {
      if (e.total() == 0) continue;
      s.x.push_back(scale);
      s.y.push_back(100 * e.moving_share());
    } else if (e.has_recall() && e.has_precision()) {
      s.x.push_back(100 * e.recall());
      s.y.push_back(100 * e.precision());
    }
  }
  if (s.x.size() < 2) s.x.clear(), s.y.clear();
  return s;
}

}  // namespace

std::string write_report(const EvalResults& r, const EvalExamples& ex, const std::string& dir) {
  std::error_code ec;
  const fs::path root(dir);
  fs::create_directories(root / "plots", ec);
  if (!ec) fs::create_directories(root / "windows", ec);
  if (ec) fail(dir, "", "cannot create the report's folders: " + ec.message());

  HtmlReport page("spikems evaluation report");
  page.paragraph("Command (run " + r.date + ", in " + r.working_directory + "):");
  page.code(r.command_line);
  std::string models;
  for (const auto& m : r.models)
    models += (models.empty() ? "" : "; ") + model_label(r, m) + " (" + m.name +
              (m.time_step_ms > 0 ? ", time step " + fmt("%g", m.time_step_ms) + " ms" : "") +
              (m.iir ? ", FIR layers run as IIR" : "") + ")";
  page.paragraph("Models: " + models + ".");
  if (r.max_seconds > 0)
    page.paragraph("Only the first " + fmt("%g", r.max_seconds) + " s of each sequence scored.");
  if (r.min_moving_share_pct > 0)
    page.paragraph("Only windows in which at least " + fmt("%g", r.min_moving_share_pct) +
                   " % of the input events are truly moving are scored (the SpikeMS authors' "
                   "test filter); the others are counted as filtered.");
  if (r.keep_events < 1)
    page.paragraph("Every sequence thinned first: each event kept with probability " +
                   fmt("%g", r.keep_events) + " (seed 0), labels and all.");
  if (r.group_windows > 1)
    page.paragraph("Windows scored in groups of " + std::to_string(r.group_windows) +
                   " consecutive ones: IoU and detection of the unions of P and G over a "
                   "group's scored windows, counted once per window (the SpikeMS authors' "
                   "test).");
  if (r.interrupted)
    page.paragraph("Interrupted (Ctrl-C): only the sequences finished before it are in.");
  const std::string g = r.boxes.empty() ? "pixels with moving-object events"
                                        : "pixels inside the boxes valid in the window";
  page.paragraph(
      "IoU of the pixels with output spikes (steps starting in the window) against the " + g +
      ", per window from each sequence's first event (the partial last window dropped); mean ± "
      "std over all scored windows of a dataset; detection = 0-MMS. Windows without moving "
      "objects are skipped (counted). See docs/evaluation.md.");

  page.heading("Scores");
  const TextTable summary = summary_table(r);
  page.table(summary.header, summary.rows, "per dataset and window length");
  const TextTable bands = band_table(r);
  if (!bands.rows.empty())
    page.table(bands.header, bands.rows,
               "by the share of a window's input events that are truly moving (small objects "
               "or dense texture: a low share)");

  // Plots: one per dataset (the runs share the datasets, in the same order).
  const size_t datasets = r.models.empty() ? 0 : r.models[0].datasets.size();
  const int64_t shown_us = ex.window_us > 0 ? ex.window_us : example_window_length(r.windows_us);
  if (datasets > 0) page.heading("Plots");
  for (size_t d = 0; d < datasets; ++d) {
    const std::string data = r.models[0].datasets[d].data;
    std::vector<PlotSeries> lines;
    for (const auto& m : r.models)
      if (d < m.datasets.size()) lines.push_back(iou_series(model_label(r, m), m.datasets[d]));
    PlotOptions lo;
    lo.title = "IoU against window length: " + file_name(data);
    lo.x_label = "window length (ms)";
    lo.y_label = "IoU % (mean ± std)";
    const std::string line_file = "plots/iou_by_window_" + std::to_string(d + 1) + ".svg";
    write_svg((root / line_file).string(), svg_line_plot(lines, lo));
    page.image(line_file, "IoU (mean ± std over scored windows) against window length, " + data);

    // Per-sequence bars at the length the example windows use.
    size_t wi = 0;
    while (wi < r.windows_us.size() && r.windows_us[wi] != shown_us) ++wi;
    if (wi == r.windows_us.size()) continue;

    // Size bands at the same length: a group of bars per band, one bar per model.
    const WindowSummary& first = r.models[0].datasets[d].windows.at(wi);
    if (!first.bands.empty()) {
      std::vector<std::string> bands;
      for (const BandSummary& b : first.bands) bands.push_back(band_name(b));
      std::vector<PlotSeries> per_model;
      for (const auto& m : r.models) {
        if (d >= m.datasets.size() || m.datasets[d].windows.at(wi).bands.size() != bands.size())
          continue;
        PlotSeries b;
        b.label = model_label(r, m);
        for (const BandSummary& band : m.datasets[d].windows.at(wi).bands)
          b.y.push_back(band.windows > 0 ? band.iou_mean : 0.0);
        per_model.push_back(std::move(b));
      }
      PlotOptions so;
      so.title = "IoU by the moving share of the window's events, " + ms(shown_us) +
                 " ms windows: " + file_name(data);
      so.x_label = "share of the window's events that move";
      so.y_label = "IoU % (mean)";
      so.y_min = 0;
      so.y_max = 100;  // IoU's whole range: the bands compare across plots, and the legend
                       // (top right) stays clear of the bars
      so.width = 760;  // room for model file names in the legend
      const std::string band_file = "plots/iou_by_share_" + std::to_string(d + 1) + ".svg";
      write_svg((root / band_file).string(), svg_bar_plot(bands, per_model, so));
      page.image(band_file, "IoU per size band (" + ms(shown_us) + " ms windows), " + data);
    }

    std::vector<std::string> names;
    for (const auto& s : r.models[0].datasets[d].sequences) names.push_back(file_name(s.name));
    if (names.empty()) continue;
    std::vector<PlotSeries> bars;
    for (const auto& m : r.models) {
      if (d >= m.datasets.size()) continue;
      PlotSeries b;
      b.label = model_label(r, m);
      for (const auto& s : m.datasets[d].sequences) {
        const WindowSummary& w = s.windows.at(wi);
        b.y.push_back(w.windows > 0 ? w.iou_mean : 0.0);  // no scored window: an empty bar
      }
      bars.push_back(std::move(b));
    }
    PlotOptions bo;
    bo.title = "IoU per sequence, " + ms(shown_us) + " ms windows: " + file_name(data);
    bo.x_label = "sequence";
    bo.y_label = "IoU % (mean)";
    bo.y_min = 0;
    bo.width = std::max(640, int(names.size()) * (24 + 14 * int(bars.size())) + 90);
    const std::string bar_file = "plots/iou_per_sequence_" + std::to_string(d + 1) + ".svg";
    write_svg((root / bar_file).string(), svg_bar_plot(names, bars, bo));
    page.image(bar_file, "IoU per sequence (" + ms(shown_us) + " ms windows), " + data);
  }

  // Operating points: a curve per model file scored at several output-threshold factors.
  // (A curve per output gate too.)
  std::vector<std::pair<std::string, int>> swept;
  for (const auto& m : r.models) {
    const std::pair<std::string, int> key{m.path, m.output_gate_steps};
    if (m.output_threshold != 1 && std::find(swept.begin(), swept.end(), key) == swept.end())
      swept.push_back(key);
  }
  for (size_t d = 0; d < datasets && !swept.empty(); ++d) {
    std::vector<PlotSeries> curves;
    for (const auto& [p, gate] : swept) {
      PlotSeries c = operating_points(r, p, gate, d, r.static_scene);
      if (!c.x.empty()) curves.push_back(std::move(c));
    }
    if (curves.empty()) continue;
    // The all-events baseline as a reference point: recall 100 %, precision = the base rate.
    for (const auto& m : r.models)
      if (!r.static_scene && m.path.rfind("baseline:", 0) == 0 && d < m.datasets.size() &&
          !m.datasets[d].windows.empty() && m.datasets[d].windows[0].has_events &&
          m.datasets[d].windows[0].events.has_precision()) {
        PlotSeries b;
        b.label = m.name;
        b.x = {100 * m.datasets[d].windows[0].events.recall()};
        b.y = {100 * m.datasets[d].windows[0].events.precision()};
        curves.push_back(std::move(b));
      }
    const std::string data = r.models[0].datasets[d].data;
    const std::string w = ms(r.windows_us.at(0));
    PlotOptions po;
    po.y_min = 0;
    po.width = 760;
    std::string caption;
    if (r.static_scene) {
      po.title = "Share labelled moving against the output threshold: " + file_name(data);
      po.x_label = "output threshold factor (θ ×)";
      po.y_label = "events labelled moving %";
      caption = "Share of the events labelled moving at each output-threshold factor (" + w +
                " ms windows), " + data;
    } else {
      po.title = "Event precision against recall: " + file_name(data);
      po.x_label = "event recall %";
      po.y_label = "event precision %";
      po.y_max = 100;
      caption =
          "Event precision against recall, one point per output-threshold factor (the "
          "factor rises to the left; " +
          w + " ms windows), " + data;
    }
    const std::string file = "plots/operating_points_" + std::to_string(d + 1) + ".svg";
    write_svg((root / file).string(), svg_line_plot(curves, po));
    page.image(file, caption);
  }

  page.heading("Per sequence");
  const TextTable per_seq = sequence_table(r);
  page.table(per_seq.header, per_seq.rows, "per sequence and window length");

  // Example windows.
  bool any = false;
  for (const auto& ds : ex.datasets)
    for (const auto& s : ds) any = any || !s.windows.empty();
  if (any) {
    page.heading("Windows");
    std::string panels =
        "input events (ON red, OFF blue) | ground truth (" +
        std::string(r.boxes.empty() ? "pixels with moving-object events" : "box pixels") +
        ", dark grey)";
    for (const auto& m : r.models) panels += " | " + model_label(r, m);
    page.paragraph(
        "A few " + ms(ex.window_us) +
        " ms windows per sequence, evenly spaced over those with moving objects: " + panels +
        ". Prediction panels: green = predicted and moving, orange = predicted but not moving, "
        "blue = moving but missed. Predictions are the ones scored above (same pass).");
  }
  std::map<std::string, int> used;  // file names already taken
  for (size_t d = 0; d < ex.datasets.size(); ++d)
    for (const auto& s : ex.datasets[d]) {
      if (s.windows.empty()) continue;
      page.heading(s.name, 3);
      std::string base = slug(fs::path(s.name).stem().string());
      const int n = used[base]++;
      if (n > 0) base += "_" + std::to_string(n + 1);
      for (const auto& w : s.windows) {
        char start[32];  // zero-padded: the files sort in time order
        std::snprintf(start, sizeof start, "%09lld", static_cast<long long>(w.t0_us));
        const std::string file = "windows/" + base + "_" + start + "us.png";
        write_png((root / file).string(), example_image(w));
        std::string caption = ms(w.t0_us) + "–" + ms(w.t1_us) + " ms:";
        for (size_t i = 0; i < w.counts.size() && i < r.models.size(); ++i) {
          const MaskCounts& c = w.counts[i];
          caption += " " + model_label(r, r.models[i]) + " IoU " +
                     (c.truth > 0 ? fmt("%.1f", 100 * iou(c)) + " %" : std::string("–")) +
                     (i + 1 < w.counts.size() ? ";" : "");
        }
        page.image(file, caption);
      }
    }

  const std::string path = (root / "report.html").string();
  page.write(path);
  return path;
}

}  // namespace spikems
