// `spikems train --recipe FILE --out DIR`: runs a whole training recipe (data sets, train,
// calibrate and eval stages; docs/training.md, "Recipes") by spawning one `spikems` command per
// stage with the output folder as working directory. It reads and writes only files, TOML and
// JSON (no LibTorch in it), so that it compiles fast and fails before any stage on a bad recipe.
#pragma once

#include <string>

namespace spikems::cli {

struct RecipeRunOptions {
  std::string recipe, out;
  std::string stage;    // run only this stage ("data": the data sets)
  std::string restart;  // delete this stage's results and every later stage's done.json first
  bool list = false;    // print the stages and their state, run nothing
  bool quiet = false;   // no progress bars in the stages (the per-stage lines stay)
  int threads = -1;     // -1: the recipe's recipe.threads
  std::string device;   // passed to train stages (cpu, cuda); empty: each config's own
  // Data-parallel (resolved like plain `spikems train`): rank 0 runs the non-train stages, every
  // rank runs each train stage with master_port + the stage's index.
  int rank = 0, world_size = 1, master_port = 29500;
  std::string master_addr;
  double dist_timeout_s = 300;
};

// Throws spikems::Error naming the recipe file, the table and the reason.
void run_recipe(const RecipeRunOptions& o);

}  // namespace spikems::cli
