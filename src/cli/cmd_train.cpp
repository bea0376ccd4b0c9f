// `spikems train --config configs/train/NAME.toml --out DIR`: trains the SpikeMS network
// (src/train/trainer/); `--recipe FILE` runs a whole recipe of stages (cmd_train_recipe.h).
// This file only parses the command line and calls the trainer or the recipe runner.
#include <cstdio>

#include "cli/cmd_train_recipe.h"
#include "cli/command.h"
#include "cli/torch_helper.h"
#include "core/util/duration.h"
#include "core/util/error.h"
#include "core/util/host_memory.h"
#include "train/trainer/trainer.h"

namespace {

struct Args {
  std::string config, out, resume;
  std::vector<std::string> set;
  int steps = 0, threads = -1;
  std::string device, kernels, time_limit;
  bool quiet = false;
  std::string command;
  spikems::train::DistFlags dist;
  std::string recipe, stage, restart;
  bool list = false;
};

void run_recipe_command(const Args& a) {
  const char* other = !a.config.empty()       ? "--config"
                      : !a.resume.empty()     ? "--resume"
                      : !a.set.empty()        ? "--set"
                      : a.steps > 0           ? "--steps"
                      : !a.kernels.empty()    ? "--kernels"
                      : !a.time_limit.empty() ? "--time-limit"
                                              : nullptr;
  if (other)
    spikems::fail("spikems train --recipe", "",
                  std::string(other) +
                      " does not go with --recipe: each stage's keys are in the recipe "
                      "([stage.set])");
  if (a.out.empty()) spikems::fail("spikems train --recipe", "", "give --out DIR");
  spikems::cli::RecipeRunOptions o;
  o.recipe = a.recipe;
  o.out = a.out;
  o.stage = a.stage;
  o.restart = a.restart;
  o.list = a.list;
  o.quiet = a.quiet;
  o.threads = a.threads;
  o.device = a.device;
  const spikems::train::DistOptions d = spikems::train::resolve_dist_options(a.dist);
  o.rank = d.rank;
  o.world_size = d.world_size;
  o.master_addr = d.master_addr;
  o.master_port = d.master_port;
  o.dist_timeout_s = d.timeout_s;
  spikems::cli::run_recipe(o);
}

void run(const Args& a) {
  using namespace spikems::train;
  if (!a.recipe.empty()) return run_recipe_command(a);
  if (!a.stage.empty() || !a.restart.empty() || a.list)
    spikems::fail("spikems train", "", "--stage, --restart and --list go with --recipe FILE");
  std::vector<std::string> overrides = a.set;
  if (a.steps > 0) overrides.push_back("optim.steps=" + std::to_string(a.steps));
  if (a.threads >= 0) overrides.push_back("run.threads=" + std::to_string(a.threads));
  if (!a.device.empty()) overrides.push_back("run.device=\"" + a.device + "\"");
  if (!a.kernels.empty()) overrides.push_back("run.kernels=\"" + a.kernels + "\"");
  spikems::keep_freed_memory();  // freed tensor memory reused: no page faults per step
  TrainRunOptions ro;
  ro.dist = resolve_dist_options(a.dist);  // flags, then MASTER_ADDR, MASTER_PORT, RANK, WORLD_SIZE
  ro.progress = !a.quiet;
  ro.command = a.command;
  if (!a.time_limit.empty()) {
    const int64_t us = spikems::parse_duration_us(a.time_limit);
    if (us <= 0)
      spikems::fail("--time-limit", a.time_limit,
                    "must be a positive duration, e.g. 9min or 150min");
    ro.time_limit_s = double(us) / 1e6;
  }
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
  if (ro.dist.rank != 0) {  // rank 0 reports the run
    std::printf("rank %d: trained %lld steps\n", ro.dist.rank, (long long)r.steps);
    return;
  }
  std::printf(
      "trained %lld steps in %.0f s; best validation IoU %.1f %%; model: %s/model.safetensors"
      " (best: %s/best.safetensors)\n",
      (long long)r.steps, r.wall_seconds, r.best_val_iou, ro.out_dir.c_str(), ro.out_dir.c_str());
  if (r.time_limit_reached)
    std::printf(
        "stopped by --time-limit at step %lld of %lld; continue with: spikems train "
        "--resume %s\n",
        (long long)r.steps, (long long)cfg.steps, ro.out_dir.c_str());
}

void add(CLI::App& app) {
  static Args a;
  auto* cmd = app.add_subcommand("train", spikems::cli::torch_command("train").description);
  cmd->add_option("--config,-c", a.config,
                  "training configuration (TOML, configs/train/; or a run's config.json)")
      ->check(CLI::ExistingFile);
  cmd->add_option("--out,-o", a.out,
                  "run folder: log, checkpoints, models (with --recipe: the recipe's output "
                  "folder)");
  cmd->add_option("--recipe", a.recipe,
                  "run a whole recipe (TOML: data sets, then train, calibrate and eval stages) "
                  "into --out; the same command again continues after a stop or a kill")
      ->check(CLI::ExistingFile);
  cmd->add_option("--stage", a.stage,
                  "with --recipe: run only this stage (\"data\": the data sets); what it reads "
                  "must be made");
  cmd->add_flag("--list", a.list,
                "with --recipe: print the stages (kind, expected time, done / resumable / "
                "pending) and exit");
  cmd->add_option("--restart", a.restart,
                  "with --recipe: delete this stage's results and every later stage's done.json "
                  "first (after its definition changed)");
  cmd->add_option("--resume", a.resume, "continue the run in this folder from its checkpoint")
      ->check(CLI::ExistingDirectory);
  cmd->add_option("--set", a.set, "override a config key: section.key=value (repeatable)");
  cmd->add_option("--steps", a.steps, "training length in steps (optim.steps)")
      ->check(CLI::Range(1, 1 << 30));
  cmd->add_option("--threads", a.threads,
                  "CPU threads (run.threads; 0 = all cores; with --recipe: every stage's)")
      ->check(CLI::Range(0, 1024));
  cmd->add_option("--device", a.device, "cpu or cuda (run.device)")
      ->check(CLI::IsMember({"cpu", "cuda"}));
  cmd->add_option("--kernels", a.kernels,
                  "synapse kernels (run.kernels): auto, sparse (scatter of the input spikes) or "
                  "dense (LibTorch convolutions)")
      ->check(CLI::IsMember({"auto", "sparse", "dense"}));
  cmd->add_flag("--quiet,-q", a.quiet, "no progress bar");
  cmd->add_option("--time-limit", a.time_limit,
                  "stop after the step that ends past this wall time (e.g. 9min, 150min, 3600s; "
                  "data loading counts), with a checkpoint; continue with --resume");
  // Data-parallel training, launched like torchrun (docs/training.md).
  cmd->add_option("--world-size", a.dist.world_size,
                  "data-parallel: number of processes (WORLD_SIZE; 1 = single process)")
      ->check(CLI::Range(1, 65536));
  cmd->add_option("--rank", a.dist.rank, "data-parallel: this process's rank (RANK)")
      ->check(CLI::Range(0, 65535));
  cmd->add_option("--master-addr", a.dist.master_addr,
                  "data-parallel: rank 0's host name or address (MASTER_ADDR)");
  cmd->add_option("--master-port", a.dist.master_port,
                  "data-parallel: rank 0's store port (MASTER_PORT; default 29500)")
      ->check(CLI::Range(1, 65535));
  cmd->add_option("--dist-timeout", a.dist.timeout_s,
                  "data-parallel: seconds a rank waits for the others before stopping "
                  "(default 300)")
      ->check(CLI::Range(0.001, 1e7));
  cmd->footer(
      "Examples:\n"
      "  spikems train --config configs/train/default.toml --out my-run\n"
      "  spikems train --resume my-run --time-limit 150min   (continue after a stop or a kill; "
      "at most 150 minutes, then a checkpoint)\n"
      "  spikems train --config configs/train/default.toml --out my-run --set optim.lr=0.002 "
      "--steps 500\n"
      "  spikems train --recipe configs/recipes/quick.toml --out out/quick   (data, stages, "
      "calibration, scores, NAME.summary.md; the same command again continues)\n"
      "  spikems train --recipe configs/recipes/quick.toml --out out/quick --list   (each "
      "stage's state)\n"
      "The run folder gets config.json, log.jsonl, curves.svg, checkpoint.pt, model.safetensors "
      "and best.safetensors. Every key, recipes, and data-parallel runs (--world-size, --rank, "
      "--master-addr on every process): docs/training.md.");
  cmd->callback([] {
    a.command = spikems::cli::invoked_command();
    run(a);
  });
}

}  // namespace

SPIKEMS_COMMAND(train, 60, add);
