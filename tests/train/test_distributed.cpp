// Data-parallel `spikems train` (src/train/trainer/distributed.*): two processes on localhost
// equal one process with the combined batch; a rank that dies or hangs ends the other with a
// message naming it; bad launch settings stop before any rendezvous.
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "common/test_paths.h"
#include "core/model/model_file.h"
#include "train/trainer/distributed.h"

namespace spikems::train {
namespace {

namespace fs = std::filesystem;
using test::run_command;
using test::scratch_dir;
using test::spikems_binary;

// A port the kernel just handed out (free unless someone takes it in the next milliseconds).
int free_port() {
  int s = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  a.sin_port = 0;
  EXPECT_EQ(bind(s, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
  socklen_t n = sizeof a;
  getsockname(s, reinterpret_cast<sockaddr*>(&a), &n);
  close(s);
  return ntohs(a.sin_port);
}

const std::string& tiny_data() {
  static std::string dir = [] {
    std::string d = fs::temp_directory_path() / ("spikems_dist_tiny_" + std::to_string(getpid()));
    fs::remove_all(d);
    std::string out;
    EXPECT_EQ(run_command(spikems_binary() +
                              " simulate --preset tiny --sequences 4 --duration 0.2s --seed 3 "
                              "--threads 1 --no-progress --out " +
                              d,
                          &out),
              0)
        << out;
    test::scratch_registry.dirs.push_back(d);
    return d;
  }();
  return dir;
}

// `spikems train` on tiny crops with a loss that is a mean over samples (L_spike and the
// activity term; no rate floors, no soft IoU), so that the mean of the ranks' gradients is
// the gradient of the whole batch.
std::string train_command(int steps, int batch) {
  const std::string d = tiny_data();
  std::string cmd = spikems_binary() + " train -q --config " + test::source_dir() +
                    "/configs/train/default.toml --steps " + std::to_string(steps);
  for (const std::string& o :
       {"data.train=[{path=\"" + d + "\", split=\"train\"}]",
        "data.val=[{path=\"" + d + "\", split=\"val\"}]", std::string("sample.crop=32"),
        std::string("sample.warmup_ms=5"), "optim.batch=" + std::to_string(batch),
        std::string("optim.warmup_steps=2"), std::string("loss.kind=spike"),
        std::string("loss.iou_weight=0.0"), std::string("loss.floor_weight=0.0"),
        std::string("run.threads=1"), std::string("run.log_every=1"),
        std::string("run.val_samples=4"), std::string("run.val_every=2"),
        std::string("run.val_full_s=0.0"), std::string("run.checkpoint_every=2")})
    cmd += " --set '" + o + "'";
  return cmd;
}

std::string slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::vector<double> log_losses(const std::string& dir) {
  std::vector<double> out;
  std::ifstream in(dir + "/log.jsonl");
  std::string line;
  while (std::getline(in, line)) {
    auto j = nlohmann::json::parse(line);
    if (j["kind"] == "train") out.push_back(j["loss"].get<double>());
  }
  return out;
}

struct Ranks {
  int rc0 = -1, rc1 = -1;
  std::string out0, out1;
};

// Two ranks of `cmd` on localhost. `env1` goes to rank 1 alone, `env0` to rank 0 alone. Each
// rank is bounded by `timeout 120` so a broken build fails instead of hanging the suite.
Ranks run_two(const std::string& cmd, const std::string& dir, const std::string& extra,
              const std::string& env0 = "", const std::string& env1 = "") {
  const std::string common = " --world-size 2 --master-addr 127.0.0.1 --master-port " +
                             std::to_string(free_port()) + " " + extra;
  const std::string r0 = "env " + env0 + " timeout -s KILL 120 " + cmd + common + " --rank 0";
  const std::string r1 = "env " + env1 + " timeout -s KILL 120 " + cmd + common + " --rank 1";
  const std::string sh = "cd " + dir + "; (" + r0 + " > out0 2>&1; echo $? > rc0) & " + "(" + r1 +
                         " > out1 2>&1; echo $? > rc1) & wait";
  run_command("bash -c '" + [&] {
    std::string q;  // single quotes inside the bash -c argument
    for (char ch : sh) q += ch == '\'' ? std::string("'\\''") : std::string(1, ch);
    return q;
  }() + "'");
  Ranks r;
  r.rc0 = std::atoi(slurp(dir + "/rc0").c_str());
  r.rc1 = std::atoi(slurp(dir + "/rc1").c_str());
  r.out0 = slurp(dir + "/out0");
  r.out1 = slurp(dir + "/out1");
  return r;
}

TEST(Distributed, TwoRanksEqualOneProcessWithTheCombinedBatch) {
  const std::string base = scratch_dir();
  const std::string one = base + "/one", two = base + "/two";
  std::string out;
  ASSERT_EQ(run_command(train_command(3, 2) + " --out " + one, &out), 0) << out;
  const Ranks r = run_two(train_command(3, 2), base, "--out " + two);
  ASSERT_EQ(r.rc0, 0) << r.out0;
  ASSERT_EQ(r.rc1, 0) << r.out1;
  // Rank 0 alone wrote the run folder; it holds what a single process writes.
  for (const char* f : {"model.safetensors", "checkpoint.pt", "log.jsonl", "config.json"})
    EXPECT_TRUE(fs::exists(two + "/" + f)) << f;
  const ModelSpec a = load_model(one + "/model.safetensors");
  const ModelSpec b = load_model(two + "/model.safetensors");
  ASSERT_EQ(a.layers.size(), b.layers.size());
  // Tolerance 1e-5 absolute: the ranks' gradients are summed in another order than one
  // process sums them (float rounding). Measured: 3e-8 between the two runs, 9e-3 between
  // batch 2 and its first sample alone (checked below), weights up to 0.7.
  double max_diff = 0;
  for (size_t k = 0; k < a.layers.size(); ++k) {
    ASSERT_EQ(a.layers[k].weight.size(), b.layers[k].weight.size());
    for (size_t i = 0; i < a.layers[k].weight.size(); ++i)
      max_diff =
          std::max(max_diff, double(std::abs(a.layers[k].weight[i] - b.layers[k].weight[i])));
  }
  EXPECT_LT(max_diff, 1e-5) << "largest weight difference, 1 process vs 2 ranks";
  // The tolerance tells a missing share apart: a run on sample 0 alone ends far away.
  const std::string half = base + "/half";
  ASSERT_EQ(run_command(train_command(3, 1) + " --out " + half, &out), 0) << out;
  const ModelSpec h = load_model(half + "/model.safetensors");
  double half_diff = 0;
  for (size_t k = 0; k < a.layers.size(); ++k)
    for (size_t i = 0; i < a.layers[k].weight.size(); ++i)
      half_diff =
          std::max(half_diff, double(std::abs(a.layers[k].weight[i] - h.layers[k].weight[i])));
  EXPECT_GT(half_diff, 1e-4) << "batch 2 vs its first sample alone";
  // Resume with another world size: 2 steps in 1 process, the 3rd in 2 ranks.
  const std::string mixed = base + "/mixed";
  ASSERT_EQ(run_command(train_command(2, 2) + " --out " + mixed, &out), 0) << out;
  fs::create_directories(base + "/resume");
  const Ranks rr = run_two(spikems_binary() + " train -q --resume " + mixed + " --steps 3",
                           base + "/resume", "");
  ASSERT_EQ(rr.rc0, 0) << rr.out0;
  ASSERT_EQ(rr.rc1, 0) << rr.out1;
  const ModelSpec m = load_model(mixed + "/model.safetensors");
  double mixed_diff = 0;
  for (size_t k = 0; k < a.layers.size(); ++k)
    for (size_t i = 0; i < a.layers[k].weight.size(); ++i)
      mixed_diff =
          std::max(mixed_diff, double(std::abs(a.layers[k].weight[i] - m.layers[k].weight[i])));
  EXPECT_LT(mixed_diff, 1e-5) << "1 process for 3 steps vs 1 process for 2 + 2 ranks for 1";
  const auto la = log_losses(one), lb = log_losses(two);
  ASSERT_EQ(la.size(), 3u);
  ASSERT_EQ(lb.size(), 3u);
  for (size_t i = 0; i < 3; ++i) EXPECT_NEAR(la[i], lb[i], 1e-5 * std::abs(la[i]) + 1e-9) << i;
}

TEST(Distributed, ARankThatDiesEndsTheOtherWithAMessageNamingIt) {
  const std::string dir = scratch_dir();
  const Ranks r = run_two(train_command(6, 2), dir, "--out " + dir + "/run --dist-timeout 10", "",
                          "SPIKEMS_TEST_DIE_AT_STEP=1");
  EXPECT_EQ(r.rc1, 3) << r.out1;  // the test switch's exit
  EXPECT_EQ(r.rc0, 1) << r.out0;
  EXPECT_NE(r.out0.find("rank 1 is gone"), std::string::npos) << r.out0;
  EXPECT_NE(r.out0.find("last seen at step 1"), std::string::npos) << r.out0;
  // The last checkpoint (none at step 1 with checkpoint_every 2) is not half-written.
  EXPECT_FALSE(fs::exists(dir + "/run/checkpoint.pt"));
}

TEST(Distributed, RankZeroThatDiesEndsTheOthers) {
  const std::string dir = scratch_dir();
  const Ranks r = run_two(train_command(6, 2), dir, "--out " + dir + "/run --dist-timeout 10",
                          "SPIKEMS_TEST_DIE_AT_STEP=3", "");
  EXPECT_EQ(r.rc0, 3) << r.out0;
  EXPECT_EQ(r.rc1, 1) << r.out1;
  EXPECT_NE(r.out1.find("rank 0"), std::string::npos) << r.out1;
  EXPECT_NE(r.out1.find("gone"), std::string::npos) << r.out1;
  // The checkpoint of step 2 stays whole and resumable by a single process.
  std::string out;
  EXPECT_EQ(run_command(spikems_binary() + " train -q --resume " + dir + "/run --steps 3", &out), 0)
      << out;
}

TEST(Distributed, AHungRankEndsTheOtherWithinTheTimeout) {
  const std::string dir = scratch_dir();
  // The hung rank stops answering for 2 x timeout + 2 s, then exits with 4 (no stray process).
  const Ranks r = run_two(train_command(6, 2), dir, "--out " + dir + "/run --dist-timeout 3", "",
                          "SPIKEMS_TEST_HANG_AT_STEP=1");
  EXPECT_EQ(r.rc0, 1) << r.out0;
  EXPECT_EQ(r.rc1, 4) << r.out1;
  EXPECT_NE(r.out0.find("rank 1 did not answer within 3 s"), std::string::npos) << r.out0;
}

TEST(Distributed, BadLaunchSettingsStopWithAMessage) {
  const std::string dir = scratch_dir();
  const std::string base =
      "env -u MASTER_ADDR -u RANK -u WORLD_SIZE " + train_command(2, 2) + " --out " + dir + "/run";
  auto expect_fail = [&](const std::string& args, const std::string& message) {
    std::string out;
    EXPECT_EQ(run_command(base + " " + args, &out), 1) << args << "\n" << out;
    EXPECT_NE(out.find(message), std::string::npos) << args << "\n" << out;
  };
  expect_fail("--world-size 2 --rank 2 --master-addr 127.0.0.1", "rank 2 is outside 0 .. 1");
  expect_fail("--world-size 2 --rank 0", "set MASTER_ADDR or --master-addr");
  expect_fail("--world-size 2 --master-addr 127.0.0.1", "set RANK or --rank");
  expect_fail("--world-size 2 --rank 0 --master-addr 127.0.0.1 --set optim.batch=3",
              "not divisible by the world size 2");
  std::string out;
  EXPECT_EQ(run_command("env -u MASTER_ADDR -u WORLD_SIZE RANK=x " + train_command(2, 2) +
                            " --out " + dir + "/run",
                        &out),
            1)
      << out;
  EXPECT_NE(out.find("environment variable RANK"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(dir + "/run"));
}

// Flags win over the torchrun environment; WORLD_SIZE absent is the single-process run.
TEST(Distributed, FlagsWinOverTheEnvironment) {
  setenv("WORLD_SIZE", "4", 1);
  setenv("RANK", "3", 1);
  setenv("MASTER_ADDR", "node7", 1);
  setenv("MASTER_PORT", "1234", 1);
  DistOptions o = resolve_dist_options({});
  EXPECT_EQ(o.world_size, 4);
  EXPECT_EQ(o.rank, 3);
  EXPECT_EQ(o.master_addr, "node7");
  EXPECT_EQ(o.master_port, 1234);
  DistFlags f;
  f.rank = 1;
  f.master_addr = "10.0.0.1";
  f.timeout_s = 10;
  o = resolve_dist_options(f);
  EXPECT_EQ(o.rank, 1);
  EXPECT_EQ(o.master_addr, "10.0.0.1");
  EXPECT_EQ(o.timeout_s, 10);
  for (const char* v : {"WORLD_SIZE", "RANK", "MASTER_ADDR", "MASTER_PORT"}) unsetenv(v);
  o = resolve_dist_options({});
  EXPECT_EQ(o.world_size, 1);
  EXPECT_EQ(o.rank, 0);
  EXPECT_EQ(o.timeout_s, 300);
}

}  // namespace
}  // namespace spikems::train
