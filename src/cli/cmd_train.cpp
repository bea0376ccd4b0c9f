// `spikems train --config configs/train/NAME.toml --out runs/NAME`: trains the SpikeMS network
// (src/train/trainer/). This file only parses the command line and calls the trainer.
#include <cstdio>

#include "cli/command.h"
#include "core/util/error.h"
#include "train/trainer/trainer.h"

namespace {

struct Args {
  std::string config, out, resume;
  std::vector<std::string> set;
  int steps = 0, threads = -1;
  std::string device, kernels;
  bool quiet = false;
  std::string command;
};

void run(const Args& a) {
  using namespace spikems::train;
  std::vector<std::string> overrides = a.set;
  if (a.steps > 0) overrides.push_back("optim.steps=" + std::to_string(a.steps));
  if (a.threads >= 0) overrides.push_back("run.threads=" + std::to_string(a.threads));
  if (!a.device.empty()) overrides.push_back("run.device=\"" + a.device + "\"");
  if (!a.kernels.empty()) overrides.push_back("run.kernels=\"" + a.kernels + "\"");
  TrainRunOptions ro;
  ro.progress = !a.quiet;
  ro.command = a.command;
  TrainConfig cfg;
  if (!a.resume.empty()) {
    if (!a.config.empty())
      spikems::fail("spikems train", "",
                    "--resume takes the run's own config.json; "
                    "change keys with --set instead of --config");
    ro.out_dir = a.resume;
    ro.resume = true;
    cfg = load_run_config(a.resume, overrides);
  } else {
    if (a.config.empty() || a.out.empty())
      spikems::fail("spikems train", "", "give --config FILE and --out DIR (or --resume DIR)");
    ro.out_dir = a.out;
    cfg = load_train_config(a.config, overrides);
  }
  TrainResult r = run_training(cfg, ro);
  std::printf(
      "trained %lld steps in %.0f s; best validation IoU %.1f %%; model: %s/model.safetensors"
      " (best: %s/best.safetensors)\n",
      (long long)r.steps, r.wall_seconds, r.best_val_iou, ro.out_dir.c_str(), ro.out_dir.c_str());
}

void add(CLI::App& app) {
  auto a = std::make_shared<Args>();
  auto* cmd = app.add_subcommand(
      "train", "Train the SpikeMS network on labelled event data (simulated or recorded)");
  cmd->add_option("--config,-c", a->config,
                  "training configuration (TOML, configs/train/; or a run's config.json)")
      ->check(CLI::ExistingFile);
  cmd->add_option("--out,-o", a->out, "run folder: log, checkpoints, models");
  cmd->add_option("--resume", a->resume, "continue the run in this folder from its checkpoint")
      ->check(CLI::ExistingDirectory);
  cmd->add_option("--set", a->set, "override a config key: section.key=value (repeatable)");
  cmd->add_option("--steps", a->steps, "training length in steps (optim.steps)")
      ->check(CLI::Range(1, 1 << 30));
  cmd->add_option("--threads", a->threads, "CPU threads (run.threads; 0 = all cores)")
      ->check(CLI::Range(0, 1024));
  cmd->add_option("--device", a->device, "cpu or cuda (run.device)")
      ->check(CLI::IsMember({"cpu", "cuda"}));
  cmd->add_option("--kernels", a->kernels,
                  "synapse kernels (run.kernels): auto, sparse (scatter of the input spikes) or "
                  "dense (LibTorch convolutions)")
      ->check(CLI::IsMember({"auto", "sparse", "dense"}));
  cmd->add_flag("--quiet,-q", a->quiet, "no progress bar");
  cmd->footer(
      "Examples:\n"
      "  spikems simulate --preset mod --sequences 20 --duration 2s --out data/mod-train\n"
      "  spikems train --config configs/train/default.toml --out runs/default\n"
      "  spikems train --resume runs/default                  (after a stop or a kill)\n"
      "  spikems train --config configs/train/default.toml --out runs/x --set loss.kind=both "
      "--set optim.lr=0.002 --steps 500\n"
      "The run folder gets config.json, log.jsonl, curves.svg, checkpoint.pt, model.safetensors "
      "and best.safetensors. Every key: docs/training.md.");
  cmd->callback([a] {
    a->command = spikems::cli::invoked_command();
    run(*a);
  });
}

}  // namespace

SPIKEMS_COMMAND(train, 60, add);
