// `spikems segment`: event-by-event motion segmentation with the streaming SNN runtime.
// Reads any event format chunk by chunk (or text lines from stdin, live), labels every event
// foreground/background, and optionally writes mask frames, tracked boxes and statistics.
#include <unistd.h>

#include <chrono>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>

#include "cli/command.h"
#include "core/eval/metrics.h"
#include "core/eval/window_scorer.h"
#include "core/events/event_ops.h"
#include "core/events/formats/label_column.h"
#include "core/events/io.h"
#include "core/model/default_model.h"
#include "core/model/model_file.h"
#include "core/model/model_scale.h"
#include "core/model/output_gate.h"
#include "core/model/output_threshold.h"
#include "core/model/time_step.h"
#include "core/runtime/kalman_tracker.h"
#include "core/runtime/segmenter.h"
#include "core/util/atomic_file.h"
#include "core/util/duration.h"
#include "core/util/error.h"
#include "core/util/host_memory.h"
#include "core/util/interrupt.h"
#include "core/util/progress.h"
#include "core/viz/image.h"

namespace {

using namespace spikems;

// Events per read: small chunks keep Ctrl-C responsive even when the network is slow.
constexpr size_t kChunk = 4096;

struct Args {
  std::string model, input, out, labels, masks_dir, boxes;
  std::string mask_window = "10ms";
  bool mask_window_set = false;
  bool stats = false, quiet = false, score = false, iir = false;
  int threads = 1;
  std::string downsample = "auto";
  int block_steps = 0;  // 0: default_block_steps() for files, 1 for a live stream on stdin
  int64_t step_us = 0;
  int tolerance = 3;
  double output_threshold = 1;
  std::string output_gate;  // ms; empty = the model's own
  std::string compression;  // --out's, where its format has one (empty: the format's default)
  int level = -1;
  cli::ReadFlags read;
};

// Text lines "t x y p" from stdin, one event at a time, so that a live stream is answered as
// it arrives. t in microseconds, or seconds when it has a decimal point (--time-unit auto).
class StdinTextSource {
 public:
  explicit StdinTextSource(std::string unit) : unit_(std::move(unit)) {}
  // Reads up to max events; returns false at the end of input.
  bool read(EventStream& out, size_t max) {
    char line[512];
    size_t n = 0;
    while (n < max && std::fgets(line, sizeof line, stdin)) {
      ++line_no_;
      char* s = line;
      while (*s == ' ' || *s == '\t') ++s;
      if (*s == '#' || *s == '\n' || *s == '\r' || *s == 0) continue;
      for (char* c = s; *c; ++c)
        if (*c == ',') *c = ' ';
      char tbuf[64];
      long x, y, p;
      if (std::sscanf(s, "%63s %ld %ld %ld", tbuf, &x, &y, &p) != 4)
        fail_at_line("stdin", line_no_, "expected 't x y p'");
      bool secs = unit_ == "s" || (unit_ == "auto" && std::strpbrk(tbuf, ".eE"));
      char* end = nullptr;
      double tv = std::strtod(tbuf, &end);
      if (*end || !std::isfinite(tv))
        fail_at_line("stdin", line_no_, "bad time '" + std::string(tbuf) + "'");
      int64_t t = secs ? std::llround(tv * 1e6) : std::llround(tv);
      if (x < 0 || y < 0 || x > 65535 || y > 65535 || (p != 0 && p != 1 && p != -1))
        fail_at_line("stdin", line_no_, "x, y must be 0..65535 and p 0/1 (or -1)");
      out.push_back(t, uint16_t(x), uint16_t(y), uint8_t(p == 1 ? 1 : 0));
      ++n;
      if (live_) break;  // hand each event on at once
    }
    return n > 0;
  }
  void set_live(bool v) { live_ = v; }

 private:
  std::string unit_;
  uint64_t line_no_ = 0;
  bool live_ = true;
};

// At the sensor's size: a frame of a downsampled network (f.scale > 1) fills each of its pixels'
// scale x scale sensor pixels.
Image mask_image(const PredictionFrame& f, SensorSize sensor) {
  const int w = f.scale > 1 ? sensor.width : f.width, h = f.scale > 1 ? sensor.height : f.height;
  Image img(w, h, 0, 0, 0);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const size_t i = size_t(y / f.scale) * f.width + size_t(x / f.scale);
      if (f.foreground[i])
        img.set(x, y, 255, 255, 255);
      else if (f.events[i])
        img.set(x, y, 90, 90, 90);
    }
  return img;
}

