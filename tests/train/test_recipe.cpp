// `spikems train --recipe` (src/cli/cmd_train_recipe.cpp) on tests/data/recipes/tiny.toml: every
// kind of stage end to end and a stage that died resumed, --stage / --list / --restart, bad
// recipes refused before anything runs, the shipped recipes' checks, users' data in every
// layout, and a data-parallel stage.
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>

#include "common/test_paths.h"
#include "common/text_file.h"
#include "core/events/formats/npy.h"
#include "core/events/io.h"
#include "core/model/model_file.h"

namespace spikems {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using test::run_command;
using test::scratch_dir;
using test::spikems_binary;

json read_json(const std::string& path) {
  return json::parse(test::read_text(path));
}

std::string tiny_recipe() {
  return test::source_dir() + "/tests/data/recipes/tiny.toml";
}

// The tiny recipe with `from` replaced by `to` (each must occur), written into `dir`.
std::string edited_recipe(const std::string& dir,
                          const std::vector<std::pair<std::string, std::string>>& edits,
                          const std::string& name = "recipe.toml") {
  std::string text = test::read_text(tiny_recipe());
  for (const auto& [from, to] : edits) {
    const size_t at = text.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) text.replace(at, from.size(), to);
  }
  const std::string path = dir + "/" + name;
  std::ofstream(path) << text;
  return path;
}

// `spikems train --recipe RECIPE --out OUT -q ARGS`, with `env` before it.
int recipe(const std::string& file, const std::string& out, const std::string& args,
           std::string* output, const std::string& env = "") {
  return run_command(env + " " + spikems_binary() + " train -q --recipe '" + file + "' --out '" +
                         out + "' " + args,
                     output);
}

std::vector<double> train_losses(const std::string& run) {
  std::vector<double> out;
  std::ifstream in(run + "/log.jsonl");
  for (std::string line; std::getline(in, line);) {
    const json j = json::parse(line);
    if (j["kind"] == "train") out.push_back(j["loss"].get<double>());
  }
  return out;
}

double max_weight_difference(const std::string& a, const std::string& b) {
  const ModelSpec ma = load_model(a), mb = load_model(b);
  EXPECT_EQ(ma.layers.size(), mb.layers.size());
  double d = 0;
  for (size_t k = 0; k < ma.layers.size() && k < mb.layers.size(); ++k) {
    EXPECT_EQ(ma.layers[k].weight.size(), mb.layers[k].weight.size());
    for (size_t i = 0; i < ma.layers[k].weight.size() && i < mb.layers[k].weight.size(); ++i)
      d = std::max(d, double(std::abs(ma.layers[k].weight[i] - mb.layers[k].weight[i])));
  }
  return d;
}

fs::file_time_type mtime(const std::string& p) {
  return fs::last_write_time(p);
}

