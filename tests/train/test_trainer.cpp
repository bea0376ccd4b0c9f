// `spikems train` end to end on tiny simulated data: the loss falls and validation IoU beats
// the untrained network; a run killed with SIGKILL and resumed continues with exactly the
// losses of an uninterrupted run; bad configurations and a non-finite loss stop with messages
// naming the key or the step.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <thread>

#include "common/test_paths.h"
#include "core/eval/evaluation.h"
#include "core/events/io.h"
#include "core/model/model_file.h"
#include "core/util/error.h"
#include "train/trainer/train_config.h"
#include "train/trainer/trainer.h"

namespace spikems::train {
namespace {

namespace fs = std::filesystem;
using test::run_command;
using test::scratch_dir;
using test::spikems_binary;

// A tiny simulated dataset shared by the tests of this file (made once).
const std::string& tiny_data() {
  static std::string dir = [] {
    std::string d = fs::temp_directory_path() / ("spikems_train_tiny_" + std::to_string(getpid()));
    fs::remove_all(d);
    std::string out;
    int rc = run_command(spikems_binary() +
                             " simulate --preset tiny --sequences 6 --duration 0.3s --seed 11 "
                             "--threads 1 --no-progress --out " +
                             d,
                         &out);
    EXPECT_EQ(rc, 0) << out;
    test::scratch_registry.dirs.push_back(d);
    return d;
  }();
  return dir;
}

// `f` must throw an E whose message names every one of `needles`; `what` says what was wrongly
// accepted otherwise.
template <class E = std::exception, class F>
void expect_refused(F&& f, std::initializer_list<std::string> needles, const std::string& what) {
  try {
    f();
    ADD_FAILURE() << what << " was accepted";
  } catch (const E& e) {
    for (const auto& n : needles)
      EXPECT_NE(std::string(e.what()).find(n), std::string::npos) << e.what();
  }
}

std::vector<std::string> tiny_overrides(int steps) {
  const std::string d = tiny_data();
  return {"data.train=[{path=\"" + d + "\", split=\"train\"}]",
          "data.val=[{path=\"" + d + "\", split=\"val\"}]",
          "sample.crop=32",
          "sample.warmup_ms=5",
          "optim.batch=4",
          "optim.steps=" + std::to_string(steps),
          "optim.warmup_steps=5",
          "run.threads=1",
          "run.log_every=1",
          "run.val_samples=16",
          "run.checkpoint_every=5"};
}

std::vector<nlohmann::json> read_log(const std::string& dir, const std::string& kind) {
  std::vector<nlohmann::json> out;
  std::ifstream in(dir + "/log.jsonl");
  std::string line;
  while (std::getline(in, line))
    if (!line.empty()) {
      auto j = nlohmann::json::parse(line);
      if (j["kind"] == kind) out.push_back(j);
    }
  return out;
}

// One short simulated sequence in `data` (made here), trained and validated on, without
// augmentation: the loop's own learning, not generalisation, is under test.
std::vector<std::string> one_sequence_overrides(const std::string& data, int steps) {
  std::string out;
  EXPECT_EQ(run_command(spikems_binary() +
                            " simulate --preset tiny --sequences 1 --duration 0.2s --seed 5 "
                            "--threads 1 --no-progress --out " +
                            data,
                        &out),
            0)
      << out;
  auto ov = tiny_overrides(steps);
  const std::string one = "[{path=\"" + data + "/seq_0000.h5\"}]";
  ov.push_back("data.train=" + one);
  ov.push_back("data.val=" + one);
  for (const char* k :
       {"flip_x", "flip_y", "polarity_swap", "drop_max", "threshold_jitter", "noise_hz_max"})
    ov.push_back(std::string("sample.") + k + "=0.0");
  return ov;
}

std::string config_path();

// A run of the default config with `ov`, in `dir`, without a progress bar.
TrainResult train_quietly(const std::vector<std::string>& ov, const std::string& dir) {
  TrainRunOptions ro;
  ro.out_dir = dir;
  ro.progress = false;
  return run_training(load_train_config(config_path(), ov), ro);
}

// The mean loss of the train log lines [from, to).
double mean_loss(const std::vector<nlohmann::json>& train, size_t from, size_t to) {
  double sum = 0;
  for (size_t i = from; i < to; ++i) sum += train.at(i)["loss"].get<double>();
  return sum / double(to - from);
}

std::string config_path() {
  return test::source_dir() + "/configs/train/default.toml";
}

// `spikems eval`'s 20 ms windows over the first 0.2 s of `sequence` (what run.val_full_s = 0.2
// and run.val_full_window_ms = 20 validate on).
WindowSummary whole_sensor_eval(const std::string& model, const std::string& sequence) {
  EvalOptions eo;
  eo.model_path = model;
  eo.data = {sequence};
  eo.windows_us = {20000};
  eo.max_seconds = 0.2;
  return evaluate(eo).models.at(0).datasets.at(0).windows.at(0);
}

TEST(Trainer, LossFallsAndValidationBeatsTheUntrainedNetwork) {
  const std::string dir = scratch_dir() + "/run";
  // Scored on windows of its own training data: what this checks is that the whole loop
  // (data, loss, optimizer, validation, files) learns; generalisation is the default model's
  // job (docs/results.md). One short sequence, no augmentation, L_bce alone, a higher rate.
  const std::string data = scratch_dir() + "/data";
  auto ov = one_sequence_overrides(data, 100);
  for (const char* k : {"sample.centred_fraction=1.0", "optim.lr=0.003", "loss.kind=bce",
                        "loss.floor_weight=0.0", "loss.activity_weight=0.0", "run.val_every=100",
                        "run.val_full_s=0.2", "run.val_full_window_ms=20", "sample.warmup_ms=30"})
    ov.push_back(k);
  TrainResult r = train_quietly(ov, dir);
  EXPECT_EQ(r.steps, 100);
  auto train = read_log(dir, "train");
  ASSERT_EQ(train.size(), 100u);
  EXPECT_LT(mean_loss(train, 90, 100), 0.7 * mean_loss(train, 0, 10))
      << "mean loss of steps 1-10 vs 91-100";
  for (const auto& line : train) {  // one gradient norm per layer's weight, finite, some > 0
    ASSERT_EQ(line["grad_norms"].size(), 6u);
    double most = 0;
    for (const auto& g : line["grad_norms"]) {
      EXPECT_TRUE(std::isfinite(g.get<double>()) && g.get<double>() >= 0);
      most = std::max(most, g.get<double>());
    }
    EXPECT_GT(most, 0.0) << "step " << line["step"];
  }
  auto val = read_log(dir, "val");
  ASSERT_EQ(val.size(), 2u);  // before training (step 0) and at the end
  EXPECT_EQ(val[0]["step"], 0);
  EXPECT_GT(val[1]["iou"].get<double>(), val[0]["iou"].get<double>() + 8.0);
  // Whole-sensor validation is `spikems eval`'s number for the model of that step.
  const WindowSummary w = whole_sensor_eval(dir + "/model.safetensors", data + "/seq_0000.h5");
  ASSERT_GT(w.windows, 0u);
  EXPECT_NEAR(val[1]["full_iou"].get<double>(), w.iou_mean, 1e-9);
  EXPECT_EQ(val[1]["full_windows"].get<size_t>(), w.windows);
  // ... and its event counts: precision, the share of moving events, the share called moving.
  ASSERT_TRUE(w.has_events);
  const EventCounts& e = w.events;
  EXPECT_NEAR(val[1]["full_event_precision"].get<double>(), 100 * e.precision(), 1e-9);
  EXPECT_NEAR(val[1]["full_event_base_rate"].get<double>(),
              100.0 * double(e.tp + e.fn) / double(e.total()), 1e-9);
  EXPECT_NEAR(val[1]["full_moving"].get<double>(), 100 * e.moving_share(), 1e-9);
  EXPECT_GT(val[1]["full_event_base_rate"].get<double>(), 0.0);
  // ... and its size bands (`spikems eval`'s default edges), each as eval scores it.
  const auto& bands = val[1]["full_iou_bands"];
  ASSERT_EQ(bands.size(), w.bands.size());
  ASSERT_EQ(bands.size(), 3u);
  for (size_t b = 0; b < bands.size(); ++b) {
    EXPECT_EQ(bands[b]["share_min_pct"].get<double>(), w.bands[b].lo_pct);
    EXPECT_EQ(bands[b]["windows"].get<size_t>(), w.bands[b].windows);
    if (w.bands[b].windows > 0)
      EXPECT_NEAR(bands[b]["iou_mean"].get<double>(), w.bands[b].iou_mean, 1e-9);
    else
      EXPECT_TRUE(bands[b]["iou_mean"].is_null());
  }
  EXPECT_GT(val[1]["full_iou"].get<double>(), val[0]["full_iou"].get<double>() + 5.0);
  EXPECT_EQ(r.best_val_iou,
            std::max(val[0]["full_iou"].get<double>(), val[1]["full_iou"].get<double>()));
  // The model file every command reads, with its provenance.
  ModelSpec m = load_model(dir + "/model.safetensors");
  EXPECT_EQ(m.training["steps"], 100);
  EXPECT_EQ(m.layers.size(), 6u);
  EXPECT_EQ(m.layers[0].neuron.discretisation, Discretisation::IIR);
  // The pixel scale it learned: the training data's sensor (docs/runtime.md, "Pixel scale").
  const SensorSize sensor = read_recording(data + "/seq_0000.h5").events.sensor;
  EXPECT_EQ(m.train_width, sensor.width);
  EXPECT_EQ(m.train_height, sensor.height);
  EXPECT_TRUE(fs::exists(dir + "/best.safetensors"));
  EXPECT_TRUE(fs::exists(dir + "/curves.svg"));
}

// A dataset whose sequences come from two cameras ([sensor] sizes): whole-sensor training
// (sample.crop = 0) mixes the sizes within a batch (to_tensors pads them), learns, and the
// whole-sensor validation scores each sequence at its own size as `spikems eval` does.
TEST(Trainer, WholeSensorTrainingMixesSensorSizes) {
  const std::string scratch = scratch_dir();
  const std::string data = scratch + "/data", cfg = scratch + "/two-cameras.toml";
  std::string text;
  ASSERT_EQ(run_command(spikems_binary() + " simulate --preset tiny --print-config", &text), 0);
  const size_t at = text.find("[sensor]\n");
  ASSERT_NE(at, std::string::npos) << text;
  text.insert(at + 9, "sizes = [[64, 48], [48, 40]]\n");
  {
    std::ofstream f(cfg);
    f << text;
  }
  std::string out;
  ASSERT_EQ(run_command(spikems_binary() + " simulate --config " + cfg +
                            " --sequences 4 --duration 0.2s --seed 6 --threads 1 --no-progress "
                            "--out " +
                            data,
                        &out),
            0)
      << out;
  std::set<int> widths;
  for (int i = 0; i < 4; ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "/seq_%04d.h5", i);
    widths.insert(read_recording(data + name).events.sensor.width);
  }
  ASSERT_EQ(widths, (std::set<int>{48, 64})) << "seed 6 no longer draws both sizes";
  auto ov = tiny_overrides(60);
  for (const char* k :
       {"flip_x", "flip_y", "polarity_swap", "drop_max", "threshold_jitter", "noise_hz_max"})
    ov.push_back(std::string("sample.") + k + "=0.0");
  const std::string all = "[{path=\"" + data + "\", split=\"all\"}]";
  for (const std::string& k : {"data.train=" + all, "data.val=" + all, std::string("sample.crop=0"),
                               std::string("model.type=ann2d"), std::string("loss.kind=bce"),
                               std::string("optim.lr=0.003"), std::string("sample.warmup_ms=0"),
                               std::string("run.val_every=60"), std::string("run.val_full_s=0.2"),
                               std::string("run.val_full_window_ms=20")})
    ov.push_back(k);
  const std::string dir = scratch + "/run";
  ASSERT_EQ(train_quietly(ov, dir).steps, 60);
  const auto train = read_log(dir, "train");
  ASSERT_EQ(train.size(), 60u);
  for (const auto& l : train) ASSERT_TRUE(std::isfinite(l["loss"].get<double>()));
  EXPECT_LT(mean_loss(train, 40, 60), mean_loss(train, 0, 20));
  const auto val = read_log(dir, "val");
  ASSERT_EQ(val.size(), 2u);
  EvalOptions eo;
  eo.model_path = dir + "/model.safetensors";
  eo.data = {data};
  eo.split = "all";
  eo.windows_us = {20000};
  eo.max_seconds = 0.2;
  const WindowSummary w = evaluate(eo).models.at(0).datasets.at(0).windows.at(0);
  ASSERT_GT(w.windows, 0u);
  EXPECT_NEAR(val[1]["full_iou"].get<double>(), w.iou_mean, 1e-9);
  EXPECT_GT(val[1]["full_iou"].get<double>(), val[0]["full_iou"].get<double>() + 5.0);
  EXPECT_GT(val[1]["iou"].get<double>(), val[0]["iou"].get<double>() + 5.0);
  // Two sensor sizes in the training data: no single pixel scale is recorded.
  EXPECT_EQ(load_model(dir + "/model.safetensors").train_width, 0);
}

// data.val_static: at each validation the share of the static scenes' events the model calls
// moving, which is `spikems eval --static-scene`'s number for the model of that step (here the
// training sequence itself, read as if every event were background).
TEST(Trainer, StaticValidationIsEvalsFalsePositiveShare) {
  const std::string dir = scratch_dir() + "/run";
  const std::string data = scratch_dir() + "/data";
  auto ov = one_sequence_overrides(data, 6);
  for (const char* k : {"run.val_every=3", "run.val_full_s=0.2", "run.val_full_window_ms=20"})
    ov.push_back(k);
  ov.push_back("data.val_static=[{path=\"" + data + "/seq_0000.h5\"}]");
  EXPECT_EQ(train_quietly(ov, dir).steps, 6);
  auto val = read_log(dir, "val");
  ASSERT_EQ(val.size(), 3u);  // steps 0, 3, 6
  for (const auto& v : val) ASSERT_TRUE(v.contains("static_moving")) << v.dump();
  EvalOptions eo;
  eo.model_path = dir + "/model.safetensors";
  eo.data = {data + "/seq_0000.h5"};
  eo.windows_us = {20000};
  eo.max_seconds = 0.2;
  eo.static_scene = true;
  const WindowSummary w = evaluate(eo).models.at(0).datasets.at(0).windows.at(0);
  ASSERT_TRUE(w.has_events);
  EXPECT_EQ(w.events.tp + w.events.fn, 0u);  // static: no event is truly moving
  EXPECT_NEAR(val[2]["static_moving"].get<double>(), 100 * w.events.moving_share(), 1e-9);
  EXPECT_EQ(val[2]["static_events"].get<uint64_t>(), w.events.total());
  EXPECT_GT(w.events.total(), 1000u);
  EXPECT_GT(val[2]["static_moving"].get<double>(), 0.0);  // some calls: a comparison, not 0 = 0
  // The same data scored as labelled: its moving share equals the static share's calls.
  EXPECT_NEAR(val[2]["full_moving"].get<double>(), val[2]["static_moving"].get<double>(), 1e-9);
}

// model.readout = "potential": the loss scores the output layer's potential; the run learns
// as the spiking readout does, and the model file's output layer has no refractory (so the
// runtime's labels are the potential's threshold crossings; RuntimeVsTorch checks those).
TEST(Trainer, PotentialReadoutLearnsAndSavesAnOutputWithoutRefractory) {
  const std::string dir = scratch_dir() + "/run";
  const std::string data = scratch_dir() + "/data";
  auto ov = one_sequence_overrides(data, 60);
  for (const char* k :
       {"sample.centred_fraction=1.0", "optim.lr=0.003", "loss.kind=bce", "loss.floor_weight=0.0",
        "loss.activity_weight=0.0", "run.val_every=60", "run.val_full_s=0.2",
        "run.val_full_window_ms=20", "sample.warmup_ms=30", "model.readout=\"potential\""})
    ov.push_back(k);
  EXPECT_EQ(train_quietly(ov, dir).steps, 60);
  auto train = read_log(dir, "train");
  ASSERT_EQ(train.size(), 60u);
  EXPECT_LT(mean_loss(train, 50, 60), 0.7 * mean_loss(train, 0, 10))
      << "mean loss of steps 1-10 vs 51-60";
  auto val = read_log(dir, "val");
  ASSERT_EQ(val.size(), 2u);
  EXPECT_GT(val[1]["full_iou"].get<double>(), val[0]["full_iou"].get<double>() + 5.0);
  const ModelSpec m = load_model(dir + "/model.safetensors");
  EXPECT_EQ(m.layers.back().neuron.scale_ref, 0.f);
  EXPECT_EQ(m.layers.front().neuron.scale_ref, NeuronParams{}.scale_ref);
  // L_spike compares spike trains: refused with the potential readout, naming the key.
  auto bad = ov;
  bad.push_back("loss.kind=both");
  expect_refused<Error>([&] { load_train_config(config_path(), bad); }, {"loss.kind"},
                        "loss.kind = both with the potential readout");
}

// model.output_gate_ms: the run's model carries the gate (in steps) and validates with it; the
// loss scores the potential readout, which the gate does not touch, so the losses equal those of
// the same run without a gate. Bad values name the key.
TEST(Trainer, OutputGateKeyGatesTheSavedModel) {
  const std::string root = scratch_dir();  // once: each call empties the folder
  const std::string data = root + "/data";
  auto ov = one_sequence_overrides(data, 6);
  for (const char* k :
       {"sample.step_ms=1.0", "run.val_every=6", "run.val_full_s=0.1", "run.val_full_window_ms=20",
        "sample.warmup_ms=10", "model.readout=\"potential\"", "loss.kind=bce",
        "loss.floor_weight=0.0", "loss.activity_weight=0.0"})
    ov.push_back(k);
  auto gated = ov;
  gated.push_back("model.output_gate_ms=3");
  const std::string a = root + "/plain", b = root + "/gated";
  EXPECT_EQ(train_quietly(ov, a).steps, 6);
  EXPECT_EQ(train_quietly(gated, b).steps, 6);
  EXPECT_EQ(load_model(a + "/model.safetensors").output_gate_steps, 0);
  EXPECT_EQ(load_model(b + "/model.safetensors").output_gate_steps, 3);
  const auto la = read_log(a, "train"), lb = read_log(b, "train");
  ASSERT_EQ(la.size(), lb.size());
  for (size_t i = 0; i < la.size(); ++i)
    EXPECT_DOUBLE_EQ(la[i]["loss"].get<double>(), lb[i]["loss"].get<double>()) << "step " << i;
  ASSERT_EQ(read_log(b, "val").size(), 2u);  // before the first step and after the last
  for (const char* bad : {"model.output_gate_ms=-1", "model.output_gate_ms=2.5"}) {
    auto o = ov;
    o.push_back(bad);
    expect_refused<Error>([&] { load_train_config(config_path(), o); }, {"model.output_gate_ms"},
                          bad);
  }
}

// model.init from a file trained at another step: refused without model.init_time_constants
// (setting the step alone would silently change every neuron's per-step decay); "steps" scales
// the file's time constants by the ratio of the steps, "ms" keeps them.
TEST(Trainer, InitAtAnotherTimeStepNeedsTheKey) {
  const std::string scratch = scratch_dir();
  auto ov = tiny_overrides(1);
  ov.push_back("sample.step_ms=1.0");
  ov.push_back("run.val_full_s=0.0");
  ASSERT_EQ(train_quietly(ov, scratch + "/w0").steps, 1);
  const ModelSpec w0 = load_model(scratch + "/w0/model.safetensors");
  ASSERT_DOUBLE_EQ(w0.time_step_ms, 1);
  auto at2 = ov;
  at2.push_back("model.init=\"" + scratch + "/w0/model.safetensors\"");
  at2.push_back("sample.step_ms=2.0");
  expect_refused<Error>([&] { train_quietly(at2, scratch + "/refused"); },
                        {"model.init", "trained with 1 ms steps and sample.step_ms is 2",
                         "model.init_time_constants"},
                        "a 1 ms model at 2 ms steps without the key");
  for (const char* keep : {"steps", "ms"}) {
    auto o = at2;
    o.push_back(std::string("model.init_time_constants=\"") + keep + "\"");
    const std::string dir = scratch + "/" + keep;
    ASSERT_EQ(train_quietly(o, dir).steps, 1) << keep;
    const ModelSpec m = load_model(dir + "/model.safetensors");
    EXPECT_DOUBLE_EQ(m.time_step_ms, 2);
    const float f = std::string(keep) == "steps" ? 2.f : 1.f;
    ASSERT_EQ(m.layers.size(), w0.layers.size());
    for (size_t k = 0; k < m.layers.size(); ++k) {
      EXPECT_FLOAT_EQ(m.layers[k].neuron.tau_s, f * w0.layers[k].neuron.tau_s) << keep << k;
      EXPECT_FLOAT_EQ(m.layers[k].neuron.tau_r, f * w0.layers[k].neuron.tau_r) << keep << k;
    }
  }
}

// model.srm_onset: a model trained with it carries it (the runtime then answers in the input's
// own step); a model.init file is switched; a bad value or FIR neurons are refused.
TEST(Trainer, SrmOnsetIsSetOnEveryLayer) {
  const std::string scratch = scratch_dir();
  auto ov = tiny_overrides(1);
  ov.push_back("run.val_full_s=0.0");
  auto same = ov;
  same.push_back("model.srm_onset=\"same_step\"");
  same.push_back("model.tau_r=[2, 4, 8]");  // per level, the decoder mirrored
  ASSERT_EQ(train_quietly(same, scratch + "/same").steps, 1);
  const ModelSpec m = load_model(scratch + "/same/model.safetensors");
  for (const auto& l : m.layers) EXPECT_EQ(l.neuron.srm_onset, SrmOnset::SameStep);
  ASSERT_EQ(m.layers.size(), 6u);
  const float tau_r[] = {2, 4, 8, 8, 4, 2};
  for (size_t k = 0; k < 6; ++k) EXPECT_EQ(m.layers[k].neuron.tau_r, tau_r[k]) << k;
  auto back = ov;
  back.push_back("model.init=\"" + scratch + "/same/model.safetensors\"");
  back.push_back("model.srm_onset=\"next_step\"");
  ASSERT_EQ(train_quietly(back, scratch + "/back").steps, 1);
  for (const auto& l : load_model(scratch + "/back/model.safetensors").layers)
    EXPECT_EQ(l.neuron.srm_onset, SrmOnset::NextStep);
  auto bad = ov;
  bad.push_back("model.srm_onset=\"soon\"");
  expect_refused<Error>([&] { train_quietly(bad, scratch + "/bad"); },
                        {"model.srm_onset", "next_step", "same_step"}, "an unknown onset");
  auto fir = same;
  fir.push_back("model.neurons=\"fir\"");
  expect_refused<Error>([&] { train_quietly(fir, scratch + "/fir"); }, {"model.srm_onset", "iir"},
                        "same_step with FIR neurons");
}

// Runs `spikems train` as a child process and kills it with SIGKILL once its first checkpoint
// is on disk.
void train_and_kill(const std::vector<std::string>& args, const std::string& dir) {
  pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    std::vector<char*> argv;
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    int devnull = open("/dev/null", O_WRONLY);
    dup2(devnull, 1);
    dup2(devnull, 2);
    execv(argv[0], argv.data());
    _exit(127);
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::minutes(5);
  while (!fs::exists(dir + "/checkpoint.pt") && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  kill(pid, SIGKILL);
  int status = 0;
  waitpid(pid, &status, 0);
  ASSERT_TRUE(fs::exists(dir + "/checkpoint.pt"));
}

TEST(Trainer, ResumeAfterKillContinuesWithTheSameLosses) {
  const std::string base = scratch_dir();
  const std::string straight = base + "/straight", killed = base + "/killed";
  std::vector<std::string> args = {spikems_binary(), "train", "--config", config_path(), "-q"};
  for (const auto& o : tiny_overrides(24)) {
    args.push_back("--set");
    args.push_back(o);
  }
  args.push_back("--set");
  args.push_back("run.val_every=100");
  auto with_out = [&](const std::string& d) {
    auto a = args;
    a.push_back("--out");
    a.push_back(d);
    return a;
  };
  std::string cmd, out;
  for (const auto& a : with_out(straight)) cmd += "'" + a + "' ";
  ASSERT_EQ(run_command(cmd, &out), 0) << out;
  train_and_kill(with_out(killed), killed);
  ASSERT_EQ(run_command(spikems_binary() + " train -q --resume " + killed, &out), 0) << out;
  auto a = read_log(straight, "train"), b = read_log(killed, "train");
  ASSERT_EQ(a.size(), 24u);
  ASSERT_EQ(b.size(), 24u) << "a resumed log has each step once";
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i]["step"], b[i]["step"]);
    EXPECT_DOUBLE_EQ(a[i]["loss"].get<double>(), b[i]["loss"].get<double>()) << "step " << i + 1;
  }
  auto runs = read_log(killed, "run");
  bool resumed = false;
  for (const auto& r : runs) resumed |= r["event"] == "resume";
  EXPECT_TRUE(resumed);
  // The resumed run carries its time over: the log's wall time never falls across the resume
  // (a ratio of the two runs' times would depend on the machine's load), and the file's time
  // is the log's last.
  ModelSpec sa = load_model(straight + "/model.safetensors"),
            sb = load_model(killed + "/model.safetensors");
  const double wa = sa.training["wall_seconds"].get<double>(),
               wb = sb.training["wall_seconds"].get<double>();
  for (size_t i = 1; i < b.size(); ++i)
    EXPECT_GE(b[i]["wall_s"].get<double>(), b[i - 1]["wall_s"].get<double>()) << "step " << i + 1;
  EXPECT_GE(wb, b.back()["wall_s"].get<double>() - 1e-6);
  EXPECT_LT(wb, 5.0 * wa + 30);
  for (const auto& j : read_log(killed, "train")) {
    EXPECT_LT(j["wall_s"].get<double>(), 1e5);
    EXPECT_LT(j["samples_per_s"].get<double>(), 1e5);
  }
  // Same weights at the end.
  ModelSpec ma = load_model(straight + "/model.safetensors"),
            mb = load_model(killed + "/model.safetensors");
  for (size_t k = 0; k < ma.layers.size(); ++k) EXPECT_EQ(ma.layers[k].weight, mb.layers[k].weight);
}

