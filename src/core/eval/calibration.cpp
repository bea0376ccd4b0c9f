#include "core/eval/calibration.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/eval/results.h"
#include "core/model/output_threshold.h"
#include "core/util/error.h"
#include "core/util/text_format.h"

namespace spikems {

CalibrationResult calibrate(const CalibrationOptions& opt) {
  if (opt.criterion != "event-iou" && opt.criterion != "iou")
    fail("--criterion", "", "'" + opt.criterion + "' is not a criterion: use event-iou or iou");
  if (opt.factors.empty()) fail("--factors", "", "no factor to try");
  std::vector<double> factors = opt.factors;
  std::sort(factors.begin(), factors.end());
  EvalOptions e;
  e.models = {opt.model};
  e.data = opt.data;
  e.split = opt.split;
  e.windows_us = {opt.window_us};
  e.output_thresholds = factors;
  e.output_gates_us = opt.gates_us;
  std::sort(e.output_gates_us.begin(), e.output_gates_us.end());
  e.threads = opt.threads;
  e.max_seconds = opt.max_seconds;
  e.progress = opt.progress;
  e.command_line = opt.command_line;
  CalibrationResult r;
  r.eval = evaluate(e);
  if (r.eval.interrupted) fail("spikems calibrate", "", "interrupted: no model written");
  for (const ModelResult& m : r.eval.models) {
    CalibrationPoint p;
    p.factor = m.output_threshold;
    p.gate_steps = m.output_gate_steps;
    p.gate_ms = m.output_gate_steps * m.time_step_ms;
    EventCounts ev;
    double iou_sum = 0;
    for (const DatasetResult& d : m.datasets) {
      const WindowSummary& w = d.windows.at(0);
      iou_sum += w.iou_mean * double(w.windows);
      p.windows += w.windows;
      ev += w.events;
    }
    if (p.windows == 0)
      fail(opt.model, "",
           "no window of the data has moving objects: calibrating needs labelled moving "
           "events (check --data and --split)");
    p.iou = iou_sum / double(p.windows);
    const double union_ = double(ev.tp + ev.fp + ev.fn);
    p.event_iou = union_ > 0 ? 100 * double(ev.tp) / union_ : 0;
    p.precision = 100 * ev.precision();
    p.recall = 100 * ev.recall();
    p.moving = 100 * ev.moving_share();
    p.score = opt.criterion == "iou" ? p.iou : p.event_iou;
    r.points.push_back(p);
  }
  for (size_t i = 1; i < r.points.size(); ++i) {
    const CalibrationPoint &a = r.points[i], &b = r.points[r.best];
    // Ties (within rounding): the factor nearer 1, then the shorter gate.
    const double la = std::abs(std::log(a.factor)), lb = std::abs(std::log(b.factor));
    const bool better = a.score > b.score + 1e-9 ||
                        (a.score >= b.score - 1e-9 &&
                         (la < lb - 1e-12 || (la <= lb + 1e-12 && a.gate_steps < b.gate_steps)));
    if (better) r.best = i;
  }
  return r;
}

ModelSpec calibrated_model(const CalibrationOptions& opt, const CalibrationResult& r) {
  const CalibrationPoint& best = r.points.at(r.best);
  ModelSpec m = with_output_threshold(load_model(opt.model), best.factor, opt.model);
  m.output_gate_steps = best.gate_steps;  // the model's own when no gate was swept
  double before = 1;
  nlohmann::json previous;  // an earlier calibration's record, kept inside the new one
  if (m.training.is_object() && m.training.contains("calibration")) {
    previous = m.training["calibration"];
    if (previous.contains("output_threshold_scale"))
      before = previous["output_threshold_scale"].get<double>();
  }
  nlohmann::json table = nlohmann::json::array();
  for (const auto& p : r.points)
    table.push_back({{"factor", p.factor},
                     {"output_gate_ms", p.gate_ms},
                     {"iou", p.iou},
                     {"event_iou", p.event_iou},
                     {"event_precision", p.precision},
                     {"event_recall", p.recall},
                     {"moving_share", p.moving},
                     {"windows", p.windows}});
  if (!m.training.is_object()) m.training = nlohmann::json::object();
  m.training["calibration"] = {{"factor", best.factor},
                               {"output_threshold_scale", before * best.factor},
                               {"output_gate_ms", best.gate_ms},
                               {"criterion", opt.criterion},
                               {"score", best.score},
                               {"data", opt.data},
                               {"split", opt.split},
                               {"window_ms", double(opt.window_us) / 1000.0},
                               {"max_seconds", opt.max_seconds},
                               {"points", table},
                               {"command", opt.command_line},
                               {"date", r.eval.date},
                               {"source_model", opt.model}};
  if (!previous.is_null()) m.training["calibration"]["previous"] = std::move(previous);
  return m;
}

std::string calibration_table(const CalibrationOptions& opt, const CalibrationResult& r) {
  const bool gates = !opt.gates_us.empty();
  std::string out = std::string("| factor |") + (gates ? " gate ms |" : "") + " IoU % (" +
                    fmt("%g", double(opt.window_us) / 1000.0) +
                    " ms) | event IoU % | event P % | event R % | moving % | |\n";
  out += gates ? "|---|---|---|---|---|---|---|---|\n" : "|---|---|---|---|---|---|---|\n";
  for (size_t i = 0; i < r.points.size(); ++i) {
    const CalibrationPoint& p = r.points[i];
    out += "| " + fmt("%g", p.factor) + " | " + (gates ? fmt("%g", p.gate_ms) + " | " : "") +
           fmt("%.1f", p.iou) + " | " + fmt("%.1f", p.event_iou) + " | " +
           fmt("%.1f", p.precision) + " | " + fmt("%.1f", p.recall) + " | " +
           fmt("%.1f", p.moving) + " | " + (i == r.best ? "chosen (" + opt.criterion + ")" : "") +
           " |\n";
  }
  return out;
}

}  // namespace spikems
