#include "core/eval/evaluation.h"

#include <cmath>
#include <filesystem>

#include "core/dataset/sequence.h"
#include "core/eval/ann_scorer.h"
#include "core/eval/baseline_scorer.h"
#include "core/eval/boxes.h"
#include "core/eval/sequence_scorer.h"
#include "core/events/event_ops.h"
#include "core/model/output_gate.h"
#include "core/model/output_threshold.h"
#include "core/model/time_step.h"
#include "core/util/error.h"
#include "core/util/interrupt.h"
#include "core/util/progress.h"
#include "core/util/text_format.h"
#include "core/viz/event_frame.h"

namespace spikems {

namespace fs = std::filesystem;

namespace {

// A captured mask of a downsampled network (its grid, ceil(W/f) x ceil(H/f)) at the sensor's
// size, each of its pixels filling f x f sensor pixels; a sensor-sized one as it is.
std::vector<uint8_t> at_sensor(const std::vector<uint8_t>& m, int w, int h, SensorSize s) {
  if (w == s.width && h == s.height) return m;
  const int f = int(std::lround(double(s.width) / w));
  if (f < 1 || (s.width + f - 1) / f != w || (s.height + f - 1) / f != h ||
      m.size() != size_t(w) * h)
    fail("report", "", "example window with inconsistent sizes");
  std::vector<uint8_t> out(size_t(s.width) * s.height);
  for (int y = 0; y < s.height; ++y)
    for (int x = 0; x < s.width; ++x)
      out[size_t(y) * s.width + x] = m[size_t(y / f) * w + size_t(x / f)];
  return out;
}

// The windows every run captured for one sequence, as one ExampleWindow each (input events
// rendered here, while the sequence is loaded).
SequenceExamples collect_examples(const LabelledSequence& seq,
                                  const std::vector<const SequenceScore*>& runs) {
  SequenceExamples out;
  out.name = seq.name;
  if (runs.empty() || seq.events.empty()) return out;
  const int64_t origin = seq.events.t_first();
  for (size_t k = 0; k < runs[0]->captured.size(); ++k) {
    const CapturedWindow& c = runs[0]->captured[k];
    ExampleWindow w;
    w.t0_us = c.t0_us - origin;
    w.t1_us = c.t1_us - origin;
    // At the sensor's size: the runs may see it at different resolutions (--downsample).
    const SensorSize sensor = seq.events.sensor;
    w.width = sensor.width;
    w.height = sensor.height;
    w.truth = at_sensor(c.truth, c.width, c.height, sensor);
    w.events = render_events(seq.events, c.t0_us, c.t1_us, sensor);
    for (const SequenceScore* r : runs) {
      // Every run scores the same windows of the same data, so it captured the same ones.
      if (k >= r->captured.size() || r->captured[k].index != c.index)
        fail(seq.name, "", "internal: runs captured different windows for the report");
      const CapturedWindow& rc = r->captured[k];
      w.predicted.push_back(at_sensor(rc.predicted, rc.width, rc.height, sensor));
      w.counts.push_back(r->captured[k].counts);
    }
    out.windows.push_back(std::move(w));
  }
  return out;
}

}  // namespace

EvalResults evaluate(const EvalOptions& opt, EvalExamples* examples) {
  std::vector<std::string> paths = opt.models;
  if (!opt.model_path.empty()) paths.insert(paths.begin(), opt.model_path);
  for (const auto& b : opt.baselines)
    if (b != kAllEventsBaseline)
      fail("spikems eval", "--baseline " + b,
           "unknown baseline (use " + std::string(kAllEventsBaseline) + ")");
  if (paths.empty() && opt.baselines.empty())
    fail("spikems eval", "", "no model given (--model FILE)");
  if (opt.data.empty()) fail("spikems eval", "", "no data given (--data PATH)");
  check_band_edges(opt.share_bands_pct);
  if (!(opt.min_moving_share_pct >= 0 && opt.min_moving_share_pct < 100))
    fail("--min-moving-share", fmt("%g", opt.min_moving_share_pct),
         "must be a percentage in [0, 100), e.g. 50");
  if (opt.min_moving_share_pct > 0 && (opt.static_scene || !opt.boxes.empty()))
    fail("--min-moving-share", "",
         "filters windows by their labelled moving events: it takes neither --static-scene nor "
         "--boxes");
  if (!(opt.keep_events > 0 && opt.keep_events <= 1))
    fail("--keep-events", fmt("%g", opt.keep_events),
         "must be the share of events kept, in (0, 1], e.g. 0.25");
  if (opt.group_windows < 1 || opt.group_windows > 10000)
    fail("--group-windows", std::to_string(opt.group_windows),
         "must be a whole number of windows in [1, 10000], e.g. 8 (the authors' test)");
  if (opt.group_windows > 1 && opt.static_scene)
    fail("--group-windows", "",
         "groups windows with moving objects: a static scene has none (drop --static-scene)");
  const std::vector<double> scales =
      opt.output_thresholds.empty() ? std::vector<double>{1.0} : opt.output_thresholds;
  std::vector<ModelSpec> models;
  std::vector<std::string> model_paths;
  std::vector<double> model_scales;
  std::vector<bool> model_retimed;
  const std::vector<int64_t> gates =
      opt.output_gates_us.empty() ? std::vector<int64_t>{-1} : opt.output_gates_us;
  for (const auto& p : paths) {
    ModelSpec m = load_model(p);
    if (opt.train_width > 0 && m.train_width > 0 &&
        (opt.train_width != m.train_width || opt.train_height != m.train_height))
      fail("--train-grid", p,
           "the model records its own training grid, " + std::to_string(m.train_width) + "x" +
               std::to_string(m.train_height) + ": drop --train-grid (or use --downsample N)");
    if (opt.train_width > 0 && m.train_width == 0) {
      m.train_width = opt.train_width;
      m.train_height = opt.train_height;
      m.validate(p);
    }
    if (opt.iir && m.type == ModelType::SNN) m = with_iir_neurons(std::move(m), p);
    const double file_step_ms = m.time_step_ms;
    if (opt.time_step_ms > 0)
      m = with_time_step(std::move(m), opt.time_step_ms, TimeConstants::Steps, p);
    const bool retimed = m.time_step_ms != file_step_ms;
    check_windows(opt.windows_us, time_step_us(m), p);
    if (!opt.kalman_us.empty()) check_windows(opt.kalman_us, time_step_us(m), p + " (--kalman)");
    for (int64_t g : gates)
      for (double s : scales) {
        ModelSpec v = g < 0 ? m : with_output_gate(m, g, p);
        models.push_back(s == 1.0 ? std::move(v) : with_output_threshold(std::move(v), s, p));
        model_paths.push_back(p);
        model_scales.push_back(s);
        model_retimed.push_back(retimed);
      }
  }
  if (!opt.baselines.empty()) check_windows(opt.windows_us, 1, "--windows");

  // Every source's sequence list first, so that a bad path or an empty split fails at once.
  struct Source {
    DatasetSource src;
    std::vector<std::string> files;
    bool folder = false;  // a simulator folder with splits
  };
  std::vector<Source> sources;
  size_t total = 0;
  for (const auto& path : opt.data) {
    Source s;
    s.src.path = path;
    s.src.split = opt.split;
    s.files = sequence_files(s.src);
    s.folder = !(s.files.size() == 1 && s.files[0] == path);
    total += s.files.size();
    sources.push_back(std::move(s));
  }
  // Box ground truth belongs to one recording: one file of boxes per --data would need a way
  // to pair them; one at a time keeps the command plain.
  std::shared_ptr<const BoxTruth> boxes;
  if (opt.static_scene && !opt.boxes.empty())
    fail("--static-scene", "", "a static scene has no moving objects: it takes no --boxes");
  if (!opt.boxes.empty()) {
    if (total != 1)
      fail("--boxes " + opt.boxes, "",
           "a boxes file is the ground truth of one recording: give it with exactly one --data "
           "holding one sequence (found " +
               std::to_string(total) + " sequences in " + std::to_string(sources.size()) +
               " --data)");
    boxes = std::make_shared<const BoxTruth>(BoxTruth::read(opt.boxes));
  }

  EvalResults r;
  r.command_line = opt.command_line;
  r.date = utc_now_iso8601();
  std::error_code ec;
  r.working_directory = fs::current_path(ec).string();
  r.max_seconds = opt.max_seconds;
  r.windows_us = opt.windows_us;
  r.kalman_us = opt.kalman_us;
  // One result per model, then per baseline; each sequence is loaded once for all of them.
  const size_t runs = models.size() + opt.baselines.size();
  std::vector<ModelResult> res(runs);
  for (size_t i = 0; i < models.size(); ++i) {
    res[i].path = model_paths[i];
    res[i].output_threshold = model_scales[i];
    res[i].output_gate_steps = models[i].output_gate_steps;
    res[i].name = models[i].name;
    res[i].time_step_ms = double(time_step_us(models[i])) / 1000.0;
    res[i].iir = opt.iir;
    res[i].time_step_scaled = model_retimed[i];
  }
  for (size_t i = 0; i < opt.baselines.size(); ++i) {
    ModelResult& m = res[models.size() + i];
    m.path = "baseline:" + opt.baselines[i];
    m.name = "every event moving";
    m.time_step_ms = 0;
  }

  ProgressBar bar("eval", total * runs, "runs", opt.progress);
  SequenceScoreOptions so;
  so.threads = opt.threads;
  so.downsample = opt.downsample;
  so.kalman_us = opt.kalman_us;
  so.gate_events = opt.gate_events;
  so.boxes = boxes;
  r.boxes = opt.boxes;
  r.gate_events = opt.gate_events;
  r.static_scene = opt.static_scene;
  r.share_bands_pct = opt.share_bands_pct;
  so.moving_share = !opt.share_bands_pct.empty();
  so.min_moving_share = opt.min_moving_share_pct / 100.0;
  r.min_moving_share_pct = opt.min_moving_share_pct;
  so.group_windows = opt.group_windows;
  r.group_windows = opt.group_windows;
  r.keep_events = opt.keep_events;
  r.label_tolerance_steps = so.label_tolerance_steps;
  so.max_us = opt.max_seconds > 0 ? int64_t(opt.max_seconds * 1e6 + 0.5) : 0;
  size_t done = 0;
  const bool want_examples = examples && opt.example_windows > 0 && opt.example_sequences > 0;
  if (examples) {
    *examples = EvalExamples{};
    examples->window_us = example_window_length(opt.windows_us);
  }
  std::vector<bool> ran_any(runs, false);
  for (const auto& s : sources) {
    std::vector<std::vector<SequenceScore>> scores(runs);
    std::vector<SequenceExamples> shown;
    for (const auto& f : s.files) {
      if (interrupted()) break;
      const std::string name = fs::path(f).filename().string();
      bar.set_status(name + " loading");
      bar.update(done);
      LabelledSequence seq = load_sequence(f, s.src.mask_dilation, !boxes && !opt.static_scene);
      if (opt.static_scene) seq.events.label.assign(seq.events.size(), 0);
      if (boxes) {  // the boxes replace any labels: moving = inside a box valid at its time
        boxes->check_sensor(seq.events.sensor);
        boxes->label(seq.events);
      }
      if (opt.keep_events < 1) seq.events = thin_events(seq.events, opt.keep_events);
      const uint64_t n = seq.events.size();
      // The report's windows come from this same pass (no second run).
      so.capture_windows.clear();
      if (want_examples && shown.size() < size_t(opt.example_sequences)) {
        so.capture_window_us = examples->window_us;
        so.capture_windows =
            example_windows(seq, so.capture_window_us, opt.example_windows, so.max_us);
      }
      bool complete = true;
      for (size_t i = 0; i < runs && complete; ++i) {
        so.progress = [&](uint64_t k) {
          bar.set_status(name + " " + std::to_string(n ? 100 * k / n : 100) + " %");
          bar.update(done);
          return !interrupted();
        };
        SequenceScore sc = i >= models.size() ? score_all_events(seq, opt.windows_us, so)
                           : models[i].type == ModelType::ANN2D
                               ? score_ann_sequence(models[i], seq, opt.windows_us, so)
                               : score_sequence(models[i], seq, opt.windows_us, so);
        complete = sc.complete;
        if (complete && i < models.size()) {  // the factor it ran at, the same everywhere?
          if (!ran_any[i])
            res[i].downsample = sc.downsample;
          else if (res[i].downsample != sc.downsample)
            res[i].downsample = 0;
          ran_any[i] = true;
        }
        if (complete) scores[i].push_back(std::move(sc));
        bar.update(++done);
      }
      if (!complete) {  // interrupted mid-sequence: keep whole sequences only
        for (auto& v : scores)
          if (v.size() > scores[runs - 1].size()) v.pop_back();
        break;
      }
      if (!so.capture_windows.empty()) {
        std::vector<const SequenceScore*> last;
        for (auto& v : scores) last.push_back(&v.back());
        shown.push_back(collect_examples(seq, last));
        for (auto& v : scores) v.back().captured.clear();  // the masks live in `shown` now
      }
    }
    if (!scores[0].empty() || !interrupted()) {
      for (size_t i = 0; i < runs; ++i)
        res[i].datasets.push_back(
            dataset_result(s.src.path, s.folder ? opt.split : "", scores[i], opt.share_bands_pct));
      if (examples) examples->datasets.push_back(std::move(shown));
    }
    if (interrupted()) {
      r.interrupted = true;
      break;
    }
  }
  bar.set_status("");
  bar.finish();
  r.models = std::move(res);
  return r;
}

}  // namespace spikems