TEST(Recipe, TinyRecipeRunsEveryKindOfStageAndResumesAStageThatDied) {
  const std::string base = scratch_dir(), out = base + "/out", b = base + "/b";
  std::string log;
  ASSERT_EQ(recipe(tiny_recipe(), out, "", &log), 0) << log;
  EXPECT_NE(log.find("[3/5] student: train, ~"), std::string::npos) << log;
  // The data sets at half resolution: 64 x 48 rooms stored at 32 x 24.
  const json m = read_json(out + "/data/rooms/manifest.json");
  EXPECT_EQ(m["sensor"], json({32, 24}));
  EXPECT_EQ(m["sequences"].size(), 4u);
  const Recording rec = read_recording(out + "/data/rooms/seq_0000.h5");
  EXPECT_EQ(rec.events.sensor, (SensorSize{32, 24}));
  // The student started from the teacher and was distilled from it.
  const json cfg = read_json(out + "/student.config.json");
  EXPECT_EQ(cfg["model"]["init_ann"], "teacher/model.safetensors");
  EXPECT_EQ(cfg["loss"]["teacher"], "teacher/model.safetensors");
  EXPECT_EQ(read_json(out + "/student/done.json")["inputs"]["@teacher"],
            read_json(out + "/teacher/done.json")["kept_hash"]);
  // Its loss falls (mean of the last five logged against the first five: 3.75 / 4.09 / 3.99
  // -> 3.03 / 2.76 / 2.73 with run.seed 1, 2, 3).
  const auto loss = train_losses(out + "/student");
  ASSERT_EQ(loss.size(), 20u);
  double first = 0, last = 0;
  for (int i = 0; i < 5; ++i) {
    first += loss[size_t(i)] / 5;
    last += loss[loss.size() - 1 - size_t(i)] / 5;
  }
  EXPECT_LT(last, first - 0.3) << "first five " << first << ", last five " << last;
  // The calibrated model, and the eval stage's results scoring it.
  const ModelSpec model = load_model(out + "/spikems-tiny.safetensors");
  EXPECT_TRUE(model.training.contains("calibration")) << model.training.dump();
  const json res = read_json(out + "/eval/heldout/results.json");
  const json& d = res["models"][0]["datasets"][0];
  EXPECT_EQ(res["models"][0]["model"], "spikems-tiny.safetensors");
  ASSERT_EQ(d["windows"].size(), 2u);
  // tiny.summary.md: one scores row holding results.json's values; the recipe copied beside it.
  char row[256];
  std::snprintf(
      row, sizeof row,
      "| heldout | spikems-tiny.safetensors | data/val | 20 / 100 | %.1f / %.1f | %.1f / %.1f |",
      d["windows"][0]["iou_mean"].get<double>(), d["windows"][1]["iou_mean"].get<double>(),
      d["windows"][0]["detection_rate"].get<double>(),
      d["windows"][1]["detection_rate"].get<double>());
  const std::string md = test::read_text(out + "/tiny.summary.md");
  EXPECT_NE(md.find(row), std::string::npos) << row << "\n" << md;
  const json sum = read_json(out + "/tiny.summary.json");
  ASSERT_EQ(sum["stages"].size(), 5u);
  double total = 0;
  for (const auto& s : sum["stages"]) total += s["wall_s"].get<double>();
  EXPECT_NEAR(sum["total_wall_s"].get<double>(), total, 1e-6);
  EXPECT_GT(total, 0);
  EXPECT_EQ(sum["scores"][0]["iou"][1], d["windows"][1]["iou_mean"]);
  EXPECT_EQ(test::read_text(out + "/tiny.recipe.toml"), test::read_text(tiny_recipe()));

  // Resume: the student again, its trainer dying after step 12 (checkpoints every 5 steps);
  // the same command then resumes it and ends with the uninterrupted run's weights.
  fs::copy(out, b, fs::copy_options::recursive);
  ASSERT_EQ(recipe(tiny_recipe(), b, "--restart student", &log, "SPIKEMS_TEST_DIE_AT_STEP=12"), 1)
      << log;
  EXPECT_NE(log.find("resumes from its last checkpoint"), std::string::npos) << log;
  EXPECT_FALSE(fs::exists(b + "/student/done.json"));
  EXPECT_FALSE(fs::exists(b + "/eval/heldout/done.json"));
  const auto data_time = mtime(b + "/data/done.json"),
             teacher_time = mtime(b + "/teacher/done.json");
  ASSERT_EQ(recipe(tiny_recipe(), b, "--list", &log), 0) << log;
  EXPECT_NE(log.find("resumable at step 10 of 20"), std::string::npos) << log;
  ASSERT_EQ(recipe(tiny_recipe(), b, "", &log), 0) << log;
  EXPECT_NE(log.find("student: train (resuming at step 10 of 20)"), std::string::npos) << log;
  EXPECT_NE(log.find("[2/5] teacher: done"), std::string::npos) << log;
  // The trainer resumes exactly (Trainer.ResumeAfterKillContinuesWithTheSameLosses): tolerance 0.
  EXPECT_EQ(
      max_weight_difference(out + "/student/model.safetensors", b + "/student/model.safetensors"),
      0.0);
  EXPECT_EQ(mtime(b + "/data/done.json"), data_time);
  EXPECT_EQ(mtime(b + "/teacher/done.json"), teacher_time);
  EXPECT_EQ(read_json(out + "/eval/heldout/results.json")["models"][0]["datasets"][0]["windows"],
            read_json(b + "/eval/heldout/results.json")["models"][0]["datasets"][0]["windows"]);
}

