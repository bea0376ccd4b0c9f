// `spikems simulate`: labelled synthetic event data (MOD/EV-IMO/EED-like scenes), one file per
// sequence plus manifest.json; or `--stats-compare FILE` to set simulated statistics beside a
// real recording's (docs/simulator.md).
#include <cstdio>
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

namespace {

struct Args {
  std::string preset = "mod", config, out, duration, noise, stats_compare, format = "spikems-h5",
              mask_period;
  int sequences = 1, threads = 0, width = 0, height = 0;
  uint64_t seed = 1;
  bool no_progress = false, print_config = false;
};

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
}

void add(CLI::App& app) {
  auto args = std::make_shared<Args>();
  auto* cmd = app.add_subcommand(
      "simulate",
      "Generate labelled event data from a simulated 3-D scene (event camera simulator)");
  cmd->footer(
      "Examples:\n"
      "  spikems simulate --preset mod --sequences 40 --duration 2s --out data/mod\n"
      "  spikems simulate --preset eed-net --noise clean --out data/eed --threads 2\n"
      "  spikems simulate --config my.toml --out data/x     (start from --print-config)\n"
      "  spikems simulate --preset mod --stats-compare poster_translation.npz\n"
      "Presets: mod, mod-translate, evimo, eed-net, poster, tiny (configs/sim/*.toml). See "
      "docs/simulator.md.");
  cmd->add_option("--preset", args->preset,
                  "Scene preset: mod, mod-translate, evimo, eed-net, poster, tiny")
      ->check(CLI::IsMember(::spikems::sim::preset_names()));
  cmd->add_option("--config", args->config, "TOML config (replaces the preset)")
      ->check(CLI::ExistingFile);
  cmd->add_option("--sequences", args->sequences, "Number of sequences")
      ->check(CLI::Range(1, 1000000));
  cmd->add_option("--duration", args->duration, "Length of each sequence (e.g. 2s, 500ms)");
  cmd->add_option("--out", args->out, "Output folder (seq_XXXX.h5 + manifest.json)");
  cmd->add_option("--threads", args->threads, "Worker threads (default: all cores)")
      ->check(CLI::Range(1, 1024));
  cmd->add_option("--seed", args->seed, "Global seed (same seed, same bytes)");
  cmd->add_option("--noise", args->noise, "Sensor noise: clean or noisy (default: config)")
      ->check(CLI::IsMember({"clean", "noisy"}));
  cmd->add_option("--width", args->width, "Sensor width (default: config)")
      ->check(CLI::Range(8, 4096));
  cmd->add_option("--height", args->height, "Sensor height (default: config)")
      ->check(CLI::Range(8, 4096));
  cmd->add_option("--mask-period", args->mask_period,
                  "Period of mask frames and poses (default 1ms; coarser = smaller files)");
  cmd->add_option("--format", args->format, "Output format (default spikems-h5)");
  cmd->add_option("--stats-compare", args->stats_compare,
                  "Print event statistics of FILE (a real recording) beside simulated ones")
      ->check(CLI::ExistingFile);
  cmd->add_flag("--print-config", args->print_config, "Print the preset's TOML and exit");
  cmd->add_flag("--no-progress", args->no_progress, "No progress bar");
  cmd->callback([args] { run(*args); });
}

}  // namespace

SPIKEMS_COMMAND(simulate, 40, add);