// setup_s: building the network's state (once per stream, inside wall_s); the streaming rate
// leaves it out, as a live stream pays it before its first event.
void print_stats(const Segmenter& seg, double wall_s, double setup_s) {
  const auto st = seg.network().stats();
  const double steps = double(std::max<int64_t>(1, seg.steps()));
  std::fprintf(stderr, "\n%-6s %10s %12s %12s %10s %14s %12s %9s\n", "layer", "neurons",
               "in spikes", "out spikes", "rate", "SynOps", "visits/step", "us/step");
  uint64_t syn = 0;
  for (size_t k = 0; k < st.size(); ++k) {
    syn += st[k].synops;
    std::fprintf(stderr,
                 "%-6zu %10zu %12" PRIu64 " %12" PRIu64 " %10.5f %14" PRIu64 " %12.1f %9.1f\n",
                 k + 1, st[k].neurons, st[k].in_spikes, st[k].out_spikes,
                 double(st[k].out_spikes) / (double(st[k].neurons) * steps), st[k].synops,
                 double(st[k].visits) / steps, st[k].seconds * 1e6 / steps);
  }
  std::fprintf(stderr, "%-6s %10s %12s %12s %10s %14" PRIu64 "\n", "total", "", "", "", "", syn);
  const StreamingNetwork& net = seg.network();
  if (net.output_gate_steps() > 0) {
    const uint64_t all = net.gate_kept() + net.gate_removed();
    std::fprintf(stderr,
                 "output gate %d steps: kept %" PRIu64 " of the last layer's %" PRIu64
                 " spikes (%.1f %%)\n",
                 net.output_gate_steps(), net.gate_kept(), all,
                 all ? 100.0 * double(net.gate_kept()) / double(all) : 0.0);
  }
  const double sim_s = double(seg.steps()) * double(seg.step_us()) * 1e-6;
  std::fprintf(
      stderr,
      "events %" PRIu64 " (%.1f%% foreground), %" PRId64 " steps of %" PRId64
      " us, label window %d steps%s\n",
      seg.events_in(),
      seg.events_in() ? 100.0 * double(seg.foreground_events()) / double(seg.events_in()) : 0.0,
      seg.steps(), seg.step_us(), seg.label_window_steps(),
      seg.downsample() > 1
          ? (", the sensor downsampled " + std::to_string(seg.downsample()) + "x").c_str()
          : "");
  std::fprintf(stderr,
               "simulated %.3f s in %.3f s wall (setup %.3f s, network %.3f s): %s events/s, "
               "real-time factor %.2f (after setup %.2f, network only %.2f)\n",
               sim_s, wall_s, setup_s, seg.network_seconds(),
               human_count(double(seg.events_in()) / std::max(wall_s, 1e-9)).c_str(),
               sim_s / std::max(wall_s, 1e-9), sim_s / std::max(wall_s - setup_s, 1e-9),
               sim_s / std::max(seg.network_seconds(), 1e-9));
  // The other threads run the network beside this one's reading and labelling.
  if (const int threads = seg.network().threads(); threads > 1)
    std::fprintf(stderr,
                 "(with --threads %d, \"network\" is this thread's time in it; the other "
                 "threads' runs beside reading and labelling: compare the whole wall time)\n",
                 threads);
}