// A time limit stops the run after the step that passes it, with a checkpoint and a
// "time_limit" run line; --resume then finishes the run with every step logged once.
TEST(Trainer, TimeLimitStopsWithACheckpointAndResumeFinishes) {
  const std::string dir = scratch_dir() + "/run";
  auto ov = tiny_overrides(12);
  ov.push_back("run.val_every=100");
  TrainRunOptions ro;
  ro.out_dir = dir;
  ro.progress = false;
  ro.time_limit_s = 1e-6;  // passed by the end of the first step: exactly one step runs
  TrainResult r = run_training(load_train_config(config_path(), ov), ro);
  EXPECT_TRUE(r.time_limit_reached);
  EXPECT_EQ(r.steps, 1);
  EXPECT_TRUE(fs::exists(dir + "/checkpoint.pt"));
  auto runs = read_log(dir, "run");
  ASSERT_FALSE(runs.empty());
  EXPECT_EQ(runs.back()["event"], "time_limit");
  EXPECT_EQ(runs.back()["step"], 1);

  // The log gzipped meanwhile (as the repository keeps long logs): the resume unpacks it and
  // continues the whole log.
  {
    std::ifstream f(dir + "/log.jsonl");
    std::stringstream text;
    text << f.rdbuf();
    gzFile g = gzopen((dir + "/log.jsonl.gz").c_str(), "wb");
    ASSERT_TRUE(g);
    ASSERT_EQ(gzwrite(g, text.str().data(), unsigned(text.str().size())), int(text.str().size()));
    gzclose(g);
    fs::remove(dir + "/log.jsonl");
  }
  ro.resume = true;
  ro.time_limit_s = 0;
  r = run_training(load_run_config(dir, {}), ro);
  EXPECT_FALSE(r.time_limit_reached);
  EXPECT_EQ(r.steps, 12);
  auto train = read_log(dir, "train");
  ASSERT_EQ(train.size(), 12u);
  for (size_t i = 0; i < train.size(); ++i) EXPECT_EQ(train[i]["step"], int(i + 1));
  EXPECT_EQ(read_log(dir, "run").front()["event"], "start");
  EXPECT_EQ(read_log(dir, "run").back()["event"], "done");
  EXPECT_FALSE(fs::exists(dir + "/log.jsonl.gz"));

  // The command line refuses a duration that is not one, naming the flag.
  std::string out;
  EXPECT_NE(run_command(spikems_binary() + " train -q --resume " + dir + " --time-limit 0s", &out),
            0);
  EXPECT_NE(out.find("--time-limit"), std::string::npos) << out;
  EXPECT_NE(
      run_command(spikems_binary() + " train -q --resume " + dir + " --time-limit soon", &out), 0);
  EXPECT_NE(out.find("soon"), std::string::npos) << out;
}