TEST(Recipe, StageListAndRestart) {
  const std::string dir = scratch_dir(), out = dir + "/out";
  std::string log;
  // A stage whose input is missing names it and the command that makes it.
  ASSERT_EQ(recipe(tiny_recipe(), out, "--stage student", &log), 1) << log;
  EXPECT_NE(log.find("teacher/model.safetensors"), std::string::npos) << log;
  EXPECT_NE(log.find("--stage teacher"), std::string::npos) << log;
  EXPECT_FALSE(fs::exists(out));
  // Without -q the stages' bars (their final lines, off a terminal) name the stage.
  ASSERT_EQ(run_command(spikems_binary() + " train --recipe " + tiny_recipe() + " --out " + out +
                            " --stage data",
                        &log),
            0)
      << log;
  EXPECT_NE(log.find("[1/5 data rooms] simulate [####"), std::string::npos) << log;
  EXPECT_TRUE(fs::exists(out + "/data/val/manifest.json"));
  EXPECT_FALSE(fs::exists(out + "/teacher"));
  ASSERT_EQ(recipe(tiny_recipe(), out, "--stage teacher", &log), 0) << log;
  EXPECT_EQ(train_losses(out + "/teacher").size(), 20u);
  EXPECT_FALSE(fs::exists(out + "/student"));
  // The teacher's definition changed: --list says so, a run is refused (nothing runs) until
  // --restart teacher.
  const std::string changed =
      edited_recipe(dir, {{"\"optim.steps\" = 20\n\"optim.batch\" = 4\n\"optim.warmup_steps\" = 2\n"
                           "\"run.log_every\" = 1\n\"run.val_every\" = 20",
                           "\"optim.steps\" = 16\n\"optim.batch\" = 4\n\"optim.warmup_steps\" = 2\n"
                           "\"run.log_every\" = 1\n\"run.val_every\" = 20"}});
  ASSERT_EQ(recipe(changed, out, "--list", &log), 0) << log;
  EXPECT_NE(log.find("data             data      ~3 s      done in"), std::string::npos) << log;
  EXPECT_NE(log.find("teacher          train     ~5 s      changed"), std::string::npos) << log;
  EXPECT_NE(log.find("student          train     ~8 s      pending"), std::string::npos) << log;
  EXPECT_NE(log.find("heldout          eval      ~1 s      pending"), std::string::npos) << log;
  ASSERT_EQ(recipe(changed, out, "", &log), 1) << log;
  EXPECT_NE(log.find("stage \"teacher\""), std::string::npos) << log;
  EXPECT_NE(log.find("--restart teacher"), std::string::npos) << log;
  EXPECT_FALSE(fs::exists(out + "/student"));
  EXPECT_EQ(train_losses(out + "/teacher").size(), 20u);
  ASSERT_EQ(recipe(changed, out, "--restart teacher --stage teacher", &log), 0) << log;
  EXPECT_EQ(train_losses(out + "/teacher").size(), 16u);
  EXPECT_FALSE(fs::exists(out + "/student"));
}

TEST(Recipe, BadRecipesNameFileTableAndReasonAndRunNothing) {
  const std::string dir = scratch_dir();
  struct Case {
    std::string from, to, table, reason;
  };
  const std::vector<Case> cases = {
      {"keep = \"last\"\ntime = \"5s\"", "keep = \"last\"\ntiem = \"5s\"", "stage[1] \"teacher\"",
       "unknown key \"tiem\""},
      {"\"model.init_ann\" = \"@teacher\"", "\"model.init_ann\" = \"@heldout\"",
       "stage[2] \"student\"", "\"@heldout\" is not an earlier stage"},
      {"[data.val]", "[data.mine]\npath = \"no/such/events\"\n\n[data.val]", "data.mine",
       "no such file or folder"},
      {"kind = \"calibrate\"", "kind = \"calibration\"", "stage[3] \"calibrate\"",
       "kind \"calibration\" is not one of train, calibrate, eval"},
      {"\"optim.steps\" = 20", "\"optim.stepz\" = 20", "stage[1] \"teacher\"",
       "optim.stepz: unknown key"},
      {"[data.val]", "[data.half]\nfrom = \"rooms\"\n\n[data.val]", "data.half",
       "\"from\" needs \"downsample\" of 2 or more"},
      {"[data.val]", "[data.half]\nfrom = \"nosuch\"\ndownsample = 2\n\n[data.val]", "data.half",
       "\"from\" = \"nosuch\" must name a \"simulate\" set of this recipe"},
  };
  for (size_t i = 0; i < cases.size(); ++i) {
    const Case& c = cases[i];
    const std::string file =
        edited_recipe(dir, {{c.from, c.to}}, "bad" + std::to_string(i) + ".toml");
    const std::string out = dir + "/out" + std::to_string(i);
    std::string log;
    EXPECT_EQ(recipe(file, out, "", &log), 1) << log;
    for (const std::string& needle : {file, c.table, c.reason})
      EXPECT_NE(log.find(needle), std::string::npos) << "case " << i << ": " << needle << "\n"
                                                     << log;
    EXPECT_FALSE(fs::exists(out)) << "case " << i << ": something ran";
  }
}

