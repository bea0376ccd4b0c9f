// `spikems average`: write the uniform average of several snapshots of one training run
// (core/model/model_average.h). Parses the options and calls the core.
#include <cstdio>
#include <filesystem>

#include "cli/command.h"
#include "core/model/model_average.h"
#include "core/util/error.h"

namespace {

using namespace spikems;
namespace fs = std::filesystem;

struct Args {
  std::vector<std::string> models;
  std::string out;
  bool quiet = false;
};

void run(const Args& a) {
  if (a.models.size() < 2)
    fail("--model", "",
         "give at least two models to average, e.g. --model a.safetensors "
         "b.safetensors");
  std::vector<ModelSpec> specs;
  for (const std::string& p : a.models) {
    std::error_code ec;
    if (fs::equivalent(p, a.out, ec))
      fail("--out " + a.out, "", "is one of the models: write the average to a new file");
    specs.push_back(load_model(p));
  }
  save_model(a.out, average_models(specs, a.models));
  if (!a.quiet)
    std::fprintf(stderr,
                 "wrote %s: the average of %zu models (calibrate it before use: `spikems "
                 "calibrate --model %s ...`)\n",
                 a.out.c_str(), specs.size(), a.out.c_str());
}

void add(CLI::App& app) {
  static Args a;
  auto* cmd = app.add_subcommand(
      "average",
      "(experimental) Average the weights of several snapshots of one training run into one "
      "model");
  cmd->footer(
      "Weights, axonal delays and biases are averaged element by element (stochastic weight "
      "averaging); the models must be snapshots of one network with identical settings "
      "(architecture, neurons, thresholds, output gate), else the first difference is named. "
      "Snapshots a few hundred steps apart can differ in how much they call moving; an "
      "average over a window of them smooths that. The average keeps the first model's name "
      "and training record, drops its calibration and lists its sources in "
      "training.averaged_from: choose its output threshold again with `spikems calibrate`.\n\n"
      "Example:\n"
      "  spikems average --model my-run/val-step2500.safetensors my-run/val-step2750.safetensors "
      "my-run/model.safetensors --out my-run/swa.safetensors");
  cmd->add_option("--model", a.models, "Model files to average (two or more)")->required();
  cmd->add_option("--out", a.out, "Where to write the average (a new file; written atomically)")
      ->required();
  cmd->add_flag("--quiet", a.quiet, "No note on stderr");
  cmd->callback([] { run(a); });
}

}  // namespace

SPIKEMS_COMMAND(average, 48, add);