TEST(Trainer, BadConfigsNameTheKey) {
  auto msg = [](const std::vector<std::string>& ov) {
    try {
      load_train_config(config_path(), ov);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(msg({"optim.lrate=0.1"}).find("optim.lrate: unknown key"), std::string::npos);
  EXPECT_NE(msg({"bogus.x=1"}).find("bogus.x: unknown key"), std::string::npos);
  EXPECT_NE(msg({"optim.batch=\"eight\""}).find("optim.batch: wrong type: expected an integer"),
            std::string::npos);
  EXPECT_NE(msg({"optim.lr=-1"}).find("optim.lr: must be positive"), std::string::npos);
  EXPECT_NE(msg({"loss.kind=hinge"}).find("loss.kind: \"hinge\" is not one of bce, spike, both"),
            std::string::npos);
  EXPECT_NE(msg({"model.init_rates=[0.1]"}).find("model.init_rates"), std::string::npos);
  EXPECT_NE(msg({"sample.speed_max=0.5"}).find("sample.speed_max: must be in [1, 8]"),
            std::string::npos);
  EXPECT_NE(msg({"loss.rate_ceilings=[0.1]"})
                .find("loss.rate_ceilings: needs one ceiling per hidden layer (5)"),
            std::string::npos);
  EXPECT_NE(msg({"model.readout=\"potential\"", "model.delays=true"})
                .find("model.readout: the potential readout scores the output layer's undelayed"),
            std::string::npos);
  EXPECT_NE(msg({"model.readout=\"membrane\""}).find("model.readout: \"membrane\" is not one of"),
            std::string::npos);
  EXPECT_NE(msg({"loss.rate_floors=[0.1, 0.1]"})
                .find("loss.rate_floors: needs one floor per hidden layer (5)"),
            std::string::npos);
  EXPECT_NE(msg({"loss.rate_ceilings=[0.1, 0.1, 0.1, 0.1, 0.1]",
                 "loss.rate_floors=[0.0, 0.2, 0.0, 0.0, 0.0]"})
                .find("loss.rate_floors: each must lie in [0, 1) and below its layer's ceiling"),
            std::string::npos);
  EXPECT_NE(msg({"loss.rate_ceilings=[0.1, 0.1, 1.5, 0.1, 0.1]"})
                .find("loss.rate_ceilings: each must lie above loss.rate_floor"),
            std::string::npos);
  EXPECT_NE(msg({"loss.teacher_weight=-1.0"}).find("loss.teacher_weight: must not be negative"),
            std::string::npos);
  EXPECT_NE(msg({"data.val=[]", "data.val_static=[{path=\"" + tiny_data() + "\"}]"})
                .find("data.val_static: needs data.val too"),
            std::string::npos);
  // The static scenes are scored in windows of run.val_full_window_ms even with val_full_s = 0.
  EXPECT_NE(msg({"run.val_full_s=0.0", "sample.step_ms=2", "run.val_full_window_ms=5",
                 "data.val_static=[{path=\"" + tiny_data() + "\"}]"})
                .find("run.val_full_window_ms: must be a multiple of sample.step_ms"),
            std::string::npos);
  EXPECT_NE(msg({"loss.teacher_static=\"never\""})
                .find("loss.teacher_static: \"never\" is not one of teacher, skip, labels"),
            std::string::npos);
  EXPECT_NE(
      msg({"loss.teacher_static=\"skip\""})
          .find("loss.teacher_static: changes the distillation: needs loss.teacher_weight > 0"),
      std::string::npos);
  EXPECT_NE(msg({"loss.offevent_weight=-1.0"}).find("loss.offevent_weight: must not be negative"),
            std::string::npos);
  EXPECT_NE(msg({"loss.offevent_weight=1.0", "loss.projection=\"exponential\""})
                .find("loss.offevent_weight: needs loss.projection = \"sigmoid\""),
            std::string::npos);
  EXPECT_NE(msg({"loss.attention_weight=1.0"}).find("loss.teacher: needs an ANN-2D model file"),
            std::string::npos);
  EXPECT_NE(msg({"loss.attention_weight=-1.0"}).find("loss.attention_weight: must not be negative"),
            std::string::npos);
  EXPECT_NE(msg({"loss.feature_weight=1.0"}).find("loss.teacher: needs an ANN-2D model file"),
            std::string::npos);
  EXPECT_NE(msg({"model.init_ann=\"a.safetensors\"", "model.init=\"b.safetensors\""})
                .find("model.init_ann: starts a spiking network's data initialisation"),
            std::string::npos);
  EXPECT_NE(msg({"model.init_time_constants=\"seconds\"", "model.init=\"b.safetensors\""})
                .find("model.init_time_constants: \"seconds\" is not one of steps, ms"),
            std::string::npos);
  EXPECT_NE(msg({"model.init_time_constants=\"steps\""})
                .find("model.init_time_constants: applies to a model.init file"),
            std::string::npos);
  EXPECT_NE(msg({"loss.feature_weight=-1.0"}).find("loss.feature_weight: must not be negative"),
            std::string::npos);
  EXPECT_NE(msg({"loss.teacher_weight=1.0"}).find("loss.teacher: needs an ANN-2D model file"),
            std::string::npos);
  EXPECT_NE(msg({"loss.teacher_weight=1.0", "loss.teacher=\"t.safetensors\"", "model.type=ann2d",
                 "loss.kind=bce"})
                .find("loss.teacher_weight: distils into the spiking network"),
            std::string::npos);
  EXPECT_NE(msg({"model.channels=[16, 1.5]"}).find("model.channels: each level's channels"),
            std::string::npos);
  EXPECT_NE(msg({"model.channels=[]"}).find("model.channels: needs 1 to 6"), std::string::npos);
  EXPECT_NE(msg({"model.channels=[8, 16]", "model.init_rates=[0.1, 0.1, 0.1, 0.1, 0.1, 0.1]"})
                .find("model.init_rates: needs one rate per layer (4)"),
            std::string::npos);
  EXPECT_NE(msg({"model.tau_s=[1, 1]"}).find("model.tau_s: needs one time constant per level"),
            std::string::npos);
  EXPECT_NE(msg({"model.tau_s=[1, 0, 1]"}).find("model.tau_s: each must lie in 0.1..100 ms"),
            std::string::npos);
  EXPECT_NE(msg({"model.tau_r=[1, 1]"}).find("model.tau_r: needs one time constant per level"),
            std::string::npos);
  EXPECT_NE(msg({"model.tau_r=[1, 200, 1]"}).find("model.tau_r: each must lie in 0.1..100 ms"),
            std::string::npos);
  EXPECT_NE(msg({"model.tau_rho=-1.0"}).find("model.tau_rho: must lie in 0.01..100"),
            std::string::npos);
  EXPECT_EQ(load_train_config(config_path(), {"model.tau_rho=3.0"}).tau_rho, 3.0);
  EXPECT_EQ(load_train_config(config_path(), {"model.tau_s=[1, 2, 3]"}).tau_s,
            (std::vector<double>{1, 2, 3}));
  {  // Other widths: one default firing target per layer, 0.02 for the output.
    TrainConfig w = load_train_config(config_path(), {"model.channels=[8, 16]"});
    EXPECT_EQ(w.channels, (std::vector<int>{8, 16}));
    EXPECT_EQ(w.init_rates, (std::vector<double>{0.03, 0.03, 0.03, 0.02}));
  }
  EXPECT_NE(msg({"loss.output_floor=1.5"}).find("loss.output_floor: must lie in [0, 1)"),
            std::string::npos);
  EXPECT_NE(
      msg({"loss.rate_ceiling=0.001"}).find("loss.rate_ceiling: must be above loss.rate_floor"),
      std::string::npos);
  EXPECT_NE(msg({"loss.iou_weight=-1.0"}).find("loss.iou_weight: must not be negative"),
            std::string::npos);
  EXPECT_NE(msg({"run.val_full_s=-1.0"}).find("run.val_full_s"), std::string::npos);
  EXPECT_NE(msg({"run.val_full_s=0.5", "run.val_full_window_ms=1.5"})
                .find("run.val_full_window_ms: must be a multiple of sample.step_ms"),
            std::string::npos);
  EXPECT_NE(msg({"data.train=[{path=\"x\", wieght=2}]"}).find("entry key \"wieght\""),
            std::string::npos);
  EXPECT_NE(msg({"optim.lr"}).find("expected section.key=value"), std::string::npos);
  // A valid override is taken, a bare word as a string.
  TrainConfig c = load_train_config(config_path(), {"model.neurons=fir", "optim.lr=0.01"});
  EXPECT_EQ(c.neurons, "fir");
  EXPECT_DOUBLE_EQ(c.lr, 0.01);
  EXPECT_DOUBLE_EQ(c.source["optim"]["lr"].get<double>(), 0.01);
  // A run's config.json starts a new run with the same configuration.
  {
    const std::string d = scratch_dir();
    std::ofstream(d + "/config.json") << c.source.dump(2);
    TrainConfig again = load_train_config(d + "/config.json", {"optim.batch=3"});
    EXPECT_EQ(again.neurons, "fir");
    EXPECT_DOUBLE_EQ(again.lr, 0.01);
    EXPECT_EQ(again.batch, 3);
    std::ofstream(d + "/bad.json") << "{\"optim\": {\"lr\": \"fast\"}}";
    EXPECT_THROW(load_train_config(d + "/bad.json", {}), Error);
  }
  // TOML syntax errors name the line; a missing file its path. Through the CLI: exit 1.
  const std::string dir = scratch_dir();
  { std::ofstream(dir + "/bad.toml") << "[optim]\nlr = = 3\n"; }
  std::string out;
  EXPECT_EQ(
      run_command(
          spikems_binary() + " train --config " + dir + "/bad.toml --out " + dir + "/r 2>&1", &out),
      1);
  EXPECT_NE(out.find("bad.toml: at line 2"), std::string::npos) << out;
  EXPECT_EQ(run_command(spikems_binary() + " train --config " + config_path() + " --out " + dir +
                            "/r --set data.train='[\"" + dir + "/none\"]' 2>&1",
                        &out),
            1);
  EXPECT_NE(out.find("none: no such file or folder"), std::string::npos) << out;
  EXPECT_EQ(run_command(spikems_binary() + " train --resume " + dir + " 2>&1", &out), 1);
  EXPECT_NE(out.find("a `spikems train` run folder?"), std::string::npos) << out;
}

// Every recipe the repository ships parses, and the geometry it asks for is buildable. The
// hybrid recipe takes its ANN-2D teacher on the command line: without it, it is refused.
TEST(Trainer, ShippedConfigsParse) {
  int n = 0;
  for (const auto& e : fs::directory_iterator(test::source_dir() + "/configs/train")) {
    if (e.path().extension() != ".toml") continue;
    SCOPED_TRACE(e.path().string());
    std::vector<std::string> ov;
    if (e.path().filename() == "hybrid.toml") {
      expect_refused<Error>([&] { load_train_config(e.path().string(), {}); }, {"loss.teacher"},
                            "the hybrid recipe without a teacher");
      ov = {"model.init_ann=\"teacher.safetensors\"", "loss.teacher=\"teacher.safetensors\""};
    }
    TrainConfig c = load_train_config(e.path().string(), ov);
    EXPECT_EQ(c.init_rates.size(), 2 * c.channels.size());
    EXPECT_NO_THROW(spikems_architecture(c.padded, Discretisation::IIR, c.channels));
    ++n;
  }
  EXPECT_GE(n, 3);  // default, ann2d, deep
}

TEST(Trainer, Ann2dBaselineLearnsAndEvalScoresItsFile) {
  // The ANN-2D baseline through the same loop, set up as the SNN's test above (one sequence,
  // no augmentation): its loss falls, its IoU rises, and the whole-sensor validation is
  // `spikems eval`'s number for its model file.
  const std::string dir = scratch_dir() + "/ann";
  const std::string data = scratch_dir() + "/data";
  const auto base = one_sequence_overrides(data, 100);
  auto ov = base;
  for (const char* k : {"model.type=ann2d", "sample.warmup_ms=0", "sample.centred_fraction=1.0",
                        "loss.kind=bce", "loss.iou_weight=1.0", "optim.lr=0.003",
                        "run.val_every=100", "run.val_full_s=0.2", "run.val_full_window_ms=20"})
    ov.push_back(k);
  EXPECT_EQ(train_quietly(ov, dir).steps, 100);
  auto train = read_log(dir, "train");
  ASSERT_EQ(train.size(), 100u);
  EXPECT_LT(mean_loss(train, 90, 100), 0.7 * mean_loss(train, 0, 10))
      << "mean loss of steps 1-10 vs 91-100";
  auto val = read_log(dir, "val");
  ASSERT_EQ(val.size(), 2u);
  EXPECT_GT(val[1]["iou"].get<double>(), val[0]["iou"].get<double>() + 10.0);
  EXPECT_GT(val[1]["full_iou"].get<double>(), val[0]["full_iou"].get<double>() + 10.0);
  const ModelSpec m = load_model(dir + "/model.safetensors");
  EXPECT_EQ(m.type, ModelType::ANN2D);
  const WindowSummary w = whole_sensor_eval(dir + "/model.safetensors", data + "/seq_0000.h5");
  ASSERT_GT(w.windows, 0u);
  EXPECT_NEAR(val[1]["full_iou"].get<double>(), w.iou_mean, 1e-9);
  // ann2d has no spike trains: L_spike is refused.
  EXPECT_THROW(load_train_config(config_path(), {"model.type=ann2d", "loss.kind=both"}), Error);

  // The trained ANN as the SNN's teacher (loss.teacher): every other term off, the SNN's loss
  // is the distillation alone, logged as "distill", and it falls.
  // (Beside the ANN's folder: scratch_dir() would empty the test's folder, data included.)
  const std::string student = (std::filesystem::path(dir).parent_path() / "student").string();
  auto sv = base;
  for (const std::string k :
       {"loss.kind=spike", "loss.lambda=0.0", "loss.iou_weight=0.0", "loss.activity_weight=0.0",
        "loss.floor_weight=0.0", "loss.teacher_weight=1.0", "optim.lr=0.003"})
    sv.push_back(k);
  sv.push_back("loss.teacher=" + dir + "/model.safetensors");
  EXPECT_EQ(train_quietly(sv, student).steps, 100);
  const auto st = read_log(student, "train");
  ASSERT_EQ(st.size(), 100u);
  double first = 0, last = 0;
  for (size_t i = 0; i < 10; ++i) {
    first += st[i]["distill"].get<double>() / 10;
    last += st[90 + i]["distill"].get<double>() / 10;
  }
  for (const auto& line : st) {
    EXPECT_NEAR(line["loss"].get<double>(), line["distill"].get<double>(), 1e-5);
    // The teacher's own entropy: in [0, ln 2], and no student's cross-entropy is below it
    // (Gibbs' inequality, pixel by pixel, so for the mean too).
    const double floor = line["distill_floor"].get<double>();
    EXPECT_GE(floor, 0.0);
    EXPECT_LE(floor, std::log(2.0) + 1e-9);
    EXPECT_GE(line["distill"].get<double>(), floor - 1e-6) << "step " << line["step"];
    // The best constant student's score: the entropy of the mean is at least the mean entropy
    // (concavity), and at most ln 2.
    const double constant = line["distill_const"].get<double>();
    EXPECT_GE(constant, floor - 1e-9) << "step " << line["step"];
    EXPECT_LE(constant, std::log(2.0) + 1e-9);
  }
  EXPECT_GT(first, 0.0);
  EXPECT_LT(last, 0.9 * first) << "distillation loss of steps 1-10 vs 91-100";
  // Attention or feature transfer alone (the distillation off): the loss is the logged term,
  // a mean of squared distances of unit vectors (in (0, 2]); the other term is not logged.
  auto transfer_only = [&](const std::string& key, const std::string& other,
                           const std::string& out) {
    auto v = sv;
    for (const std::string k : {"loss.teacher_weight=0.0", "optim.steps=5"}) v.push_back(k);
    v.push_back("loss." + key + "_weight=1.0");
    EXPECT_EQ(train_quietly(v, out).steps, 5);
    for (const auto& line : read_log(out, "train")) {
      const double a = line[key].get<double>();
      EXPECT_GT(a, 0.0);
      EXPECT_LE(a, 2.0);
      EXPECT_NEAR(line["loss"].get<double>(), a, 1e-5);
      EXPECT_FALSE(line.contains(other));
    }
    return v;
  };
  const auto av = transfer_only("attention", "feature", student + "-att");
  // A teacher of another depth cannot be paired layer by layer: refused, naming the key.
  auto deeper = av;
  deeper.push_back("model.channels=[4, 8]");
  deeper.push_back("model.init_rates=[0.1, 0.1, 0.1, 0.1]");
  expect_refused([&] { train_quietly(deeper, student + "-att2"); }, {"loss.attention_weight"},
                 "a teacher of another depth for attention transfer");
  const auto fv = transfer_only("feature", "attention", student + "-feat");
  // Started from the teacher's own weights (model.init_ann), the hidden layers begin nearer the
  // teacher's activity than from random weights.
  auto fa = fv;
  fa.push_back("model.init_ann=" + dir + "/model.safetensors");
  EXPECT_EQ(train_quietly(fa, student + "-feat-ann").steps, 5);
  const double f_random = read_log(student + "-feat", "train").at(0)["feature"].get<double>();
  const double f_ann = read_log(student + "-feat-ann", "train").at(0)["feature"].get<double>();
  EXPECT_LT(f_ann, 0.8 * f_random) << "feature term at step 1 (measured: 0.54 against 1.36)";
  // A missing ANN file is refused before any data is read, naming the key.
  auto missing = fv;
  missing.push_back("model.init_ann=" + dir + "/no-such.safetensors");
  expect_refused([&] { train_quietly(missing, student + "-feat-missing"); },
                 {"model.init_ann", "no-such.safetensors"}, "a missing model.init_ann file");
  // The same depth with other channels pairs layers but not channels: refused, naming the key.
  auto narrower = fv;
  narrower.push_back("model.channels=[16, 32, 32]");
  expect_refused([&] { train_quietly(narrower, student + "-feat2"); }, {"loss.feature_weight"},
                 "a teacher with other channels for feature transfer");
  // A teacher that is not an ANN-2D (the student's own file) is refused, naming the key.
  auto bad = sv;
  bad.push_back("loss.teacher=" + student + "/model.safetensors");
  expect_refused([&] { train_quietly(bad, student + "2"); }, {"loss.teacher"}, "an SNN teacher");
  // Nor one whose step is not a whole multiple of the run's (its event frame cannot be made
  // from the run's bins): finer, or 1 ms against 0.4 ms.
  for (const char* step : {"2", "0.4"}) {
    auto other_step = sv;
    other_step.push_back(std::string("sample.step_ms=") + step);
    expect_refused([&] { train_quietly(other_step, student + "3"); },
                   {std::string("trained with 1 ms steps, this run's sample.step_ms is ") + step},
                   std::string("a teacher of 1 ms steps for ") + step + " ms steps");
  }
  // A teacher of coarser steps is re-binned: the same ANN teaches a student at 0.5 ms steps
  // (its frame merges the student's steps in pairs) and the distillation still falls.
  auto finer = sv;
  finer.push_back("sample.step_ms=0.5");
  finer.push_back("optim.steps=40");
  EXPECT_EQ(train_quietly(finer, student + "4").steps, 40);
  const auto fl = read_log(student + "4", "train");
  ASSERT_EQ(fl.size(), 40u);
  EXPECT_LT(fl.back()["distill"].get<double>() + fl[38]["distill"].get<double>(),
            0.95 * (fl[0]["distill"].get<double>() + fl[1]["distill"].get<double>()));
}

// An ANN-2D on one short sequence, validated on the whole sensor after `steps` steps.
std::vector<std::string> ann_overrides(const std::string& data, int steps) {
  auto ov = one_sequence_overrides(data, steps);
  for (const char* k : {"model.type=ann2d", "sample.centred_fraction=1.0", "loss.kind=bce",
                        "optim.lr=0.003", "run.val_full_s=0.2", "run.val_full_window_ms=20"})
    ov.push_back(k);
  ov.push_back("run.val_every=" + std::to_string(steps));
  return ov;
}

// Trains `ov` in `dir` for `steps` steps; `spikems eval` (the core's forward) must score the
// file exactly as the trainer's last whole-sensor validation did. Returns the model.
ModelSpec train_ann_and_check_eval(const std::vector<std::string>& ov, const std::string& dir,
                                   const std::string& data, int steps) {
  EXPECT_EQ(train_quietly(ov, dir).steps, steps);
  auto val = read_log(dir, "val");
  EXPECT_FALSE(val.empty());
  const WindowSummary w = whole_sensor_eval(dir + "/model.safetensors", data + "/seq_0000.h5");
  EXPECT_GT(w.windows, 0u);
  EXPECT_GT(w.iou_mean, 0.0);
  if (!val.empty()) {
    EXPECT_NEAR(val.back()["full_iou"].get<double>(), w.iou_mean, 1e-9);
  }
  const ModelSpec m = load_model(dir + "/model.safetensors");
  EXPECT_EQ(m.type, ModelType::ANN2D);
  return m;
}

// The ANN-2D with U-Net skips (model.skips on an ann2d): trained through the same loop, its
// file has the skips and `spikems eval` (the core's forward, the sensor padded to a size the
// skips meet at) scores it exactly as the trainer's whole-sensor validation.
TEST(Trainer, Ann2dWithSkipsTrainsAndEvalAgrees) {
  const std::string scratch = scratch_dir();  // each call empties the folder
  const std::string data = scratch + "/data";
  auto ov = ann_overrides(data, 20);
  ov.push_back("model.skips=true");
  ov.push_back("sample.warmup_ms=0");
  EXPECT_TRUE(train_ann_and_check_eval(ov, scratch + "/ann-skips", data, 20).has_skips());
}

// optim.ema_decay: the saved model is the running average of the trained weights, with the
// decay min(d, (1 + n) / (10 + n)) after n updates; averaging leaves training itself unchanged
// (same losses), and a run resumed from its checkpoint continues the average exactly.
TEST(Trainer, WeightAveragingIsTheRunningMeanAndResumes) {
  const std::string scratch = scratch_dir();
  const std::string data = scratch + "/data";
  auto ov = ann_overrides(data, 2);
  for (const char* k : {"sample.warmup_ms=0", "optim.schedule=\"constant\"", "optim.warmup_steps=0",
                        "run.val_full_s=0.0", "run.checkpoint_every=1"})
    ov.push_back(k);
  ASSERT_EQ(train_quietly(ov, scratch + "/w0").steps, 2);  // W0: trained weights to start from
  auto from_w0 = [&](int steps, double decay) {
    auto o = ov;
    o.push_back("model.init=\"" + scratch + "/w0/model.safetensors\"");
    o.push_back("optim.steps=" + std::to_string(steps));
    o.push_back("optim.ema_decay=" + std::to_string(decay));
    return o;
  };
  std::vector<ModelSpec> w{load_model(scratch + "/w0/model.safetensors")};
  for (int k = 1; k <= 3; ++k) {
    const std::string d = scratch + "/w" + std::to_string(k) + "k";
    ASSERT_EQ(train_quietly(from_w0(k, 0.0), d).steps, k);
    w.push_back(load_model(d + "/model.safetensors"));
  }
  ASSERT_EQ(train_quietly(from_w0(3, 0.9), scratch + "/ema").steps, 3);
  const ModelSpec e = load_model(scratch + "/ema/model.safetensors");
  // e1 = 0.1 w0 + 0.9 w1 (d = min(0.9, 1/10)), e2 = 2/11 e1 + 9/11 w2, e3 = 3/12 e2 + 9/12 w3.
  const double d[3] = {1.0 / 10, 2.0 / 11, 3.0 / 12};
  ASSERT_EQ(e.layers.size(), w[0].layers.size());
  double worst = 0, moved = 0;
  for (size_t l = 0; l < e.layers.size(); ++l)
    for (auto field : {&LayerSpec::weight, &LayerSpec::bias}) {
      const auto& got = e.layers[l].*field;
      ASSERT_EQ(got.size(), (w[3].layers[l].*field).size());
      for (size_t i = 0; i < got.size(); ++i) {
        double avg = (w[0].layers[l].*field)[i];
        for (int k = 1; k <= 3; ++k)
          avg = d[k - 1] * avg + (1 - d[k - 1]) * (w[size_t(k)].layers[l].*field)[i];
        worst = std::max(worst, std::abs(double(got[i]) - avg));
        moved = std::max(moved, std::abs(avg - (w[3].layers[l].*field)[i]));
      }
    }
  EXPECT_LT(worst, 1e-6);
  EXPECT_GT(moved, 1e-4) << "the average equals the last weights: the test cannot tell";
  // Training is the same with and without the average.
  const auto la = read_log(scratch + "/w3k", "train"), lb = read_log(scratch + "/ema", "train");
  ASSERT_EQ(la.size(), 3u);
  ASSERT_EQ(lb.size(), 3u);
  for (size_t i = 0; i < 3; ++i)
    EXPECT_DOUBLE_EQ(la[i]["loss"].get<double>(), lb[i]["loss"].get<double>());
  // Stopped after one step and resumed: the same average as the straight run.
  TrainRunOptions ro;
  ro.out_dir = scratch + "/resumed";
  ro.progress = false;
  ro.time_limit_s = 1e-6;
  ASSERT_EQ(run_training(load_train_config(config_path(), from_w0(3, 0.9)), ro).steps, 1);
  ro.resume = true;
  ro.time_limit_s = 0;
  ASSERT_EQ(run_training(load_run_config(ro.out_dir, {}), ro).steps, 3);
  const ModelSpec r = load_model(ro.out_dir + "/model.safetensors");
  for (size_t l = 0; l < e.layers.size(); ++l) {
    EXPECT_EQ(r.layers[l].weight, e.layers[l].weight) << "layer " << l;
    EXPECT_EQ(r.layers[l].bias, e.layers[l].bias) << "layer " << l;
  }
  for (const char* bad : {"optim.ema_decay=1.0", "optim.ema_decay=-0.5"}) {
    auto o = ov;
    o.push_back(bad);
    expect_refused<Error>([&] { load_train_config(config_path(), o); }, {"optim.ema_decay"}, bad);
  }
}

// run.keep_val_models: each validation leaves its model as val-step<N>.safetensors, and that
// file is the model the validation scored (`spikems eval` gives the val line's number).
TEST(Trainer, KeepValModelsLeavesEachValidationsModel) {
  const std::string scratch = scratch_dir();
  const std::string data = scratch + "/data";
  const std::string dir = scratch + "/ann-keep";
  auto ov = ann_overrides(data, 20);
  ov.push_back("sample.warmup_ms=0");
  ov.push_back("run.keep_val_models=true");
  ov.push_back("run.val_every=10");
  ASSERT_EQ(train_quietly(ov, dir).steps, 20);
  const auto val = read_log(dir, "val");
  ASSERT_EQ(val.size(), 3u);  // steps 0 (untrained), 10, 20
  EXPECT_FALSE(std::filesystem::exists(dir + "/val-step0.safetensors"));
  for (size_t i = 1; i < val.size(); ++i) {
    const int64_t step = val[i]["step"].get<int64_t>();
    const std::string f = dir + "/val-step" + std::to_string(step) + ".safetensors";
    ASSERT_TRUE(std::filesystem::exists(f)) << f;
    EXPECT_EQ(load_model(f).training.at("steps").get<int64_t>(), step);
    const WindowSummary w = whole_sensor_eval(f, data + "/seq_0000.h5");
    EXPECT_NEAR(val[i]["full_iou"].get<double>(), w.iou_mean, 1e-9) << f;
  }
  // Two snapshots, not one file twice: training moved the weights between them.
  EXPECT_NE(load_model(dir + "/val-step10.safetensors").layers[0].weight,
            load_model(dir + "/val-step20.safetensors").layers[0].weight);
}

// model.history on an ANN-2D: the past frames come from the warm-up, the file records them,
// `spikems eval` scores it as the trainer's whole-sensor validation does; a warm-up too short
// to hold them, or a history on a spiking network, is refused naming the key.
TEST(Trainer, Ann2dWithHistoryTrainsAndIsChecked) {
  const std::string scratch = scratch_dir();
  const std::string data = scratch + "/data";
  auto ov = ann_overrides(data, 10);
  ov.push_back("model.history=2");
  ov.push_back("sample.warmup_ms=20");
  const ModelSpec m = train_ann_and_check_eval(ov, scratch + "/ann-history", data, 10);
  EXPECT_EQ(m.ann_history, 2);
  EXPECT_EQ(m.layers[0].in_channels, 12);
  // As a teacher: a spiking student whose warm-up holds the teacher's two past frames learns
  // from it (the distillation is logged) and starts from its weights; a shorter warm-up is
  // refused naming the key and the teacher.
  const std::string teacher = scratch + "/ann-history/model.safetensors";
  auto sv = one_sequence_overrides(data, 3);
  for (const char* k :
       {"loss.teacher_weight=1.0", "loss.feature_weight=1.0", "sample.warmup_ms=20"})
    sv.push_back(k);
  sv.push_back("loss.teacher=" + teacher);
  sv.push_back("model.init_ann=" + teacher);
  EXPECT_EQ(train_quietly(sv, scratch + "/student").steps, 3);
  for (const auto& line : read_log(scratch + "/student", "train")) {
    EXPECT_GT(line["distill"].get<double>(), 0.0);
    EXPECT_GT(line["feature"].get<double>(), 0.0);
  }
  sv.push_back("sample.warmup_ms=15");
  expect_refused([&] { train_quietly(sv, scratch + "/student-short"); },
                 {"sample.warmup_ms", "teacher"}, "a warm-up shorter than the teacher's frames");
  auto short_warmup = ov;
  short_warmup.push_back("sample.warmup_ms=15");
  expect_refused([&] { train_quietly(short_warmup, scratch + "/ann-history-short"); },
                 {"sample.warmup_ms"}, "a 15 ms warm-up for two 10 ms frames");
  auto snn = tiny_overrides(1);
  snn.push_back("model.history=1");
  expect_refused([&] { train_quietly(snn, scratch + "/snn-history"); }, {"model.history"},
                 "model.history on a spiking network");
}

// loss.rate_ceilings / rate_floors: each hidden layer pays floor_weight * (rate / its ceiling -
// 1)^2 above its own ceiling and floor_weight * (1 - rate / its floor)^2 below its own floor (0:
// none); with every other rate term off the logged activity is that sum of the logged rates.
TEST(Trainer, PerLayerRateBoundsEnterTheActivityTerm) {
  const std::string dir = scratch_dir() + "/run";
  auto ov = tiny_overrides(4);
  const std::vector<double> ceil = {0.001, 0.0, 0.9, 0.002, 0.0};  // 5 hidden layers
  const std::vector<double> floor = {0.0, 0.6, 0.0, 0.0, 0.7};
  for (const char* k : {"loss.activity_weight=0.0", "loss.floor_weight=1.0", "loss.rate_floor=0.0",
                        "loss.output_floor=0.0", "loss.rate_ceilings=[0.001, 0.0, 0.9, 0.002, 0.0]",
                        "loss.rate_floors=[0.0, 0.6, 0.0, 0.0, 0.7]"})
    ov.push_back(k);
  EXPECT_EQ(train_quietly(ov, dir).steps, 4);
  const auto lines = read_log(dir, "train");
  ASSERT_EQ(lines.size(), 4u);
  int over_ceiling = 0, under_floor = 0;
  for (const auto& line : lines) {
    ASSERT_EQ(line["rates"].size(), 6u);
    double want = 0;
    for (size_t k = 0; k < ceil.size(); ++k) {
      const double r = line["rates"][k].get<double>();
      if (ceil[k] > 0) {
        const double over = std::max(0.0, r / ceil[k] - 1);
        want += over * over;
        over_ceiling += over > 0;
      }
      if (floor[k] > 0) {
        const double under = std::max(0.0, 1 - r / floor[k]);
        want += under * under;
        under_floor += under > 0;
      }
    }
    // Rates are logged to 6 decimals: 1e-6 / 0.001 relative, squared terms of ~10^2.
    EXPECT_NEAR(line["activity"].get<double>(), want, 1e-3 * std::max(1.0, want))
        << "step " << line["step"];
  }
  EXPECT_GT(over_ceiling, 0) << "no layer fired above its ceiling: that part tested nothing";
  EXPECT_GT(under_floor, 0) << "no layer fired below its floor: that part tested nothing";
}

// loss.synops_weight: every line logs the SynOps per input event; with the linear form the
// activity term is w x that / 1000 (the other sparsity terms off), the penalised run does less
// work per event than the same run without it, and with every source weighted 0 it is that run.
TEST(Trainer, SynopsPenaltyIsLoggedAndLowersTheWorkPerEvent) {
  auto base = tiny_overrides(12);
  for (const char* k : {"loss.activity_weight=0.0", "loss.floor_weight=0.0"}) base.push_back(k);
  const std::string free_dir = scratch_dir() + "/free", paid_dir = scratch_dir() + "/paid";
  EXPECT_EQ(train_quietly(base, free_dir).steps, 12);
  auto paid = base;
  paid.push_back("loss.synops_weight=30.0");
  EXPECT_EQ(train_quietly(paid, paid_dir).steps, 12);
  const auto free_lines = read_log(free_dir, "train"), paid_lines = read_log(paid_dir, "train");
  ASSERT_EQ(free_lines.size(), 12u);
  ASSERT_EQ(paid_lines.size(), 12u);
  double free_late = 0, paid_late = 0;
  for (size_t i = 0; i < 12; ++i) {
    ASSERT_TRUE(paid_lines[i].contains("synops_per_event")) << paid_lines[i].dump();
    const double sope = paid_lines[i]["synops_per_event"].get<double>();
    EXPECT_GT(sope, 0.0);
    // Logged to 0.1: 30 x 0.05 / 1000 of rounding.
    EXPECT_NEAR(paid_lines[i]["activity"].get<double>(), 30.0 * sope / 1000, 2e-3)
        << "step " << i + 1;
    EXPECT_EQ(free_lines[i]["activity"].get<double>(), 0.0);
    if (i >= 8) {
      free_late += free_lines[i]["synops_per_event"].get<double>();
      paid_late += sope;
    }
  }
  // The first step is the same network on the same batch.
  EXPECT_NEAR(paid_lines[0]["synops_per_event"].get<double>(),
              free_lines[0]["synops_per_event"].get<double>(), 0.11);
  std::printf("SynOps per event, steps 9-12: %.1f without the penalty, %.1f with it\n",
              free_late / 4, paid_late / 4);
  EXPECT_LT(paid_late, 0.9 * free_late) << "the penalty did not lower the work per event";

  // loss.synops_source_weights all 0: the budget counts nothing, so the run is the free one, and
  // the log still gives the full count (the default net: the input and 6 layers).
  auto spared = paid;
  spared.push_back("loss.synops_source_weights=[0, 0, 0, 0, 0, 0, 0]");
  const std::string spared_dir = scratch_dir() + "/spared";
  EXPECT_EQ(train_quietly(spared, spared_dir).steps, 12);
  const auto spared_lines = read_log(spared_dir, "train");
  ASSERT_EQ(spared_lines.size(), 12u);
  for (size_t i = 0; i < 12; ++i) {
    EXPECT_EQ(spared_lines[i]["activity"].get<double>(), 0.0) << "step " << i + 1;
    EXPECT_EQ(spared_lines[i]["loss"].get<double>(), free_lines[i]["loss"].get<double>())
        << "step " << i + 1;
    EXPECT_EQ(spared_lines[i]["synops_per_event"].get<double>(),
              free_lines[i]["synops_per_event"].get<double>())
        << "step " << i + 1;
  }
}

// loss.offevent_weight: the term is logged and enters the loss with its weight (the loss is the
// sum of the logged terms, each times its weight from the run's config.json).
TEST(Trainer, OffEventTermIsLoggedAndWeighted) {
  const std::string dir = scratch_dir() + "/run";
  auto ov = tiny_overrides(4);
  ov.push_back("loss.offevent_weight=2.0");
  EXPECT_EQ(train_quietly(ov, dir).steps, 4);
  std::ifstream f(dir + "/config.json");
  const nlohmann::json cfg = nlohmann::json::parse(f);
  const double lambda = cfg["loss"]["lambda"].get<double>();
  const double iou_w = cfg["loss"]["iou_weight"].get<double>();
  ASSERT_EQ(cfg["loss"]["offevent_weight"].get<double>(), 2.0);
  const auto lines = read_log(dir, "train");
  ASSERT_EQ(lines.size(), 4u);
  int positive = 0;
  for (const auto& line : lines) {
    ASSERT_TRUE(line.contains("offevent")) << line.dump();
    const double off = line["offevent"].get<double>();
    EXPECT_GE(off, 0.0);
    positive += off > 0;
    const double sum = line["bce"].get<double>() + lambda * line["spike"].get<double>() +
                       iou_w * line["soft_iou_loss"].get<double>() +
                       line["activity"].get<double>() + 2.0 * off;
    EXPECT_NEAR(line["loss"].get<double>(), sum, 1e-5 * std::max(1.0, sum))
        << "step " << line["step"];
  }
  EXPECT_GT(positive, 0) << "no event-less pixel near the threshold: the case tested nothing";
}

TEST(Trainer, NonFiniteLossStopsNamingTheStep) {
  const std::string dir = scratch_dir() + "/run";
  auto ov = tiny_overrides(10);
  ov.push_back("loss.alpha=1e39");  // float32 overflow: inf (and 0 * inf) in L_bce
  ov.push_back("loss.kind=bce");
  TrainConfig cfg = load_train_config(config_path(), ov);
  TrainRunOptions ro;
  ro.out_dir = dir;
  ro.progress = false;
  try {
    run_training(cfg, ro);
    FAIL() << "no error";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("step 1: the loss is "), std::string::npos) << m;
    EXPECT_NE(m.find("The last good checkpoint"), std::string::npos) << m;
  }
}

}  // namespace
}  // namespace spikems::train