// Every recipe in configs/recipes/ passes the checks that precede a run (--list runs nothing).
TEST(Recipe, ShippedRecipesPassTheChecks) {
  const std::string dir = scratch_dir();
  int n = 0;
  for (const auto& e : fs::directory_iterator(test::source_dir() + "/configs/recipes")) {
    if (e.path().extension() != ".toml") continue;
    std::string log;
    EXPECT_EQ(recipe(e.path().string(), dir + "/out", "--list", &log), 0) << log;
    EXPECT_NE(log.find("pending"), std::string::npos) << log;
    ++n;
  }
  EXPECT_GE(n, 1);
  EXPECT_FALSE(fs::exists(dir + "/out"));
}

// Users' labelled data as EV-IMO v1 npz, an EVIMO2 v2 folder and a labelled event file, made
// here from one simulated 64 x 48 room (mask frames every 10 ms, object ids per event).
struct UserData {
  std::string npz, evimo2, labelled;
};

UserData make_user_data(const std::string& dir) {
  std::string log;
  EXPECT_EQ(run_command(spikems_binary() +
                            " simulate --preset tiny --sequences 1 --duration 0.2s --seed 21 "
                            "--mask-period 10ms --threads 1 --no-progress --out " +
                            dir + "/sim",
                        &log),
            0)
      << log;
  UserData u{dir + "/evimo1.npz", dir + "/evimo2", dir + "/labelled.h5"};
  const std::string seq = dir + "/sim/seq_0000.h5";
  fs::copy_file(seq, u.labelled);
  const Recording r = read_recording(seq);
  const size_t n = r.events.size(), F = r.masks.size();
  const int W = r.events.sensor.width, H = r.events.sensor.height;
  std::vector<float> ev;
  std::vector<double> t;
  std::vector<uint16_t> xy, masks;
  std::vector<uint8_t> p;
  for (size_t i = 0; i < n; ++i) {
    const double ts = double(r.events.t[i]) / 1e6;
    ev.insert(ev.end(),
              {float(ts), float(r.events.x[i]), float(r.events.y[i]), float(r.events.p[i])});
    t.push_back(ts);
    xy.insert(xy.end(), {r.events.x[i], r.events.y[i]});
    p.push_back(r.events.p[i]);
  }
  std::map<std::string, NpyArray> npz2;
  for (size_t f = 0; f < F; ++f) {
    std::vector<uint16_t> m(size_t(W * H));
    for (size_t k = 0; k < m.size(); ++k) m[k] = uint16_t(r.masks[f].ids[k] * 1000);
    masks.insert(masks.end(), m.begin(), m.end());
    char key[32];
    std::snprintf(key, sizeof key, "mask_%010zu", f);
    npz2[key] = NpyArray::from(m, {H, W});
  }
  std::map<std::string, NpyArray> npz1;
  npz1["events"] = NpyArray::from(ev, {int64_t(n), 4});
  npz1["mask"] = NpyArray::from(masks, {int64_t(F), H, W});
  npz1["discretization"] = NpyArray::from(std::vector<double>{0.01}, {});
  write_npz(u.npz, npz1, false);
  fs::create_directories(u.evimo2);
  write_npy(u.evimo2 + "/dataset_events_t.npy", NpyArray::from(t, {int64_t(n)}));
  write_npy(u.evimo2 + "/dataset_events_xy.npy", NpyArray::from(xy, {int64_t(n), 2}));
  write_npy(u.evimo2 + "/dataset_events_p.npy", NpyArray::from(p, {int64_t(n)}));
  write_npz(u.evimo2 + "/dataset_mask.npz", npz2, false);
  return u;
}

