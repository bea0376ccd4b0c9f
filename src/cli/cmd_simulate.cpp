// `spikems simulate`: labelled synthetic event data (MOD/EV-IMO/EED-like scenes), one file per
// sequence plus manifest.json; or `--stats-compare FILE` to set simulated statistics beside a
// real recording's (docs/simulator.md). `--preview` adds a contact sheet, preview.png.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <thread>

#include "cli/command.h"
#include "core/events/io.h"
#include "core/sim/event_stats.h"
#include "core/sim/presets.h"
#include "core/sim/simulate.h"
#include "core/util/duration.h"
#include "core/util/error.h"
#include "core/util/interrupt.h"
#include "core/util/progress.h"
#include "core/viz/event_frame.h"
#include "core/viz/image.h"

namespace {

struct Args {
  std::string preset = "mod", config, out, duration, noise, stats_compare, format = "spikems-h5",
              mask_period;
  int sequences = 1, threads = 0, width = 0, height = 0;
  uint64_t seed = 1;
  bool no_progress = false, print_config = false, preview = false;
};

// Contact sheet layout (docs/simulator.md): tiles in sequence order, row by row, cols =
// ceil(sqrt(n)); each tile is a kStrip-pixel white strip with the index above the event frame,
// kGap grey pixels between tiles and around the sheet. At most kMaxTiles sequences.
constexpr int kGap = 2, kStrip = 12, kMaxTiles = 64;
constexpr int64_t kPreviewWindowUs = 10000;

// 3 x 5 digit glyphs, one row per 3 bits (top row first).
void draw_number(spikems::Image& img, int x0, int y0, int value, int scale) {
  static constexpr uint8_t glyph[10][5] = {
      {7, 5, 5, 5, 7}, {2, 6, 2, 2, 7}, {7, 1, 7, 4, 7}, {7, 1, 7, 1, 7}, {5, 5, 7, 1, 1},
      {7, 4, 7, 1, 7}, {7, 4, 7, 5, 7}, {7, 1, 1, 1, 1}, {7, 5, 7, 5, 7}, {7, 5, 7, 1, 7}};
  std::string digits = std::to_string(value);
  for (size_t k = 0; k < digits.size(); ++k)
    for (int r = 0; r < 5; ++r)
      for (int c = 0; c < 3; ++c) {
        if (!(glyph[digits[k] - '0'][r] & (4 >> c))) continue;
        for (int dy = 0; dy < scale; ++dy)
          for (int dx = 0; dx < scale; ++dx)
            img.set(x0 + int(k) * 4 * scale + c * scale + dx, y0 + r * scale + dy, 0, 0, 0);
      }
}

// Events of [t0, t1) from a time-sorted file, streamed (masks are not read).
spikems::EventStream read_window(const std::string& path, int64_t t0, int64_t t1) {
  auto reader = spikems::open_reader(path);
  spikems::EventStream win, chunk;
  while (true) {
    chunk.clear();
    if (reader->read(chunk, spikems::kReadChunk) == 0) break;
    auto [b, e] = chunk.time_range(t0, t1);
    win.append(chunk, b, e);
    if (chunk.t.back() >= t1) break;
  }
  win.sensor = reader->sensor();
  return win;
}

// One 10 ms window at mid-sequence per written sequence: ON red, OFF blue, events labelled
// with a moving object in that object's label colour (orange for id 1, ...).
void write_preview(const std::string& dir, const spikems::sim::SimConfig& cfg, int sequences) {
  namespace fs = std::filesystem;
  const int n = std::min(sequences, kMaxTiles);
  const int cols = int(std::ceil(std::sqrt(double(n)))), rows = (n + cols - 1) / cols;
  const int W = cfg.width, H = cfg.height;
  spikems::Image sheet(cols * W + (cols + 1) * kGap, rows * (H + kStrip) + (rows + 1) * kGap, 160,
                       160, 160);
  const int64_t mid = cfg.duration_us / 2;
  const int64_t t0 = std::max<int64_t>(0, mid - kPreviewWindowUs / 2),
                t1 = std::min<int64_t>(cfg.duration_us + 1, t0 + kPreviewWindowUs);
  spikems::RenderOptions ro;
  ro.show_labels = true;
  for (int i = 0; i < n; ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "seq_%04d.h5", i);
    const std::string path = (fs::path(dir) / name).string();
    const int x0 = kGap + (i % cols) * (W + kGap), y0 = kGap + (i / cols) * (H + kStrip + kGap);
    for (int y = 0; y < kStrip; ++y)
      for (int x = 0; x < W; ++x) sheet.set(x0 + x, y0 + y, 255, 255, 255);
    draw_number(sheet, x0 + 2, y0 + 1, i, 2);
    if (!fs::exists(path)) continue;  // not written (interrupted): white tile
    spikems::EventStream win = read_window(path, t0, t1);
    spikems::Image tile = spikems::render_events(win, t0, t1, {W, H}, nullptr, ro);
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        const uint8_t* p = tile.px(x, y);
        sheet.set(x0 + x, y0 + kStrip + y, p[0], p[1], p[2]);
      }
  }
  spikems::write_png((fs::path(dir) / "preview.png").string(), sheet);
}