void run(const Args& a) {
  // Ctrl-C sets a flag (a second one exits at once); the loop below then stops reading and
  // commits complete outputs for the events read so far.
  install_interrupt_flag();
  keep_freed_memory();  // freed batches and queues reused: fewer page faults (host_memory.h)
  ModelSpec model = load_model(resolve_model(a.model));
  if (a.iir) model = with_iir_neurons(std::move(model), a.model);
  // Before the gate: a gate in ms then counts steps of the step the network runs at.
  if (a.step_us > 0)
    model = with_time_step(std::move(model), double(a.step_us) / 1000.0, TimeConstants::Steps,
                           "--time-step-us");
  if (a.output_threshold != 1)
    model = with_output_threshold(std::move(model), a.output_threshold, "--output-threshold");
  if (!a.output_gate.empty()) {
    const std::vector<int64_t> g = parse_gate_list_ms(a.output_gate, "--output-gate");
    if (g.size() != 1) fail("--output-gate", "", "give one duration in ms, e.g. 20 (0 = none)");
    model = with_output_gate(std::move(model), g[0], "--output-gate");
  }
  ReadOptions ro;
  ro.sort = a.read.sort;
  ro.time_unit = a.read.time_unit;
  ro.format = a.read.format;
  if (a.read.width > 0 && a.read.height > 0)
    ro.sensor = SensorSize{a.read.width, a.read.height};
  else if (a.read.width > 0 || a.read.height > 0)
    fail("spikems segment", "", "give both --width and --height");

  const bool from_stdin = a.input == "-";
  std::unique_ptr<EventReader> reader;
  std::optional<StdinTextSource> stdin_src;
  SensorSize sensor = ro.sensor;
  if (from_stdin) {
    stdin_src.emplace(a.read.time_unit);
    if (!sensor.known()) sensor = SensorSize{model.input_width, model.input_height};
    if (!sensor.known())
      fail("stdin", "", "a text stream has no header: give the sensor size with --width/--height");
  } else {
    reader = open_reader(a.input, ro);
    if (!sensor.known()) sensor = reader->sensor();
  }

  const int downsample = parse_downsample(a.downsample, "--downsample");  // 0: auto
  SegmenterOptions so;
  so.label_tolerance_steps = a.tolerance;
  so.threads = a.threads;
  so.block_steps = a.block_steps > 0 ? a.block_steps
                   : from_stdin      ? 1
                                     : default_block_steps(model.time_step_ms, a.threads);
  int64_t window = 0;
  if (!a.masks_dir.empty() || !a.boxes.empty() || a.mask_window_set || a.score)
    window = parse_duration_us(a.mask_window);
  so.mask_window_us = window;

  std::optional<Segmenter> seg;
  // Labelled events out: the format of --out's extension (text for .txt/.csv and for "-",
  // one "t x y p label" line per event), labels kept where the format has them.
  std::unique_ptr<EventWriter> sink;
  std::unique_ptr<AtomicFile> boxes;
  // --labels: the label column alone, opened now so a wrong extension stops before any work.
  std::optional<LabelColumnWriter> column;
  if (!a.labels.empty()) {
    // Two outputs renamed onto one path: the second would silently replace the first.
    for (const std::string* other : {&a.out, &a.boxes, &a.input})
      if (!other->empty() && *other != "-" &&
          std::filesystem::weakly_canonical(*other) == std::filesystem::weakly_canonical(a.labels))
        fail(a.labels, "",
             "--labels names the same file as " +
                 std::string(other == &a.out     ? "--out"
                             : other == &a.boxes ? "--boxes"
                                                 : "--input") +
                 "; give it a path of its own");
    column.emplace(a.labels);
  }
  KalmanTracker tracker;
  if (!a.masks_dir.empty()) std::filesystem::create_directories(a.masks_dir);
  if (!a.boxes.empty()) {
    boxes = std::make_unique<AtomicFile>(a.boxes);
    boxes->write(std::string("t_us,id,x0,y0,x1,y1,vx,vy\n"));
  }
  double setup_s = 0;
  auto init = [&](SensorSize s) {
    if (!s.known())
      fail(a.input, "", "the sensor size is unknown; give it with --width and --height");
    so.downsample = resolve_downsample(model, s.width, s.height, downsample, a.input);
    if (downsample == 0 && so.downsample > 1 && !a.quiet)
      std::fprintf(stderr,
                   "spikems segment: the model was trained on a %dx%d grid; the network sees "
                   "this %dx%d sensor downsampled %dx (--downsample 1 to run it at full "
                   "resolution)\n",
                   model.train_width, model.train_height, s.width, s.height, so.downsample);
    const auto t_setup = std::chrono::steady_clock::now();
    seg.emplace(model, s, so, a.input);
    setup_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_setup).count();
    WriteOptions wo;
    wo.compression = a.compression;
    wo.level = a.level;
    if (!a.out.empty()) sink = open_writer(a.out, s, wo, a.out == "-" ? "text" : "");
  };
  // --score: the paper's per-window IoU and detection rate (core/eval/window_scorer.h): G =
  // pixels with foreground input events (label != 0) in the window, P = pixels of the window's
  // mask frame (output spikes). Truth is dropped once scored (bounded memory).
  std::optional<WindowScorer> scorer;
  int64_t last_t = 0;
  auto add_truth = [&](const EventStream& c) {
    if (!a.score || c.empty()) return;
    if (!c.has_labels())
      fail(a.input, "",
           "--score needs labelled events (label = object id), e.g. from `spikems simulate`");
    // A downsampled network is scored on its own grid: G from the events at its pixels.
    if (so.downsample > 1) {
      BinningConfig geo;
      geo.downsample = so.downsample;
      const EventStream d = remap_events(c, geo);
      if (!scorer) scorer.emplace(d.sensor, std::vector<int64_t>{window});
      scorer->add_events(d);
    } else {
      if (!scorer) scorer.emplace(sensor, std::vector<int64_t>{window});
      scorer->add_events(c);
    }
    last_t = c.t.back();
  };
  auto score_frame = [&](const PredictionFrame& f) {
    if (scorer) scorer->add_frame(f);
  };
  size_t frames_written = 0;
  auto drain = [&]() {
    // Not before the first labelled events: a text header names the label column only when
    // its first batch has labels.
    if (sink && !seg->labelled().empty()) sink->write(seg->labelled());
    if (column) column->write(seg->labelled());
    seg->labelled().clear();
    seg->labelled().add_zero_labels();
    for (const auto& f : seg->frames()) {
      score_frame(f);
      if (!a.masks_dir.empty()) {
        char name[64];
        std::snprintf(name, sizeof name, "mask_%06d.png", f.index);
        write_png((std::filesystem::path(a.masks_dir) / name).string(), mask_image(f, sensor));
      }
      if (boxes)
        for (const auto& b : tracker.update(f.t1_us, f.foreground, f.width, f.height)) {
          // A downsampled frame's pixel x covers sensor pixels x*s .. x*s + s-1.
          const double sc = f.scale;
          char line[256];
          std::snprintf(line, sizeof line, "%" PRId64 ",%d,%.1f,%.1f,%.1f,%.1f,%.1f,%.1f\n", b.t_us,
                        b.id, b.x0 * sc, b.y0 * sc, b.x1 * sc + (sc - 1), b.y1 * sc + (sc - 1),
                        b.vx * sc, b.vy * sc);
          boxes->write(std::string(line));
        }
      ++frames_written;
    }
    seg->frames().clear();
  };

  const auto t0 = std::chrono::steady_clock::now();
  bool stdout_busy = a.out == "-";
  ProgressBar bar("segment", 0, "ev",
                  !a.quiet && !stdout_busy && !from_stdin && isatty(fileno(stderr)));
  EventStream chunk;
  bool stopped = false;
  while (true) {
    if (interrupted()) {
      stopped = true;
      break;
    }
    chunk.clear();
    bool more = from_stdin ? stdin_src->read(chunk, kChunk) : reader->read(chunk, kChunk) > 0;
    if (!more) {
      // Ctrl-C while the read waited (the handler restarts it) and the stream then ended: still
      // an interruption, said as such.
      stopped = interrupted();
      break;
    }
    if (!seg) {
      if (!sensor.known()) sensor = chunk.sensor;
      init(sensor);
    }
    seg->push(chunk);
    add_truth(chunk);
    drain();
    bar.update(seg->events_in());
  }
  if (!seg) init(sensor);  // an empty stream still gives (empty) outputs
  seg->finish();
  drain();
  bar.finish();
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (sink) sink->close();
  if (column) column->close();
  if (boxes) boxes->commit();
  if (stopped)
    std::fprintf(stderr,
                 "spikems segment: interrupted; outputs hold the %" PRIu64 " events read so far\n",
                 seg->events_in());
  if (a.stats) print_stats(*seg, wall, setup_s);
  // The last window is scored even when the stream ends inside it.
  if (scorer) scorer->finish(last_t + 1, /*keep_partial=*/true);
  const WindowScores scores = scorer ? scorer->scores()[0] : WindowScores{};
  if (a.score)
    std::printf(
        "score over %zu windows of %g ms with moving objects (%zu without, skipped): "
        "IoU %.1f %% +- %.1f, detection rate %.1f %%\n",
        scores.windows(), double(window) * 1e-3, scores.skipped(), 100 * scores.mean_iou(),
        100 * scores.std_iou(), 100 * scores.detection_rate());
  if (!a.masks_dir.empty() && !a.quiet)
    std::fprintf(stderr, "%zu mask frames in %s\n", frames_written, a.masks_dir.c_str());
}