TEST(Recipe, UsersDataInEveryLayoutIsRewrittenAtItsResolution) {
  const std::string dir = scratch_dir(), out = dir + "/out";
  const UserData u = make_user_data(dir);
  // Three sets at half resolution, a two-step student on each.
  std::string text =
      "[recipe]\nname = \"mine\"\nmodel = \"mine.safetensors\"\n"
      "[data.npz]\npath = \"" +
      u.npz +
      "\"\ndownsample = 2\n"
      "[data.evimo2]\npath = \"" +
      u.evimo2 +
      "\"\ndownsample = 2\n"
      "[data.labelled]\npath = \"labelled.h5\"\ndownsample = 2\n";
  for (const char* set : {"npz", "evimo2", "labelled"})
    text += std::string("[[stage]]\nname = \"on-") + set +
            "\"\nkind = \"train\"\nkeep = \"last\"\n[stage.set]\n\"model.channels\" = [8, 16]\n"
            "\"data.train\" = [{ path = \"data/" +
            set +
            "\", split = \"all\" }]\n\"sample.crop\" = 0\n\"sample.warmup_ms\" = 5\n"
            "\"optim.steps\" = 2\n\"optim.batch\" = 2\n\"optim.warmup_steps\" = 1\n";
  std::ofstream(dir + "/mine.toml") << text;  // "labelled.h5": relative to the recipe
  std::string log;
  ASSERT_EQ(recipe(dir + "/mine.toml", out, "", &log), 0) << log;
  for (const char* set : {"npz", "evimo2", "labelled"}) {
    const std::string d = out + "/data/" + set;
    EXPECT_EQ(read_json(d + "/manifest.json")["sensor"], json({32, 24})) << set;
    const Recording r = read_recording(d + "/seq_0000.h5");
    EXPECT_EQ(r.events.sensor, (SensorSize{32, 24})) << set;
    ASSERT_TRUE(r.events.has_labels()) << set;
    size_t moving = 0;
    for (uint16_t l : r.events.label) {
      EXPECT_LE(l, 1) << set;
      moving += l == 1;
    }
    EXPECT_GT(moving, 0u) << set;
    EXPECT_LT(moving, r.events.size()) << set;
    const ModelSpec m = load_model(out + "/on-" + std::string(set) + "/model.safetensors");
    EXPECT_EQ(m.training["steps"], 2) << set;
    EXPECT_EQ(m.train_width, 32) << set;
  }
  EXPECT_TRUE(fs::exists(out + "/mine.safetensors"));  // the last train stage's, copied
}

// Two recipes whose first stages are defined alike share one OUT: the second finds them done
// and runs only its own stages (the shipped default and fast recipes share their teachers).
TEST(Recipe, RecipesShareTheStagesTheyDefineAlike) {
  const std::string dir = scratch_dir(), out = dir + "/out";
  std::string log;
  ASSERT_EQ(recipe(tiny_recipe(), out, "--stage data", &log), 0) << log;
  ASSERT_EQ(recipe(tiny_recipe(), out, "--stage teacher", &log), 0) << log;
  const auto teacher_time = mtime(out + "/teacher/done.json");
  const std::string other =
      edited_recipe(dir,
                    {{"name = \"tiny\"", "name = \"other\""},
                     {"model = \"spikems-tiny.safetensors\"", "model = \"other.safetensors\""},
                     {"name = \"student\"", "name = \"student2\""},
                     {"\"optim.steps\" = 20\n\"optim.batch\" = 4\n\"optim.warmup_steps\" = 2\n"
                      "\"run.log_every\" = 1\n\"run.val_every\" = 20\n\"run.val_samples\" = 8\n"
                      "\"run.checkpoint_every\" = 5\n\n[[stage]]\nname = \"calibrate\"",
                      "\"optim.steps\" = 6\n\"optim.batch\" = 4\n\"optim.warmup_steps\" = 2\n"
                      "\"run.log_every\" = 1\n\"run.val_every\" = 20\n\"run.val_samples\" = 8\n"
                      "\"run.checkpoint_every\" = 5\n\n[[stage]]\nname = \"calibrate\""},
                     {"from = \"@student\"", "from = \"@student2\""}},
                    "other.toml");
  ASSERT_EQ(recipe(other, out, "--list", &log), 0) << log;
  const auto line = [&](const std::string& stage) {
    const size_t at = log.find(" " + stage + " ");
    return at == std::string::npos ? std::string() : log.substr(at, log.find('\n', at) - at);
  };
  EXPECT_NE(line("teacher").find("done in"), std::string::npos) << log;
  EXPECT_NE(line("student2").find("pending"), std::string::npos) << log;
  ASSERT_EQ(recipe(other, out, "", &log), 0) << log;
  EXPECT_EQ(mtime(out + "/teacher/done.json"), teacher_time);
  EXPECT_EQ(train_losses(out + "/student2").size(), 6u);
  EXPECT_EQ(read_json(out + "/student2/done.json")["inputs"]["@teacher"],
            read_json(out + "/teacher/done.json")["kept_hash"]);
  EXPECT_TRUE(fs::exists(out + "/other.safetensors"));
  EXPECT_FALSE(fs::exists(out + "/student"));  // the first recipe's own stage never ran
  // Each recipe keeps its own copy and summary in the shared OUT.
  EXPECT_EQ(test::read_text(out + "/tiny.recipe.toml"), test::read_text(tiny_recipe()));
  EXPECT_EQ(test::read_text(out + "/other.recipe.toml"), test::read_text(other));
  EXPECT_NE(test::read_text(out + "/other.summary.md").find("# Recipe other"), std::string::npos);
  EXPECT_FALSE(fs::exists(out + "/tiny.summary.md"));  // tiny has not run to its end
}