void run(const Args& a) {
  using namespace spikems;
  using namespace spikems::sim;
  if (a.print_config) {
    std::cout << preset_toml(a.preset);
    return;
  }
  SimConfig cfg = a.config.empty() ? preset_config(a.preset) : load_sim_config(a.config);
  std::string source = a.config.empty() ? "preset " + a.preset : a.config;
  if (!a.duration.empty()) {
    cfg.duration_us = parse_duration_us(a.duration);
    if (cfg.duration_us <= 0) fail("--duration", a.duration, "must be positive");
  }
  if (!a.mask_period.empty()) cfg.mask_period_us = parse_duration_us(a.mask_period);
  if (!a.noise.empty()) apply_noise_setting(cfg, a.noise);
  if (a.width > 0) cfg.width = a.width;
  if (a.height > 0) cfg.height = a.height;
  validate_sim_config(cfg, source);
  const int threads =
      a.threads > 0 ? a.threads : std::max(1, int(std::thread::hardware_concurrency()));

  if (!a.stats_compare.empty()) {
    ReadOptions ro;
    ro.sort = true;
    EventStream real = read_events(a.stats_compare, ro);
    std::vector<std::pair<std::string, EventStats>> cols{
        {a.stats_compare, compute_event_stats(real)}};
    std::vector<Recording> recs(size_t(a.sequences));
    EventStream sim;
    for (int i = 0; i < a.sequences; ++i) {
      SimulateOptions so;
      so.render_threads = threads;
      so.keep_masks = false;
      Recording r = simulate_sequence(cfg, sequence_seed(a.seed, i), so);
      cols.push_back({cfg.name + " seq " + std::to_string(i) + " (" + cfg.noise + ")",
                      compute_event_stats(r.events)});
    }
    std::cout << stats_table(cols);
    return;
  }
  if (a.out.empty()) fail("--out", "", "give the output folder (e.g. --out data/mod)");
  install_interrupt_flag();
  DatasetOptions o;
  o.out_dir = a.out;
  o.sequences = a.sequences;
  o.threads = threads;
  o.seed = a.seed;
  o.format = a.format;
  o.progress = !a.no_progress;
  o.config_source = source;
  DatasetSummary s = simulate_dataset(cfg, o);
  std::fprintf(stderr, "%s: %d sequence(s), %s events, %s each, manifest.json written%s\n",
               a.out.c_str(), s.sequences_written, human_count(double(s.events)).c_str(),
               format_duration_us(cfg.duration_us).c_str(),
               s.interrupted ? " (interrupted: the manifest lists the finished ones)" : "");
  if (s.interrupted) throw Error("interrupted");
  if (a.preview) {
    write_preview(a.out, cfg, s.sequences_written);
    std::fprintf(stderr, "%s/preview.png written (10 ms at mid-sequence, %d sequence(s))\n",
                 a.out.c_str(), std::min(s.sequences_written, kMaxTiles));
  }
}

void add(CLI::App& app) {
  static Args args;
  auto* cmd = app.add_subcommand(
      "simulate",
      "Generate labelled event data from a simulated 3-D scene (event camera simulator)");
  cmd->footer(
      "Examples:\n"
      "  spikems simulate --preset mod --sequences 40 --duration 2s --out data/mod\n"
      "  spikems simulate --preset mod --sequences 16 --duration 200ms --out data/look "
      "--preview\n"
      "  spikems simulate --config my.toml --out data/mine   (start from --print-config)\n"
      "Presets: configs/sim/*.toml (see --preset). See docs/simulator.md.");
  cmd->add_option("--preset", args.preset,
                  "Scene preset: mod, mod-fixed, mod-translate, mod-lookalikes, "
                  "modstatic-lookalikes, evimo, eed-net, poster, poster-flat, tiny")
      ->check(CLI::IsMember(::spikems::sim::preset_names()));
  cmd->add_option("--config", args.config, "TOML config (replaces the preset)")
      ->check(CLI::ExistingFile);
  cmd->add_option("--sequences", args.sequences, "Number of sequences")
      ->check(CLI::Range(1, 1000000));
  cmd->add_option("--duration", args.duration, "Length of each sequence (e.g. 2s, 500ms)");
  cmd->add_option("--out", args.out, "Output folder (seq_XXXX.h5 + manifest.json)");
  cmd->add_option("--threads", args.threads, "Worker threads (default: all cores)")
      ->check(CLI::Range(1, 1024));
  cmd->add_option("--seed", args.seed, "Global seed (same seed, same bytes)");
  cmd->add_option("--noise", args.noise, "Sensor noise: clean or noisy (default: config)")
      ->check(CLI::IsMember({"clean", "noisy"}));
  cmd->add_option("--width", args.width, "Sensor width (default: config)")
      ->check(CLI::Range(8, 4096));
  cmd->add_option("--height", args.height, "Sensor height (default: config)")
      ->check(CLI::Range(8, 4096));
  cmd->add_option("--mask-period", args.mask_period,
                  "Period of mask frames and poses (default 1ms; coarser = smaller files)");
  cmd->add_option("--format", args.format, "Output format (default spikems-h5)");
  cmd->add_option("--stats-compare", args.stats_compare,
                  "Print event statistics of FILE (a real recording) beside simulated ones")
      ->check(CLI::ExistingFile);
  cmd->add_flag("--print-config", args.print_config, "Print the preset's TOML and exit");
  cmd->add_flag("--preview", args.preview,
                "Also write <out>/preview.png: 10 ms of events at mid-sequence per sequence "
                "(first 64), in a grid");
  cmd->add_flag("--no-progress", args.no_progress, "No progress bar");
  cmd->callback([] { run(args); });
}

}  // namespace

SPIKEMS_COMMAND(simulate, 40, add);
