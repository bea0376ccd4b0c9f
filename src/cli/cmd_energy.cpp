// `spikems energy`: SynOps per sample counted by the runtime on real data, against the MACs of
// the ANN-2D of the same shapes, and the energy of both (docs/evaluation.md). Parses the
// options and calls core/eval/energy.
#include <cmath>
#include <cstdio>

#include "cli/command.h"
#include "core/eval/energy.h"
#include "core/model/default_model.h"
#include "core/util/error.h"
#include "core/util/interrupt.h"

namespace {

using namespace spikems;

struct Args {
  std::string model, split = "test", out;
  std::vector<std::string> data;
  double window_ms = 10, max_seconds = 0;
  int threads = 1;
  bool iir = false, quiet = false;
};

void run(const Args& a) {
  install_interrupt_flag();
  cli::check_split(a.split);
  if (a.max_seconds < 0) fail("--max-seconds", "", "must be positive");
  if (!(a.window_ms > 0) || !std::isfinite(a.window_ms))
    fail("--window-ms", "", "a window length must be positive");
  if (a.data.empty()) fail("spikems energy", "", "no data given (--data PATH)");
  EnergyOptions o;
  o.model_path = resolve_model(a.model);
  o.data = a.data;
  o.split = a.split;
  o.window_us = std::llround(a.window_ms * 1000.0);
  o.max_seconds = a.max_seconds;
  o.threads = a.threads;
  o.iir = a.iir;
  o.progress = !a.quiet;
  o.command_line = cli::invoked_command();
  const EnergyReport r = measure_energy(o);
  if (!a.out.empty()) write_energy(r, a.out);
  std::fputs(energy_table(r).c_str(), stdout);
  std::fflush(stdout);
  if (r.interrupted)
    std::fprintf(stderr, "spikems energy: interrupted; the counts hold the sequences finished\n");
  if (!a.out.empty() && !a.quiet)
    std::fprintf(stderr, "results in %s/results.{json,md}\n", a.out.c_str());
}

void add(CLI::App& app) {
  static Args a;
  auto* cmd = app.add_subcommand(
      "energy", "Count SynOps per sample on data and compare the energy with the ANN-2D's");
  cmd->footer(
      "Each sequence runs once through the streaming network (whole sensor). Per layer: "
      "neurons, input and output spikes, firing rate, SynOps (each input spike times the "
      "neurons it reached, borders included), and the MACs of the same layer as a dense ANN "
      "(conv: output positions x C_out x C_in x k^2; transposed conv: input positions x C_in x "
      "C_out x k^2). A sample is one window of --window-ms on the whole sensor; energy at 0.9 "
      "pJ per accumulate and 4.6 pJ per MAC. See docs/evaluation.md.\n\n"
      "Examples:\n"
      "  spikems energy --model m.safetensors --data data/mod --out energy-out\n"
      "  spikems energy --model m.safetensors --data rec.h5 --window-ms 20 --max-seconds 2");
  cmd->add_option("--model", a.model,
                  "Model file, or a shipped model's name (default or fast; default: the shipped "
                  "default)");
  cmd->add_option("--data", a.data,
                  "A `spikems simulate` folder (manifest.json) or an event file; repeatable");
  cmd->add_option("--split", a.split, "Split of simulator folders: train, val, test or all")
      ->capture_default_str();
  cmd->add_option("--window-ms", a.window_ms, "Sample length in ms (the paper's window)")
      ->capture_default_str();
  cmd->add_option("--max-seconds", a.max_seconds, "Only the first S seconds of each sequence");
  cmd->add_option("--out", a.out, "Folder for results.json and results.md");
  cmd->add_option("--threads", a.threads, "Threads inside the network (counts identical)")
      ->check(CLI::Range(1, 256));
  cmd->add_flag("--iir", a.iir, "Run FIR layers as the exact recursions of their neurons");
  cmd->add_flag("--quiet", a.quiet, "No progress bar or notes on stderr");
  cmd->callback([] { run(a); });
}

}  // namespace

SPIKEMS_COMMAND(energy, 47, add);