// `from`: a simulated set made again at 1/2 resolution without simulating it twice. "a-half"
// sorts before its source, so the runner must order the sets itself.
TEST(Recipe, FromSetIsItsSourceAtLowerResolution) {
  const std::string dir = scratch_dir(), out = dir + "/out";
  const std::string file = edited_recipe(
      dir, {{"[data.val]", "[data.a-half]\nfrom = \"rooms\"\ndownsample = 2\n\n[data.val]"}});
  std::string log;
  ASSERT_EQ(recipe(file, out, "--stage data", &log), 0) << log;
  const json src = read_json(out + "/data/rooms/manifest.json");
  const json half = read_json(out + "/data/a-half/manifest.json");
  EXPECT_EQ(src["sensor"], json({32, 24}));
  EXPECT_EQ(half["sensor"], json({16, 12}));
  ASSERT_EQ(half["sequences"].size(), src["sequences"].size());
  const Recording a = read_recording(out + "/data/rooms/seq_0001.h5");
  const Recording b = read_recording(out + "/data/a-half/seq_0001.h5");
  ASSERT_EQ(b.events.size(), a.events.size());
  ASSERT_TRUE(b.events.has_labels());
  for (size_t i = 0; i < a.events.size(); ++i) {
    ASSERT_EQ(b.events.x[i], a.events.x[i] / 2) << i;
    ASSERT_EQ(b.events.y[i], a.events.y[i] / 2) << i;
    ASSERT_EQ(b.events.label[i], a.events.label[i]) << i;
  }
  // Its definition follows its source's: a changed source makes the data stage "changed".
  const std::string changed = edited_recipe(
      dir, {{"[data.val]", "[data.a-half]\nfrom = \"rooms\"\ndownsample = 2\n\n[data.val]"},
            {"seed = 11", "seed = 13"}});
  EXPECT_NE(recipe(changed, out, "--stage data", &log), 0);
  EXPECT_NE(log.find("data set"), std::string::npos) << log;
}

