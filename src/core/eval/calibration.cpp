#include "core/eval/calibration.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>

#include "core/eval/results.h"
#include "core/model/output_threshold.h"
#include "core/model/time_step.h"
#include "core/util/error.h"
#include "core/util/text_format.h"

namespace spikems {

namespace {
// A point may be chosen: no static scenes were given, or it stays within their budget.
bool within_budget(const CalibrationOptions& opt, const CalibrationPoint& p) {
  return opt.static_data.empty() || p.static_moving <= opt.max_static_moving + 1e-9;
}
}  // namespace

CalibrationResult calibrate(const CalibrationOptions& opt) {
  if (opt.criterion != "event-iou" && opt.criterion != "iou" && opt.criterion != "detection" &&
      opt.criterion != "recall")
    fail("--criterion", "",
         "'" + opt.criterion + "' is not a criterion: use event-iou, iou, detection or recall");
  if (opt.factors.empty()) fail("--factors", "", "no factor to try");
  if (!(opt.max_static_moving >= 0 && opt.max_static_moving <= 100))
    fail("--max-static-moving", "", "must be a percentage between 0 and 100");
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
  e.downsample = opt.downsample;
  e.train_width = opt.train_width;
  e.train_height = opt.train_height;
  e.time_step_ms = opt.time_step_ms;
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
    double iou_sum = 0, detected = 0;
    for (const DatasetResult& d : m.datasets) {
      const WindowSummary& w = d.windows.at(0);
      iou_sum += w.iou_mean * double(w.windows);
      detected += w.detection_rate * double(w.windows);
      p.windows += w.windows;
      ev += w.events;
    }
    if (p.windows == 0)
      fail(opt.model, "",
           "no window of the data has moving objects: calibrating needs labelled moving "
           "events (check --data and --split)");
    p.iou = iou_sum / double(p.windows);
    p.detection = detected / double(p.windows);
    const double union_ = double(ev.tp + ev.fp + ev.fn);
    p.event_iou = union_ > 0 ? 100 * double(ev.tp) / union_ : 0;
    p.precision = 100 * ev.precision();
    p.recall = 100 * ev.recall();
    p.moving = 100 * ev.moving_share();
    p.score = opt.criterion == "iou"         ? p.iou
              : opt.criterion == "detection" ? p.detection
              : opt.criterion == "recall"    ? p.recall
                                             : p.event_iou;
    r.points.push_back(p);
  }
  if (!opt.static_data.empty()) {
    // The same factors and gates (so the same point order) on scenes where nothing moves:
    // whatever is called moving there is a false call.
    e.data = opt.static_data;
    e.split = "all";
    e.static_scene = true;
    const EvalResults still = evaluate(e);
    if (still.interrupted) fail("spikems calibrate", "", "interrupted: no model written");
    if (still.models.size() != r.points.size())
      fail("spikems calibrate", "", "internal error: static scenes scored at other points");
    for (size_t i = 0; i < r.points.size(); ++i) {
      EventCounts calls;
      for (const DatasetResult& d : still.models[i].datasets)
        if (d.windows.at(0).has_events) calls += d.windows.at(0).events;
      if (calls.total() == 0)
        fail("--static", "", "the static scenes have no event in a whole window: give longer ones");
      r.points[i].static_moving = 100 * calls.moving_share();
    }
  }
  std::optional<size_t> best;
  for (size_t i = 0; i < r.points.size(); ++i) {
    if (!within_budget(opt, r.points[i])) continue;
    if (!best) {
      best = i;
      continue;
    }
    const CalibrationPoint &a = r.points[i], &b = r.points[*best];
    // Ties (within rounding): the factor nearer 1, then the shorter gate.
    const double la = std::abs(std::log(a.factor)), lb = std::abs(std::log(b.factor));
    const bool better = a.score > b.score + 1e-9 ||
                        (a.score >= b.score - 1e-9 &&
                         (la < lb - 1e-12 || (la <= lb + 1e-12 && a.gate_steps < b.gate_steps)));
    if (better) best = i;
  }
  if (!best) {
    const auto low = std::min_element(r.points.begin(), r.points.end(),
                                      [](const CalibrationPoint& a, const CalibrationPoint& b) {
                                        return a.static_moving < b.static_moving;
                                      });
    fail("--max-static-moving", "",
         "no factor calls at most " + fmt("%g", opt.max_static_moving) +
             " % of the static scenes moving (the lowest: " + fmt("%.1f", low->static_moving) +
             " % at factor " + fmt("%g", low->factor) + ", gate " + fmt("%g", low->gate_ms) +
             " ms): try larger --factors, a gate (--gates) or a higher budget");
  }
  r.best = *best;
  return r;
}

ModelSpec calibrated_model(const CalibrationOptions& opt, const CalibrationResult& r) {
  const CalibrationPoint& best = r.points.at(r.best);
  ModelSpec m = load_model(opt.model);
  const double file_step_ms = m.time_step_ms;
  if (opt.time_step_ms > 0)
    m = with_time_step(std::move(m), opt.time_step_ms, TimeConstants::Steps, opt.model);
  m = with_output_threshold(std::move(m), best.factor, opt.model);
  m.output_gate_steps = best.gate_steps;            // the model's own when no gate was swept
  if (opt.train_width > 0 && m.train_width == 0) {  // as it was scored (EvalOptions)
    m.train_width = opt.train_width;
    m.train_height = opt.train_height;
  }
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
  if (!opt.static_data.empty())
    for (size_t i = 0; i < r.points.size(); ++i)
      table[i]["static_moving"] = r.points[i].static_moving;
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
  if (m.time_step_ms != file_step_ms)
    m.training["calibration"]["source_time_step_ms"] = file_step_ms;
  if (!opt.static_data.empty()) {
    m.training["calibration"]["static_data"] = opt.static_data;
    m.training["calibration"]["max_static_moving"] = opt.max_static_moving;
    m.training["calibration"]["static_moving"] = best.static_moving;
  }
  if (!previous.is_null()) m.training["calibration"]["previous"] = std::move(previous);
  return m;
}

std::string calibration_table(const CalibrationOptions& opt, const CalibrationResult& r) {
  const bool gates = !opt.gates_us.empty(), statics = !opt.static_data.empty();
  std::string out = std::string("| factor |") + (gates ? " gate ms |" : "") + " IoU % (" +
                    fmt("%g", double(opt.window_us) / 1000.0) +
                    " ms) | detection % | event IoU % | event P % | event R % | moving % |" +
                    (statics ? " static moving % |" : "") + " |\n";
  out += "|---|---|---|---|---|---|---|---|";
  out += std::string(gates ? "---|" : "") + (statics ? "---|" : "") + "\n";
  for (size_t i = 0; i < r.points.size(); ++i) {
    const CalibrationPoint& p = r.points[i];
    out +=
        "| " + fmt("%g", p.factor) + " | " + (gates ? fmt("%g", p.gate_ms) + " | " : "") +
        fmt("%.1f", p.iou) + " | " + fmt("%.1f", p.detection) + " | " + fmt("%.1f", p.event_iou) +
        " | " + fmt("%.1f", p.precision) + " | " + fmt("%.1f", p.recall) + " | " +
        fmt("%.1f", p.moving) + " | " +
        (statics ? fmt("%.1f", p.static_moving) + (within_budget(opt, p) ? "" : " (over)") + " | "
                 : "") +
        (i == r.best ? "chosen (" + opt.criterion + ")" : "") + " |\n";
  }
  return out;
}

}  // namespace spikems