void add(CLI::App& app) {
  static Args a;
  auto* cmd = app.add_subcommand(
      "segment",
      "Label every event as moving object or background with the event-driven SNN runtime");
  cmd->footer(
      "An event of step t is foreground when the network's output spikes at its pixel within "
      "steps t..t+L+tolerance (L = one step per layer). Text output: one line 't_us x y p "
      "label' per event. See docs/runtime.md.\n\n"
      "Examples:\n"
      "  spikems segment --input recording.raw --out labels.txt\n"
      "  spikems segment --model fast --input recording.raw --labels labels.npy --masks-dir "
      "masks\n"
      "  camera_driver | spikems segment --input - --width 346 --height 260 --out -   (live: "
      "text 't x y p' lines in, labelled lines out)");
  cmd->add_option("--model", a.model,
                  "Model file (.safetensors, spikems format), or a shipped model's name: default "
                  "(models/spikems-default.safetensors, or $SPIKEMS_MODEL: half resolution "
                  "(173x130), the shipped default) or fast (models/spikems-fast.safetensors: "
                  "half resolution, 10 ms steps, for the highest speed, about 5x real time on one "
                  "core; models/README.md)");
  cmd->add_option("--input", a.input, "Event file (any format), or - for text 't x y p' on stdin")
      ->required();
  cmd->add_option("--out", a.out,
                  "Labelled events: .txt/.csv text (t_us x y p label), - for stdout, or any "
                  "writable event format");
  cmd->add_option("--labels", a.labels,
                  "The labels alone, one per event in the input's order (sorted order with "
                  "--sort): .npy (uint8; numpy.load) or .txt (one 0/1 per line). 2 bytes or less "
                  "per event against ~19 for --out's text: the fastest output (docs/runtime.md)");
  cmd->add_option("--compression", a.compression,
                  "--out's compression where its format has one (as `spikems convert`)")
      ->check(CLI::IsMember({"lz4", "zstd", "deflate", "none"}));
  cmd->add_option("--level", a.level,
                  "--out's compression level (format default when absent: npz 1, spikems-h5 4)");
  cmd->add_option("--masks-dir", a.masks_dir, "Write a PNG mask frame per window here");
  cmd->add_option("--mask-window", a.mask_window, "Mask frame length (e.g. 10ms, 1ms, 25ms)")
      ->each([&](const std::string&) { a.mask_window_set = true; });
  cmd->add_option("--boxes", a.boxes, "Kalman-tracked object boxes, CSV t_us,id,x0,y0,x1,y1,vx,vy");
  cmd->add_flag("--stats", a.stats,
                "Print per-layer spikes and SynOps, events/s, real-time factor");
  cmd->add_flag("--score", a.score,
                "Score against the input's labels as the paper does: per --mask-window window, "
                "IoU of output-spike pixels vs pixels with moving-object events (mean +- std), "
                "and the 0-MMS detection rate");
  cmd->add_flag("--quiet", a.quiet, "No progress bar");
  cmd->add_option("--output-threshold", a.output_threshold,
                  "Factor on the output layer's threshold: > 1 labels fewer events moving "
                  "(choose it with eval --output-thresholds on validation data)")
      ->default_val(1.0);
  cmd->add_option("--output-gate", a.output_gate,
                  "Output gate in ms (0 = none; default: the model's own): output spikes count "
                  "only at pixels with an input event that recently (docs/model-format.md)");
  cmd->add_option("--downsample", a.downsample,
                  "auto, 1, 2, 4 or 8: the network sees the events at 1/N resolution, pixel "
                  "(x/N, y/N); the labels go to the original events, masks and boxes are drawn "
                  "at the sensor's size, --score is at the network's. auto (default): the N "
                  "that brings the sensor nearest the grid the model was trained on (`spikems "
                  "info` shows it; 1 for models that record none). docs/runtime.md, \"Pixel "
                  "scale\"");
  cmd->add_option("--threads", a.threads,
                  "Threads: the layers of each step run in parallel (at most one per layer)")
      ->check(CLI::Range(1, 256));
  cmd->add_option("--block-steps", a.block_steps,
                  "Steps the network takes layer by layer in one go: faster (each layer's state "
                  "stays in the cache; 16 steps: ~1.2x at 1 M ev/s), but outputs come up to N-1 "
                  "steps later (with --threads, the layers form a pipeline over blocks: as many "
                  "blocks more as layers). Default for files: ~40 ms of steps (20 ms with "
                  "--threads), 1 to 16 (16 at 1-2 ms steps, 4 at 10 ms); 1 "
                  "(lowest latency) for stdin")
      ->check(CLI::Range(1, 4096));
  cmd->add_flag("--iir", a.iir,
                "Run FIR layers with the exact recursions of the same neurons (no kernel "
                "truncation): ~1.5x faster (docs/performance.md), spikes close to but not "
                "identical with the FIR model");
  cmd->add_option("--time-step-us", a.step_us,
                  "(experimental) Run at this step, the model's time constants scaled by the "
                  "same ratio so each step behaves as trained with more time and events in it: "
                  "fewer steps, faster, outputs close to the model's own (default: the model's "
                  "step; docs/evaluation.md, \"Coarser time steps\")")
      ->check(CLI::Range(int64_t(1), int64_t(1000000)));
  cmd->add_option("--label-tolerance", a.tolerance,
                  "Steps added to the network latency in the labelling window (default 3)")
      ->check(CLI::Range(0, 1000));
  cli::add_read_flags(cmd, a.read);
  cmd->callback([] { run(a); });
}

}  // namespace

SPIKEMS_COMMAND(segment, 40, add);