// `data_threads` gives the simulator more threads than the train stages: the same bytes, the
// same stage definition (the sets made with one thread are kept), and --threads still wins.
TEST(Recipe, DataThreadsMakeTheSameSets) {
  const std::string dir = scratch_dir(), one = dir + "/one", two = dir + "/two";
  const std::string file =
      edited_recipe(dir, {{"threads = 1\n", "threads = 1\ndata_threads = 2\n"}});
  std::string log;
  ASSERT_EQ(recipe(tiny_recipe(), one, "--stage data", &log), 0) << log;
  ASSERT_EQ(recipe(file, two, "--stage data", &log), 0) << log;
  EXPECT_EQ(read_json(one + "/data/rooms/recipe-set.json")["threads"], 1);
  EXPECT_EQ(read_json(two + "/data/rooms/recipe-set.json")["threads"], 2);
  for (const char* f : {"manifest.json", "seq_0000.h5", "seq_0003.h5"})
    EXPECT_EQ(test::read_text(one + "/data/rooms/" + f), test::read_text(two + "/data/rooms/" + f))
        << f;
  const auto made = mtime(one + "/data/rooms/seq_0000.h5");
  ASSERT_EQ(recipe(file, one, "--stage data", &log), 0) << log;
  EXPECT_EQ(mtime(one + "/data/rooms/seq_0000.h5"), made) << log;
  const std::string three = dir + "/three";
  ASSERT_EQ(recipe(file, three, "--stage data --threads 1", &log), 0) << log;
  EXPECT_EQ(read_json(three + "/data/val/recipe-set.json")["threads"], 1);
  const std::string bad =
      edited_recipe(dir, {{"threads = 1\n", "threads = 1\ndata_threads = -2\n"}}, "bad.toml");
  EXPECT_EQ(recipe(bad, dir + "/bad", "--stage data", &log), 1) << log;
  EXPECT_NE(log.find("data_threads"), std::string::npos) << log;
  EXPECT_FALSE(fs::exists(dir + "/bad"));
}

// A port the kernel just handed out (free unless taken in the next milliseconds).
int free_port() {
  int s = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  EXPECT_EQ(bind(s, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
  socklen_t n = sizeof a;
  getsockname(s, reinterpret_cast<sockaddr*>(&a), &n);
  close(s);
  return ntohs(a.sin_port);
}

TEST(RecipeSlow, DataParallelStageEqualsOneProcess) {
  const std::string dir = scratch_dir(), one = dir + "/one", two = dir + "/two";
  // A student loss that is a mean over samples (as in Distributed.*): L_spike and the activity
  // term, no distillation, rate bounds or soft IoU; a batch of 2, one sample per rank.
  const std::string file = edited_recipe(
      dir, {{"\"loss.teacher\" = \"@teacher\"\n\"loss.teacher_weight\" = 1.0\n\"optim.steps\" = "
             "20\n\"optim.batch\" = 4",
             "\"loss.kind\" = \"spike\"\n\"loss.iou_weight\" = 0.0\n\"loss.floor_weight\" = "
             "0.0\n\"optim.steps\" = 3\n\"optim.batch\" = 2"}});
  std::string log;
  ASSERT_EQ(recipe(file, one, "--stage data", &log), 0) << log;
  ASSERT_EQ(recipe(file, one, "--stage teacher", &log), 0) << log;
  fs::copy(one, two, fs::copy_options::recursive);
  ASSERT_EQ(recipe(file, one, "--stage student", &log), 0) << log;
  // The student is stage 3: its ranks meet at --master-port + 2.
  const int port = free_port() - 2;
  const std::string cmd =
      spikems_binary() + " train -q --recipe '" + file + "' --out '" + two +
      "' --stage student --world-size 2 --master-addr 127.0.0.1 --master-port " +
      std::to_string(port) + " --dist-timeout 60 --rank ";
  run_command("bash -c \"(timeout -s KILL 120 " + cmd + "0 > " + dir + "/out0 2>&1; echo $? > " +
              dir + "/rc0) & (timeout -s KILL 120 " + cmd + "1 > " + dir +
              "/out1 2>&1; echo $? > " + dir + "/rc1) & wait\"");
  EXPECT_EQ(std::atoi(test::read_text(dir + "/rc0").c_str()), 0) << test::read_text(dir + "/out0");
  EXPECT_EQ(std::atoi(test::read_text(dir + "/rc1").c_str()), 0) << test::read_text(dir + "/out1");
  ASSERT_TRUE(fs::exists(two + "/student/done.json")) << test::read_text(dir + "/out0");
  // Tolerance as Distributed.TwoRanksEqualOneProcessWithTheCombinedBatch: the ranks' gradients
  // are summed in another order (float rounding).
  EXPECT_LT(
      max_weight_difference(one + "/student/model.safetensors", two + "/student/model.safetensors"),
      1e-5);
  EXPECT_EQ(train_losses(two + "/student").size(), 3u);
}

}  // namespace
}  // namespace spikems
