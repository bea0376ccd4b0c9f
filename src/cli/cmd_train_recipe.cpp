// `spikems train --recipe FILE --out DIR` (cmd_train_recipe.h): the recipe runner. The whole
// recipe is read and checked first (keys, types, references, the trainer's own config loading,
// the other commands' options in parse-only mode); then each stage runs as a child `spikems`
// process with OUT as its working directory, and leaves OUT/<stage>/done.json (atomic) so that
// the same command after a stop or a kill -9 skips what is finished and resumes the rest.
#include "cli/cmd_train_recipe.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <toml++/toml.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <sstream>
#include <thread>

#include "core/dataset/sequence.h"
#include "core/events/binning.h"
#include "core/events/event_ops.h"
#include "core/events/io.h"
#include "core/model/model_file.h"
#include "core/sim/sim_config.h"
#include "core/util/atomic_file.h"
#include "core/util/duration.h"
#include "core/util/error.h"
#include "core/util/host_info.h"
#include "core/util/text_format.h"
#include "spikems/version.h"
#include "train/trainer/toml_json.h"
#include "train/trainer/train_config.h"

extern char** environ;

namespace spikems::cli {

namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using ojson = nlohmann::ordered_json;

// ---------------------------------------------------------------- small helpers

// The same value as an ordered_json (output files keep their keys in the written order).
ojson ordered(const json& j) {
  return ojson::parse(j.dump());
}

// FNV-1a, 64 bit: a stable fingerprint of a stage's definition or a kept file (not security).
uint64_t fnv1a(const char* p, size_t n, uint64_t h = 0xcbf29ce484222325ull) {
  for (size_t i = 0; i < n; ++i) h = (h ^ uint8_t(p[i])) * 0x100000001b3ull;
  return h;
}
std::string hex(uint64_t h) {
  char b[20];
  std::snprintf(b, sizeof b, "%016llx", (unsigned long long)h);
  return b;
}
std::string hash_text(const std::string& s) {
  return hex(fnv1a(s.data(), s.size()));
}
std::string hash_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return "";
  uint64_t h = 0xcbf29ce484222325ull;
  std::vector<char> buf(1 << 20);
  while (in.read(buf.data(), std::streamsize(buf.size())) || in.gcount() > 0)
    h = fnv1a(buf.data(), size_t(in.gcount()), h);
  return hex(h);
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  if (!in) return "";
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

json read_json(const fs::path& p) {
  const std::string t = slurp(p);
  if (t.empty()) return nullptr;
  try {
    return json::parse(t);
  } catch (const std::exception&) {
    return nullptr;
  }
}

// Writes `text` atomically unless the file already holds it (ranks sharing OUT write the same
// bytes; skipping the rewrite keeps their renames from racing for nothing).
void write_if_changed(const fs::path& p, const std::string& text) {
  if (fs::exists(p) && slurp(p) == text) return;
  write_file_atomic(p.string(), text);
}

double now_unix() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

// "45 s", "25 min", "1 h 10 min": the per-stage lines' estimates.
std::string about(double s) {
  if (s < 59.5) return fmt("%.0f s", s);
  if (s < 3570) return fmt("%.0f min", s / 60);
  const long m = std::lround(s / 60);
  return std::to_string(m / 60) + " h" + (m % 60 ? " " + std::to_string(m % 60) + " min" : "");
}

// "a, b" -> {"a", "b"}.
std::vector<std::string> split_list(const std::string& s) {
  std::vector<std::string> v;
  for (size_t a = 0; a <= s.size();) {
    const size_t b = std::min(s.find(", ", a), s.size());
    v.push_back(s.substr(a, b - a));
    a = b + 2;
  }
  return v;
}

// "12.3 s", "25 min (1512 s)": measured times in the summary.
std::string wall_text(double s) {
  return s < 60 ? fmt("%.1f s", s) : about(s) + " (" + fmt("%.0f", s) + " s)";
}

std::string join(const std::vector<std::string>& v, const char* sep = ", ") {
  std::string o;
  for (const auto& s : v) o += (o.empty() ? "" : sep) + s;
  return o;
}

// The command line as a user would type it (single quotes where needed).
std::string shell_line(const std::vector<std::string>& argv) {
  std::string o;
  for (const auto& a : argv) {
    const bool plain = !a.empty() && a.find_first_of(" \t'\"\\$`*?[]{}()<>|&;#~") == a.npos;
    std::string q = plain ? a : "'";
    if (!plain) {
      for (char c : a) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
      q += "'";
    }
    o += (o.empty() ? "" : " ") + q;
  }
  return o;
}

int hardware_threads() {
  return std::max(1, int(std::thread::hardware_concurrency()));
}

// ---------------------------------------------------------------- child processes

volatile sig_atomic_t g_signal = 0;
volatile pid_t g_child = 0;

// Ctrl-C reaches the child from the terminal (same process group) and it stops cleanly (a
// train stage with a checkpoint); the runner then stops too. A SIGTERM sent to the runner alone
// is handed on. A second signal ends the runner at once; PR_SET_PDEATHSIG ends the child.
extern "C" void on_recipe_signal(int sig) {
  if (g_signal) _exit(128 + sig);
  g_signal = sig;
  if (sig == SIGTERM && g_child > 0) kill(g_child, SIGTERM);
}

void install_signals() {
  struct sigaction sa {};
  sa.sa_handler = on_recipe_signal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
}

void stop_if_interrupted() {
  if (g_signal)
    throw Error(
        "spikems train --recipe: interrupted; run the same command again to continue (finished "
        "stages are kept, a train stage resumes from its checkpoint)");
}

struct Spawn {
  std::vector<std::string> argv;
  std::string cwd;
  std::map<std::string, std::string> env;  // added to (or replacing in) this environment
  std::string stdout_path;                 // "": inherited
  bool capture = false;                    // stdout and stderr into the returned text
};

// Runs a child to its end: its exit status (128 + signal when killed).
int run_child(const Spawn& s, std::string* captured = nullptr) {
  std::vector<std::string> envs;
  for (char** e = environ; *e; ++e) {
    const std::string kv = *e;
    const std::string k = kv.substr(0, kv.find('='));
    if (!s.env.count(k)) envs.push_back(kv);
  }
  for (const auto& [k, v] : s.env) envs.push_back(k + "=" + v);
  std::vector<char*> av, ev;
  for (const auto& a : s.argv) av.push_back(const_cast<char*>(a.c_str()));
  av.push_back(nullptr);
  for (const auto& e : envs) ev.push_back(const_cast<char*>(e.c_str()));
  ev.push_back(nullptr);
  int pipefd[2] = {-1, -1};
  if (s.capture && pipe2(pipefd, O_CLOEXEC) != 0)
    fail(s.argv[0], "", std::string("cannot make a pipe: ") + std::strerror(errno));
  int out_fd = -1;
  if (!s.stdout_path.empty()) {
    out_fd = open(s.stdout_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (out_fd < 0) fail(s.stdout_path, "", std::string("cannot create: ") + std::strerror(errno));
  }
  std::fflush(nullptr);
  const pid_t parent = getpid();
  const pid_t pid = fork();
  if (pid < 0) fail(s.argv[0], "", std::string("cannot start: ") + std::strerror(errno));
  if (pid == 0) {
    prctl(PR_SET_PDEATHSIG, SIGKILL);  // a killed runner leaves no stage running on its own
    if (getppid() != parent) _exit(127);
    if (!s.cwd.empty() && chdir(s.cwd.c_str()) != 0) _exit(126);
    if (s.capture) {
      dup2(pipefd[1], 1);
      dup2(pipefd[1], 2);
    }
    if (out_fd >= 0) dup2(out_fd, 1);
    execve(av[0], av.data(), ev.data());
    _exit(127);
  }
  g_child = pid;
  if (out_fd >= 0) close(out_fd);
  if (s.capture) {
    close(pipefd[1]);
    char buf[4096];
    for (;;) {
      const ssize_t n = read(pipefd[0], buf, sizeof buf);
      if (n > 0 && captured) captured->append(buf, size_t(n));
      if (n == 0 || (n < 0 && errno != EINTR)) break;
    }
    close(pipefd[0]);
  }
  int status = 0;
  while (waitpid(pid, &status, 0) < 0)
    if (errno != EINTR) fail(s.argv[0], "", std::string("lost the child: ") + std::strerror(errno));
  g_child = 0;
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

// This program (spikems-torch: it runs the train stages) and `spikems` (every other command):
// beside it in the build tree, <prefix>/bin/spikems beside <prefix>/lib/spikems/ installed.
std::string self_exe() {
  std::error_code ec;
  const fs::path p = fs::read_symlink("/proc/self/exe", ec);
  if (ec) fail("/proc/self/exe", "", "unreadable: cannot find this program to run the stages");
  return p.string();
}
std::string main_exe() {
  const fs::path dir = fs::path(self_exe()).parent_path();
  std::vector<std::string> looked;
  for (const fs::path& p : {dir / "spikems", dir.parent_path().parent_path() / "bin/spikems"}) {
    looked.push_back(p.lexically_normal().string());
    if (access(p.c_str(), X_OK) == 0) return p.lexically_normal().string();
  }
  fail("spikems train --recipe", "",
       "cannot find the spikems program that runs the data, calibrate and eval stages (looked "
       "at: " +
           join(looked) + ")");
}

// ---------------------------------------------------------------- the recipe

using train::toml_to_json;

struct DataSet {
  std::string name, where;
  bool simulated = false;
  std::vector<std::string> sim_args;  // `spikems simulate` options (no --out, --threads)
  std::string describe;               // "simulate --preset mod ..." or the path
  std::string path;                   // absolute (path sets)
  std::string from;                   // another simulated set, made again at 1/downsample
  int downsample = 1, mask_dilation = 5;
  double expected_s = 0;
  std::string hash;
};

struct Stage {
  std::string name, kind, where;
  std::string config;  // absolute base config (train), "" = the trainer's defaults
  std::string keep = "best";
  std::string from;               // calibrate: the model, relative to OUT
  std::vector<std::string> args;  // calibrate, eval: extra options
  json set = json::array();       // train: [section, key, value] after "@NAME" resolution
  double expected_s = 0;
  json train_config;  // the resolved configuration (the trainer's config.json)
  json definition;    // the base configuration with [stage.set] on it, "@NAME" resolved
  int64_t train_steps = 0;
  std::string kept;  // relative to OUT; "" for eval
};

struct Recipe {
  std::string path, name, summary, model;
  fs::path dir;
  int threads = 1;
  int data_threads = -1;  // simulate's threads (0: every core; -1: as `threads`)
  std::vector<DataSet> data;
  std::vector<Stage> stages;
};

// One step of the run: the data sets ("data", index 0), then the [[stage]] tables in order.
struct Step {
  std::string name, kind, where;
  std::string folder;  // relative to OUT
  std::string kept;    // relative to OUT ("" for data and eval)
  std::string hash;
  double expected_s = 0;
  std::vector<int> refs;               // earlier steps whose kept file it reads
  std::vector<std::string> data_refs;  // data sets it reads
  const Stage* stage = nullptr;        // null for data
  bool makes_model = false;            // writes OUT/<recipe.model>
};

// Reads one table's keys with the recipe file and the table in every error.
class Keys {
 public:
  Keys(const toml::table& t, std::string file, std::string where)
      : t_(t), file_(std::move(file)), where_(std::move(where)) {}
  [[noreturn]] void bad(const std::string& why) const { fail(file_, where_, why); }
  const toml::node* get(const char* k) {
    used_.insert(k);
    return t_.get(k);
  }
  std::optional<std::string> str(const char* k, bool required = false) {
    const toml::node* n = get(k);
    if (!n) {
      if (required) bad(std::string("needs \"") + k + "\"");
      return std::nullopt;
    }
    if (!n->is_string()) bad(std::string("\"") + k + "\" must be a string");
    return n->as_string()->get();
  }
  std::optional<int64_t> integer(const char* k, int64_t lo, int64_t hi) {
    const toml::node* n = get(k);
    if (!n) return std::nullopt;
    if (!n->is_integer()) bad(std::string("\"") + k + "\" must be an integer");
    const int64_t v = n->as_integer()->get();
    if (v < lo || v > hi)
      bad(std::string("\"") + k + "\" = " + std::to_string(v) + " is outside " +
          std::to_string(lo) + " .. " + std::to_string(hi));
    return v;
  }
  // A duration string ("12min", "90s"): seconds, 0 when absent.
  double duration_s(const char* k) {
    const auto s = str(k);
    if (!s) return 0;
    try {
      const int64_t us = parse_duration_us(*s);
      if (us <= 0) throw Error("must be positive");
      return double(us) / 1e6;
    } catch (const Error& e) {
      bad(std::string("\"") + k + "\" = \"" + *s + "\": " + e.what() + " (e.g. \"12min\")");
    }
  }
  // Unknown keys are errors listing the known ones.
  void check(const std::vector<std::string>& allowed) const {
    for (auto& [k, v] : t_) {
      const std::string key(k.str());
      if (std::find(allowed.begin(), allowed.end(), key) == allowed.end())
        bad("unknown key \"" + key + "\" (keys: " + join(allowed) + ")");
    }
  }

 private:
  const toml::table& t_;
  std::string file_, where_;
  std::set<std::string> used_;
};

std::string line_of(const toml::node& n) {
  return " (line " + std::to_string(n.source().begin.line) + ")";
}

bool good_name(const std::string& s) {
  if (s.empty() || s.size() > 64 || !std::isalnum(static_cast<unsigned char>(s[0]))) return false;
  for (char c : s)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '-') return false;
  return true;
}

// `spikems CMD ARGS` checked in parse-only mode (option names, types, ranges; files need not
// exist): a recipe's options fail before the first stage runs, not hours into it.
void check_parses(const std::string& spikems, const std::vector<std::string>& args,
                  const std::function<void(const std::string&)>& bad) {
  Spawn s;
  s.argv = {spikems};
  s.argv.insert(s.argv.end(), args.begin(), args.end());
  s.env["SPIKEMS_PARSE_ONLY"] = "1";
  s.capture = true;
  std::string out;
  if (run_child(s, &out) != 0) {
    std::vector<std::string> said;  // CLI11's message without its "Run with --help" line
    std::istringstream lines(out);
    for (std::string l; std::getline(lines, l);)
      if (!l.empty() && l.find("Run with --help") == l.npos) said.push_back(l);
    bad("`spikems " + shell_line(args) + "` does not parse: " + join(said, "; "));
  }
}

class RecipeReader {
 public:
  RecipeReader(const std::string& path, const std::string& spikems) : spikems_(spikems) {
    r_.path = path;
    r_.dir = fs::absolute(path).parent_path();
  }

  Recipe read() {
    toml::table t;
    try {
      t = toml::parse_file(r_.path);
    } catch (const toml::parse_error& e) {
      fail(r_.path,
           "line " + std::to_string(e.source().begin.line) + ", column " +
               std::to_string(e.source().begin.column),
           std::string(e.description()));
    }
    Keys top(t, r_.path, "the top level");
    top.check({"recipe", "data", "stage"});
    read_recipe_table(t);
    read_data(t);
    read_stages(t);
    return r_;
  }

 private:
  std::string near_recipe(const std::string& p) const {
    fs::path q(p);
    if (q.is_relative()) q = r_.dir / q;
    return fs::absolute(q).lexically_normal().string();
  }

  void read_recipe_table(const toml::table& t) {
    const toml::node* n = t.get("recipe");
    if (!n || !n->is_table()) fail(r_.path, "the top level", "needs a [recipe] table");
    Keys k(*n->as_table(), r_.path, "[recipe]" + line_of(*n));
    k.check({"name", "summary", "model", "threads", "data_threads"});
    r_.name = *k.str("name", true);
    if (!good_name(r_.name)) k.bad("\"name\" must be letters, digits, '-' or '_'");
    r_.summary = k.str("summary").value_or("");
    r_.model = *k.str("model", true);
    if (r_.model.find('/') != r_.model.npos || r_.model.size() <= 12 ||
        r_.model.compare(r_.model.size() - 12, 12, ".safetensors") != 0 || r_.model[0] == '.')
      k.bad("\"model\" = \"" + r_.model +
            "\" must be a file name ending in .safetensors (written into the output folder)");
    r_.threads = int(k.integer("threads", 0, 1024).value_or(1));
    r_.data_threads = int(k.integer("data_threads", 0, 1024).value_or(-1));
  }

  void read_data(const toml::table& t) {
    const toml::node* n = t.get("data");
    if (!n) return;
    if (!n->is_table())
      fail(r_.path, "data" + line_of(*n), "must be tables [data.NAME], one per data set");
    for (auto& [key, v] : *n->as_table()) {
      DataSet d;
      d.name = std::string(key.str());
      d.where = "data." + d.name + line_of(v);
      if (!v.is_table()) fail(r_.path, d.where, "must be a table [data." + d.name + "]");
      if (!good_name(d.name))
        fail(r_.path, d.where, "a data set's name must be letters, digits, '-' or '_'");
      Keys k(*v.as_table(), r_.path, d.where);
      k.check({"simulate", "path", "from", "downsample", "time", "mask_dilation"});
      const toml::node* sim = k.get("simulate");
      const auto path = k.str("path");
      const auto from = k.str("from");
      if (int(bool(sim)) + int(bool(path)) + int(bool(from)) != 1)
        k.bad(
            "needs one of \"simulate\" (a table of `spikems simulate` options), \"path\" (a "
            "folder or file of labelled events) or \"from\" (another simulated set of this "
            "recipe, with \"downsample\")");
      d.downsample = int(k.integer("downsample", 1, 64).value_or(1));
      d.expected_s = k.duration_s("time");
      json def = {{"downsample", d.downsample}};
      if (from) {
        // The same rooms at two resolutions cost one simulation: a full-resolution stage and
        // the half-resolution ones read the same sequences.
        if (d.downsample < 2) k.bad("\"from\" needs \"downsample\" of 2 or more");
        if (k.get("mask_dilation")) k.bad("\"mask_dilation\" is for \"path\" sets (mask frames)");
        d.from = *from;
        d.describe = "data set " + d.from;
        r_.data.push_back(std::move(d));  // hashed below, once its source's hash is known
        continue;
      }
      if (sim) {
        if (!sim->is_table()) k.bad("\"simulate\" must be a table, e.g. { preset = \"mod\" }");
        if (k.get("mask_dilation")) k.bad("\"mask_dilation\" is for \"path\" sets (mask frames)");
        d.simulated = true;
        read_simulate(*sim->as_table(), d, def);
      } else {
        d.path = near_recipe(*path);
        std::error_code ec;
        if (!fs::exists(d.path, ec))
          k.bad("\"path\" = \"" + *path + "\": no such file or folder (" + d.path + ")");
        d.mask_dilation = int(k.integer("mask_dilation", 0, 99).value_or(5));
        d.describe = d.path;
        def["path"] = d.path;
        def["mask_dilation"] = d.mask_dilation;
      }
      d.hash = hash_text(def.dump());
      r_.data.push_back(std::move(d));
    }
    for (auto& d : r_.data) {
      if (d.from.empty()) continue;
      const auto src = std::find_if(r_.data.begin(), r_.data.end(),
                                    [&](const DataSet& s) { return s.name == d.from; });
      if (src == r_.data.end() || !src->simulated)
        fail(r_.path, d.where,
             "\"from\" = \"" + d.from + "\" must name a \"simulate\" set of this recipe");
      d.hash = hash_text(json{{"from", src->hash}, {"downsample", d.downsample}}.dump());
    }
    // Sources first: TOML tables come in name order, not file order.
    std::stable_partition(r_.data.begin(), r_.data.end(),
                          [](const DataSet& d) { return d.from.empty(); });
  }

  void read_simulate(const toml::table& sim, DataSet& d, json& def) {
    Keys s(sim, r_.path, d.where + ": simulate");
    s.check({"preset", "config", "sequences", "duration", "seed", "mask_period", "noise", "width",
             "height"});
    auto& a = d.sim_args;
    if (auto p = s.str("preset")) a.insert(a.end(), {"--preset", *p});
    if (auto c = s.str("config")) {
      if (s.get("preset")) s.bad("give \"preset\" or \"config\", not both");
      const std::string abs = near_recipe(*c);
      if (!fs::is_regular_file(abs))
        s.bad("\"config\" = \"" + *c + "\": no such file (" + abs + ")");
      try {
        validate_sim_config(sim::load_sim_config(abs), abs);
      } catch (const Error& e) {
        s.bad(std::string("\"config\": ") + e.what());
      }
      a.insert(a.end(), {"--config", abs});
      def["config_text"] = hash_text(slurp(abs));  // the content, wherever the recipe lies
    }
    if (auto v = s.integer("sequences", 1, 1000000))
      a.insert(a.end(), {"--sequences", std::to_string(*v)});
    for (const char* key : {"duration", "mask_period"})
      if (auto v = s.str(key)) {
        try {
          if (parse_duration_us(*v) <= 0) throw Error("must be positive");
        } catch (const Error& e) {
          s.bad(std::string("\"") + key + "\" = \"" + *v + "\": " + e.what());
        }
        a.insert(a.end(), {std::string("--") + (key[0] == 'd' ? "duration" : "mask-period"), *v});
      }
    if (auto v = s.integer("seed", 0, INT64_MAX)) a.insert(a.end(), {"--seed", std::to_string(*v)});
    if (auto v = s.str("noise")) a.insert(a.end(), {"--noise", *v});
    if (auto v = s.integer("width", 8, 4096)) a.insert(a.end(), {"--width", std::to_string(*v)});
    if (auto v = s.integer("height", 8, 4096)) a.insert(a.end(), {"--height", std::to_string(*v)});
    std::vector<std::string> check = {"simulate"};
    check.insert(check.end(), a.begin(), a.end());
    check.insert(check.end(), {"--out", "x"});
    check_parses(spikems_, check, [&](const std::string& why) { s.bad(why); });
    std::vector<std::string> shown = a;
    for (size_t i = 0; i + 1 < shown.size(); ++i)
      if (shown[i] == "--config") shown[i + 1] = fs::path(shown[i + 1]).filename().string();
    d.describe = "simulate " + join(shown, " ");
    json args = a;
    for (size_t i = 0; i + 1 < args.size(); ++i)
      if (args[i] == "--config") args[i + 1] = "";  // its content is hashed instead
    def["simulate"] = args;
  }

  // "@NAME" -> OUT-relative kept file of an earlier stage; records the reference.
  std::string resolve_refs(const std::string& s, size_t self, std::vector<int>& refs,
                           const std::function<void(const std::string&)>& bad) const {
    std::string out;
    size_t i = 0;
    while (i < s.size()) {
      if (s[i] != '@') {
        out += s[i++];
        continue;
      }
      size_t j = i + 1;
      while (j < s.size() &&
             (std::isalnum(static_cast<unsigned char>(s[j])) || s[j] == '_' || s[j] == '-'))
        ++j;
      const std::string name = s.substr(i + 1, j - i - 1);
      if (name.empty()) {
        out += s[i++];
        continue;
      }
      size_t k = 0;
      while (k < names_.size() && names_[k] != name) ++k;
      if (k == names_.size())
        bad("\"@" + name + "\" names no stage (stages: " + join(names_) + ")");
      if (k >= self)
        bad("\"@" + name +
            "\" is not an earlier stage: a stage reads only what the stages before "
            "it made");
      if (r_.stages[k].kept.empty())
        bad("\"@" + name + "\" is an eval stage, which keeps no model");
      out += r_.stages[k].kept;
      if (std::find(refs.begin(), refs.end(), int(k) + 1) == refs.end()) refs.push_back(int(k) + 1);
      i = j;
    }
    return out;
  }

  // Every "data/NAME..." string must name a data set of this recipe.
  void collect_data_refs(const json& j, std::vector<std::string>& out, const std::string& ctx,
                         const std::function<void(const std::string&)>& bad) const {
    if (j.is_object()) {
      for (auto& [k, v] : j.items())
        collect_data_refs(v, out, ctx.empty() ? k : ctx + "." + k, bad);
    } else if (j.is_array()) {
      for (const auto& v : j) collect_data_refs(v, out, ctx, bad);
    } else if (j.is_string()) {
      const std::string s = j.get<std::string>();
      if (s.rfind("data/", 0) != 0) return;
      const std::string name = s.substr(5, s.find('/', 5) - 5);
      bool known = false;
      for (const auto& d : r_.data) known |= d.name == name;
      std::vector<std::string> sets;
      for (const auto& d : r_.data) sets.push_back(d.name);
      if (!known)
        bad("\"" + s + "\"" + (ctx.empty() ? "" : " (" + ctx + ")") +
            " is not a data set of this recipe (its sets: " + (sets.empty() ? "none" : join(sets)) +
            ")");
      if (std::find(out.begin(), out.end(), name) == out.end()) out.push_back(name);
    }
  }

  void read_stages(const toml::table& t) {
    const toml::node* n = t.get("stage");
    if (!n) fail(r_.path, "the top level", "has no [[stage]] tables: nothing to run");
    if (!n->is_array_of_tables())
      fail(r_.path, "stage" + line_of(*n), "stages are [[stage]] tables (double brackets)");
    const toml::array& arr = *n->as_array();
    // First the names and kinds: a reference to a later stage is told apart from a typo.
    for (size_t i = 0; i < arr.size(); ++i) {
      const toml::table& st = *arr[i].as_table();
      Stage s;
      const std::string at = "stage[" + std::to_string(i + 1) + "]";
      Keys k(st, r_.path, at + line_of(arr[i]));
      s.name = *k.str("name", true);
      s.where = at + " \"" + s.name + "\"" + line_of(arr[i]);
      if (!good_name(s.name) || s.name == "data" || s.name == "eval")
        fail(r_.path, s.where,
             "a stage's name must be letters, digits, '-' or '_', and not \"data\" or \"eval\" "
             "(folders of the output)");
      for (const auto& o : r_.stages)
        if (o.name == s.name) fail(r_.path, s.where, "a second stage named \"" + s.name + "\"");
      s.kind = *k.str("kind", true);
      if (s.kind != "train" && s.kind != "calibrate" && s.kind != "eval")
        fail(r_.path, s.where, "kind \"" + s.kind + "\" is not one of train, calibrate, eval");
      if (s.kind == "train") {
        s.keep = k.str("keep").value_or("best");
        if (s.keep != "best" && s.keep != "last")
          fail(r_.path, s.where,
               "keep = \"" + s.keep +
                   "\" is not best (best.safetensors) or last (model.safetensors)");
        s.kept = s.name + (s.keep == "best" ? "/best.safetensors" : "/model.safetensors");
      } else if (s.kind == "calibrate") {
        s.kept = r_.model;
      }
      names_.push_back(s.name);
      r_.stages.push_back(s);
    }
    int calibrations = 0, last_train = -1;
    for (size_t i = 0; i < arr.size(); ++i) {
      calibrations += r_.stages[i].kind == "calibrate";
      if (r_.stages[i].kind == "train") last_train = int(i);
    }
    if (calibrations > 1)
      fail(r_.path, "stage", "more than one calibrate stage: each writes the recipe's model");
    if (last_train < 0) fail(r_.path, "stage", "no train stage: nothing makes a model");
    for (size_t i = 0; i < arr.size(); ++i) read_stage(*arr[i].as_table(), i);
  }

  void read_stage(const toml::table& st, size_t i) {
    Stage& s = r_.stages[i];
    Keys k(st, r_.path, s.where);
    auto bad = [&](const std::string& why) { k.bad(why); };
    std::vector<int> refs;
    std::vector<std::string> data_refs;
    if (s.kind == "train") {
      k.check({"name", "kind", "config", "keep", "time", "set"});
    } else if (s.kind == "calibrate") {
      k.check({"name", "kind", "from", "args", "time"});
    } else {
      k.check({"name", "kind", "args", "time"});
    }
    k.str("name");
    k.str("kind");
    k.str("keep");
    s.expected_s = k.duration_s("time");
    if (const toml::node* a = k.get("args")) {
      if (!a->is_array()) bad("\"args\" must be a list of strings");
      for (auto& v : *a->as_array()) {
        if (!v.is_string()) bad("\"args\" must be a list of strings");
        s.args.push_back(resolve_refs(v.as_string()->get(), i, refs, bad));
      }
      for (const auto& x : s.args) {
        const std::string opt = x.substr(0, x.find('='));
        if (opt == "--out" || (s.kind == "calibrate" && opt == "--model"))
          bad("\"args\" must not hold " + opt + ": the runner sets it (" +
              (opt == "--out" ? "the output folder" : "\"from\"") + ")");
      }
      collect_data_refs(json(s.args), data_refs, "args", bad);
    }
    if (s.kind == "train") read_train(st, k, s, i, refs, data_refs);
    if (s.kind == "calibrate") {
      s.from = resolve_refs(*k.str("from", true), i, refs, bad);
      std::vector<std::string> cmd = {"calibrate", "--model", s.from, "--out", r_.model};
      cmd.insert(cmd.end(), s.args.begin(), s.args.end());
      check_parses(spikems_, cmd, bad);
    }
    if (s.kind == "eval") {
      const int maker = model_stage();
      if (int(i) < maker)
        bad("an eval stage scores the recipe's model, which stage \"" +
            r_.stages[size_t(maker)].name + "\" makes later: move it after that stage");
      if (std::find(refs.begin(), refs.end(), maker + 1) == refs.end()) refs.push_back(maker + 1);
      std::vector<std::string> cmd = {"eval", "--model", r_.model, "--out", "x"};
      cmd.insert(cmd.end(), s.args.begin(), s.args.end());
      check_parses(spikems_, cmd, bad);
    }
    refs_.push_back(refs);
    data_refs_.push_back(data_refs);
  }

  void read_train(const toml::table& st, Keys& k, Stage& s, size_t i, std::vector<int>& refs,
                  std::vector<std::string>& data_refs) {
    auto bad = [&](const std::string& why) { k.bad(why); };
    json cfg = json::object();
    if (auto c = k.str("config")) {
      s.config = near_recipe(*c);
      if (!fs::is_regular_file(s.config))
        bad("\"config\" = \"" + *c + "\": no such file (" + s.config + ")");
      if (s.config.size() > 5 && s.config.compare(s.config.size() - 5, 5, ".json") == 0) {
        cfg = read_json(s.config);
        if (!cfg.is_object()) fail(s.config, "", "not a JSON configuration");
      } else {
        try {
          cfg = toml_to_json(toml::parse_file(s.config));
        } catch (const toml::parse_error& e) {
          fail(s.config,
               "line " + std::to_string(e.source().begin.line) + ", column " +
                   std::to_string(e.source().begin.column),
               std::string(e.description()));
        }
      }
    }
    if (const toml::node* set = k.get("set")) {
      if (!set->is_table())
        bad("\"set\" must be a table of trainer keys, e.g. [stage.set] \"optim.steps\" = 300");
      auto put = [&](const std::string& sec, const std::string& key, const toml::node& v) {
        json val = toml_to_json(v);
        std::function<void(json&)> walk = [&](json& j) {
          if (j.is_string())
            j = resolve_refs(j.get<std::string>(), i, refs, bad);
          else if (j.is_structured())
            for (auto& x : j) walk(x);
        };
        walk(val);
        if (!cfg.contains(sec) || !cfg[sec].is_object()) cfg[sec] = json::object();
        cfg[sec][key] = val;
        s.set.push_back({sec, key, val});
      };
      for (auto& [key, v] : *set->as_table()) {
        const std::string kk(key.str());
        const size_t dot = kk.find('.');
        if (dot != kk.npos) {
          put(kk.substr(0, dot), kk.substr(dot + 1), v);
        } else if (v.is_table()) {  // [stage.set] optim.steps = 300 (a dotted key)
          for (auto& [k2, v2] : *v.as_table()) put(kk, std::string(k2.str()), v2);
        } else {
          bad("set: \"" + kk +
              "\" is not a trainer key: write \"section.key\", e.g. \"optim.steps\"");
        }
      }
    }
    s.definition = cfg;
    const train::TrainConfig c =
        train::train_config_from_json(cfg, r_.path + ": at " + s.where, {});
    s.train_config = c.source;
    s.train_steps = c.steps;
    if (s.keep == "best" && c.val.empty())
      bad("keep = \"best\" needs data.val (best.safetensors is the best validation's model); set "
          "data.val or keep = \"last\"");
    collect_data_refs(c.source, data_refs, "", bad);
  }

 public:
  // The stage that writes OUT/<recipe.model>: the calibrate stage, else the last train stage.
  int model_stage() const {
    int last = -1;
    for (size_t i = 0; i < r_.stages.size(); ++i) {
      if (r_.stages[i].kind == "calibrate") return int(i);
      if (r_.stages[i].kind == "train") last = int(i);
    }
    return last;
  }
  std::vector<std::vector<int>> refs_;
  std::vector<std::vector<std::string>> data_refs_;

 private:
  std::string spikems_;
  Recipe r_;
  std::vector<std::string> names_;
};

// The definition a stage's done.json is checked against: what the recipe asks of it, not how
// fast (threads and device are left out, so --threads and --device may change between runs).
// A train stage's is the base configuration with its keys set, not the trainer's resolved one:
// a later spikems with a new key (and its default) still finds its stages done.
std::string stage_hash(const Recipe& r, const Stage& s) {
  json d = {{"kind", s.kind}};
  if (s.kind == "train") {
    json c = s.definition;
    if (c.contains("run") && c["run"].is_object()) {
      c["run"].erase("threads");
      c["run"].erase("device");
    }
    d["config"] = c;
    d["keep"] = s.keep;
  } else {
    d["from"] = s.from;
    d["args"] = s.args;
    d["model"] = r.model;
  }
  return hash_text(d.dump());
}

// ---------------------------------------------------------------- state of OUT

enum class State { kPending, kDone, kResumable, kChanged };

struct StepState {
  State state = State::kPending;
  json done;              // done.json (kDone)
  std::string done_text;  // done.json as found when planning ("" if none)
  std::string kept_hash;
  int64_t step = 0, steps = 0;  // kResumable: the checkpoint's step of the stage's steps
  std::string why;              // kChanged
};

class Runner {
 public:
  Runner(const RecipeRunOptions& o) : o_(o) {}

  void run() {
    install_signals();
    spikems_ = main_exe();
    self_ = self_exe();
    RecipeReader reader(o_.recipe, spikems_);
    r_ = reader.read();
    out_ = fs::absolute(o_.out).lexically_normal();
    threads_ = o_.threads >= 0 ? o_.threads : r_.threads;
    make_steps(reader);
    const int only = o_.stage.empty() ? -1 : index_of(o_.stage, "--stage");
    const int restart = o_.restart.empty() ? -1 : index_of(o_.restart, "--restart");
    root_ = o_.rank == 0;
    if (restart >= 0 && root_ && !o_.list) do_restart(restart);
    plan(root_ || o_.list ? -1 : restart);
    if (o_.list) return list();
    std::vector<std::string> changed;
    for (size_t i = 0; i < steps_.size(); ++i)
      if (st_[i].state == State::kChanged && (only < 0 || int(i) == only))
        changed.push_back("stage \"" + steps_[i].name + "\": " + st_[i].why + ": pass --restart " +
                          steps_[i].name +
                          " to redo it and every later stage, or use another --out");
    if (!changed.empty()) fail(r_.path, "", join(changed, "; "));
    if (only >= 0) check_inputs(only);
    if (root_) {
      fs::create_directories(out_);
      write_if_changed(out_ / (r_.name + ".recipe.toml"), slurp(r_.path));
    }
    const auto t0 = std::chrono::steady_clock::now();
    for (size_t i = 0; i < steps_.size(); ++i) {
      if (only >= 0 && int(i) != only) continue;
      stop_if_interrupted();
      run_step(i);
    }
    bool all = true;
    for (const auto& s : st_) all &= s.state == State::kDone;
    if (!root_) {
      std::fprintf(stderr, "rank %d: recipe %s: my stages are done\n", o_.rank, r_.name.c_str());
      return;
    }
    const double took =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (all) {
      write_summary();
      std::fprintf(stderr, "recipe %s: done (%s in this run); model %s, summary %s\n",
                   r_.name.c_str(), about(took).c_str(), (out_ / r_.model).c_str(),
                   (out_ / (r_.name + ".summary.md")).c_str());
    } else {
      std::fprintf(stderr, "recipe %s: stage %s done (%s); `--list` shows the others\n",
                   r_.name.c_str(), o_.stage.c_str(), about(took).c_str());
    }
  }

 private:
  int index_of(const std::string& name, const char* opt) const {
    for (size_t i = 0; i < steps_.size(); ++i)
      if (steps_[i].name == name) return int(i);
    std::vector<std::string> names;
    for (const auto& s : steps_) names.push_back(s.name);
    fail(opt, name, "no such stage in " + r_.path + " (stages: " + join(names) + ")");
  }

  void make_steps(const RecipeReader& reader) {
    Step d;
    d.name = d.kind = d.folder = "data";
    d.where = "data";
    for (const auto& s : r_.data) d.expected_s += s.expected_s;
    json h = json::object();
    for (const auto& s : r_.data) h[s.name] = s.hash;
    d.hash = hash_text(h.dump());
    steps_.push_back(d);
    const int maker = reader.model_stage();
    for (size_t i = 0; i < r_.stages.size(); ++i) {
      const Stage& s = r_.stages[i];
      Step p;
      p.name = s.name;
      p.kind = s.kind;
      p.where = s.where;
      p.folder = s.kind == "eval" ? "eval/" + s.name : s.name;
      p.kept = s.kept;
      p.hash = stage_hash(r_, s);
      p.expected_s = s.expected_s;
      p.refs = reader.refs_[i];
      p.data_refs = reader.data_refs_[i];
      if (!p.data_refs.empty()) p.refs.insert(p.refs.begin(), 0);
      p.stage = &r_.stages[i];
      p.makes_model = int(i) == maker;
      steps_.push_back(p);
    }
  }

  const DataSet& set_named(const std::string& n) const {
    for (const auto& d : r_.data)
      if (d.name == n) return d;
    fail(r_.path, "", "internal: no data set " + n);
  }

  fs::path done_path(size_t i) const { return out_ / steps_[i].folder / "done.json"; }

  // What a stage read when it ran: the kept files' fingerprints and the data sets' definitions.
  json inputs(size_t i) const {
    json in = json::object();
    for (int r : steps_[i].refs)
      if (r > 0) in["@" + steps_[size_t(r)].name] = st_[size_t(r)].kept_hash;
    for (const auto& d : steps_[i].data_refs) in["data/" + d] = set_named(d).hash;
    return in;
  }

  // --restart NAME: that stage's results go, and every later stage's done.json.
  void do_restart(int k) {
    const Step& s = steps_[size_t(k)];
    std::error_code ec;
    fs::remove_all(out_ / s.folder, ec);
    if (s.kind == "train") fs::remove(out_ / (s.name + ".config.json"), ec);
    for (size_t j = size_t(k) + 1; j < steps_.size(); ++j) fs::remove(done_path(j), ec);
    std::fprintf(stderr, "recipe %s: --restart %s: removed %s and the later stages' done.json\n",
                 r_.name.c_str(), s.name.c_str(), (out_ / s.folder).c_str());
  }

  // Each step's state from OUT. `forget_from` >= 0 (--restart on ranks other than 0, which
  // delete nothing): as if that step's folder and the later steps' done.json were gone.
  void plan(int forget_from) {
    st_.assign(steps_.size(), StepState{});
    for (size_t i = 0; i < steps_.size(); ++i) {
      const Step& s = steps_[i];
      StepState& t = st_[i];
      const bool forgotten = forget_from >= 0 && int(i) >= forget_from;
      const bool wiped = forget_from >= 0 && int(i) == forget_from;
      t.done_text = slurp(done_path(i));
      const json done = forgotten ? json(nullptr) : read_json(done_path(i));
      bool refs_done = true;
      for (int r : s.refs) refs_done &= st_[size_t(r)].state == State::kDone;
      if (s.kind == "data") {
        plan_data(t, done);
        continue;
      }
      const json in = refs_done ? inputs(i) : json(nullptr);
      if (done.is_object()) {
        if (done.value("hash", "") != s.hash) {
          if (refs_done) {
            t.state = State::kChanged;
            t.why = "its definition changed since it was run (" + done_path(i).string() + ")";
          }
        } else if (refs_done && done.value("inputs", json()) == in && !s.kept.empty() &&
                   fs::exists(out_ / s.kept) && (!s.makes_model || fs::exists(out_ / r_.model))) {
          t.state = State::kDone;
        } else if (refs_done && s.kept.empty() && done.value("inputs", json()) == in) {
          t.state = State::kDone;  // eval
        }
        if (t.state == State::kDone) {
          t.done = done;
          t.kept_hash = done.value("kept_hash", "");
        }
      }
      if (s.kind == "train" && t.state == State::kPending && refs_done && !wiped &&
          fs::exists(out_ / s.name / "checkpoint.pt")) {
        const json sj = read_json(out_ / s.name / "stage.json");
        if (sj.is_object() && sj.value("hash", "") != s.hash) {
          t.state = State::kChanged;
          t.why = "its definition changed since its training started (" +
                  (out_ / s.name / "stage.json").string() + ")";
        } else if (sj.is_object() && sj.value("inputs", json()) == in) {
          t.state = State::kResumable;
          t.steps = s.stage->train_steps;
          try {
            t.step = load_model((out_ / s.name / "model.safetensors").string())
                         .training.value("steps", int64_t(0));
          } catch (const std::exception&) {
            t.step = 0;
          }
        }
      }
    }
  }

  void plan_data(StepState& t, const json& done) {
    if (!done.is_object() || !done.contains("sets")) return;
    bool all = true;
    for (const auto& d : r_.data) {
      const json& sets = done["sets"];
      if (!sets.contains(d.name)) {
        all = false;
        continue;
      }
      if (sets[d.name] != d.hash) {
        t.state = State::kChanged;
        t.why = "data set " + d.name + " is defined otherwise than when it was made (" +
                (out_ / "data/done.json").string() + ")";
        return;
      }
      std::error_code ec;
      all &= fs::exists(fs::symlink_status(out_ / "data" / d.name, ec));
    }
    if (all) {
      t.state = State::kDone;
      t.done = done;
    }
  }

  std::string command_for(const std::string& stage) const {
    return shell_line(
        {"spikems", "train", "--recipe", o_.recipe, "--out", o_.out, "--stage", stage});
  }

  // --stage NAME: what it reads must be there.
  void check_inputs(int k) const {
    const Step& s = steps_[size_t(k)];
    for (int r : s.refs) {
      if (r == 0) continue;
      if (st_[size_t(r)].state != State::kDone)
        fail("--stage " + s.name, "",
             "needs " + steps_[size_t(r)].kept + " of stage \"" + steps_[size_t(r)].name +
                 "\", which is not done: make it with: " + command_for(steps_[size_t(r)].name));
    }
    for (const auto& d : s.data_refs) {
      std::error_code ec;
      if (!fs::exists(fs::symlink_status(out_ / "data" / d, ec)))
        fail("--stage " + s.name, "",
             "needs the data set data/" + d +
                 ", which is not made: make the data sets with: " + command_for("data"));
    }
  }

  // ETA: each stage's `time`, scaled by measured / expected of the stages run whole so far.
  double scale() const { return expected_done_ > 0 ? measured_done_ / expected_done_ : 1.0; }
  double left_from(size_t i, bool include_self) const {
    double s = 0;
    for (size_t j = include_self ? i : i + 1; j < steps_.size(); ++j) {
      if (!o_.stage.empty() && steps_[j].name != o_.stage) continue;
      if (st_[j].state != State::kDone) s += steps_[j].expected_s;
    }
    return s * scale();
  }

  std::string tag(size_t i) const {
    return "[" + std::to_string(i + 1) + "/" + std::to_string(steps_.size()) + "]";
  }

  void run_step(size_t i) {
    const Step& s = steps_[i];
    StepState& t = st_[i];
    if (t.state == State::kDone) {
      if (root_)
        std::fprintf(stderr, "%s %s: done (%s)\n", tag(i).c_str(), s.name.c_str(),
                     about(t.done.value("wall_s", 0.0)).c_str());
      return;
    }
    if (!root_ && s.kind != "train") return wait_for(i);
    std::string line = tag(i) + " " + s.name + ": " + s.kind;
    if (t.state == State::kResumable)
      line +=
          " (resuming at step " + std::to_string(t.step) + " of " + std::to_string(t.steps) + ")";
    if (s.expected_s > 0) line += ", ~" + about(s.expected_s * scale());
    const double left = left_from(i, true);
    if (left > 0) line += "; recipe ~" + about(left) + " left";
    if (o_.rank > 0) line = "rank " + std::to_string(o_.rank) + ": " + line;
    std::fprintf(stderr, "%s\n", line.c_str());
    const auto t0 = std::chrono::steady_clock::now();
    const bool whole = t.state == State::kPending;
    if (s.kind == "data") run_data(i);
    if (s.kind == "train") run_train(i);
    if (s.kind == "calibrate") run_calibrate(i);
    if (s.kind == "eval") run_eval(i);
    const double took =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (whole && s.expected_s > 0) {
      measured_done_ += took;
      expected_done_ += s.expected_s;
    }
    if (root_) {
      std::fprintf(stderr, "%s %s: done in %s\n", tag(i).c_str(), s.name.c_str(),
                   about(took).c_str());
    }
    t.state = State::kDone;
  }

  // Ranks other than 0: a non-train stage is rank 0's; wait for its new done.json.
  void wait_for(size_t i) {
    const double limit = std::max({o_.dist_timeout_s, 3600.0, 3 * steps_[i].expected_s});
    std::fprintf(stderr, "rank %d: %s %s: waiting for rank 0 (at most %s)\n", o_.rank,
                 tag(i).c_str(), steps_[i].name.c_str(), about(limit).c_str());
    const auto t0 = std::chrono::steady_clock::now();
    for (;;) {
      const std::string now = slurp(done_path(i));
      if (!now.empty() && now != st_[i].done_text) {
        const json j = read_json(done_path(i));
        if (j.is_object()) {
          st_[i].done = j;
          st_[i].kept_hash = j.value("kept_hash", "");
          return;
        }
      }
      stop_if_interrupted();
      if (std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() > limit)
        fail(done_path(i).string(), "",
             "rank " + std::to_string(o_.rank) + ": rank 0 did not finish stage \"" +
                 steps_[i].name + "\" within " + about(limit) +
                 " (is it running, with the same --out on a shared folder?)");
      std::this_thread::sleep_for(std::chrono::milliseconds(500));
    }
  }

  std::map<std::string, std::string> progress_env(size_t i, const std::string& what) const {
    std::map<std::string, std::string> env;
    env["SPIKEMS_PROGRESS_PREFIX"] =
        "[" + std::to_string(i + 1) + "/" + std::to_string(steps_.size()) + " " + what + "]";
    const double after = left_from(i, false);
    if (after > 0) env["SPIKEMS_PROGRESS_AFTER_S"] = fmt("%.0f", after);
    return env;
  }

  int command_threads() const { return threads_ > 0 ? threads_ : hardware_threads(); }

  // The simulator writes the same files whatever its threads (tests/core/sim/test_determinism),
  // so the data sets may use more threads than the train stages, whose results depend on theirs.
  int data_threads() const {
    if (o_.threads >= 0 || r_.data_threads < 0) return command_threads();
    return r_.data_threads > 0 ? r_.data_threads : hardware_threads();
  }

  void spawn_or_fail(const Step& s, Spawn sp, const std::string& what) {
    sp.cwd = out_.string();
    const int rc = run_child(sp);
    stop_if_interrupted();
    if (rc != 0) {
      std::vector<std::string> shown = sp.argv;
      shown[0] = "spikems";  // spikems-torch runs `spikems train` for it
      fail(r_.path, s.where,
           what + " failed (exit status " + std::to_string(rc) + ") running, in " + out_.string() +
               ": " + shell_line(shown) +
               (s.kind == "train" ? "; the same command again resumes from its last checkpoint"
                                  : ""));
    }
  }

  void write_done(size_t i, double wall_s, const std::string& kept_hash, const fs::path& where) {
    const Step& s = steps_[i];
    ojson d;
    d["stage"] = s.name;
    d["kind"] = s.kind;
    d["kept"] = s.kept;
    d["kept_hash"] = kept_hash;
    d["wall_s"] = wall_s;
    d["hash"] = s.hash;
    d["inputs"] = ordered(inputs(i));
    d["spikems_version"] = SPIKEMS_VERSION;
    d["threads"] = threads_;
    d["finished_unix"] = now_unix();
    write_file_atomic(where.string(), d.dump(2) + "\n");
    st_[i].done = json::parse(d.dump());
    st_[i].kept_hash = kept_hash;
  }

  // ------------------------------------------------------------ data

  void run_data(size_t i) {
    const auto t0 = std::chrono::steady_clock::now();
    const fs::path dir = out_ / "data";
    fs::create_directories(dir);
    json sets = json::object();
    for (const auto& d : r_.data) {
      stop_if_interrupted();
      make_set(i, d);
      sets[d.name] = d.hash;
    }
    ojson done;
    done["stage"] = "data";
    done["kind"] = "data";
    done["sets"] = ordered(sets);
    done["wall_s"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    done["hash"] = steps_[i].hash;
    done["spikems_version"] = SPIKEMS_VERSION;
    done["finished_unix"] = now_unix();
    write_file_atomic(done_path(i).string(), done.dump(2) + "\n");
    st_[i].done = json::parse(done.dump());
  }

  void make_set(size_t i, const DataSet& d) {
    const fs::path dir = out_ / "data", target = dir / d.name,
                   partial = dir / ("." + d.name + ".partial");
    std::error_code ec;
    const bool plain_link = !d.simulated && d.downsample == 1 && !is_plain_folder(d.path);
    if (plain_link) {  // linked as it is: any source load_sequence reads
      fs::remove_all(partial, ec);
      fs::create_symlink(d.path, partial);
      if (fs::is_directory(fs::symlink_status(target, ec)) && !fs::is_symlink(target))
        fs::remove_all(target, ec);
      fs::rename(partial, target);
      std::fprintf(stderr, "  data/%s -> %s\n", d.name.c_str(), d.path.c_str());
      return;
    }
    const json rec = read_json(target / "recipe-set.json");
    if (rec.is_object() && rec.value("hash", "") == d.hash) {
      std::fprintf(stderr, "  data/%s: kept (made earlier)\n", d.name.c_str());
      return;
    }
    fs::remove_all(partial, ec);
    const std::string res =
        d.downsample > 1 ? " at 1/" + std::to_string(d.downsample) + " resolution" : "";
    std::fprintf(stderr, "  data/%s: %s%s\n", d.name.c_str(), d.describe.c_str(), res.c_str());
    if (!d.from.empty()) {
      downsample_simulated(i, d, dir / d.from, partial);
    } else if (d.simulated) {
      const fs::path sim = d.downsample > 1 ? dir / ("." + d.name + ".sim.partial") : partial;
      fs::remove_all(sim, ec);
      Spawn sp;
      sp.argv = {spikems_, "simulate"};
      sp.argv.insert(sp.argv.end(), d.sim_args.begin(), d.sim_args.end());
      sp.argv.insert(sp.argv.end(), {"--threads", std::to_string(data_threads()), "--out",
                                     fs::relative(sim, out_).string()});
      if (o_.quiet) sp.argv.push_back("--no-progress");
      sp.env = progress_env(i, "data " + d.name);
      spawn_or_fail(steps_[i], sp, "simulating data set " + d.name);
      if (d.downsample > 1) {
        downsample_simulated(i, d, sim, partial);
        fs::remove_all(sim, ec);
      }
    } else {
      rewrite_set(d, partial);
    }
    ojson r;
    r["set"] = d.name;
    r["hash"] = d.hash;
    r["made_by"] = "spikems train --recipe";
    if (d.simulated && d.from.empty()) r["threads"] = data_threads();
    r["spikems_version"] = SPIKEMS_VERSION;
    write_file_atomic((partial / "recipe-set.json").string(), r.dump(2) + "\n");
    fs::remove_all(target, ec);
    fs::rename(partial, target);
  }

  static bool is_plain_folder(const std::string& p) {
    std::error_code ec;
    if (!fs::is_directory(p, ec) || fs::exists(fs::path(p) / "manifest.json", ec)) return false;
    try {
      detect_format(p);  // an EV-IMO / EVIMO2 folder is one recording
      return false;
    } catch (const Error&) {
      return true;
    }
  }

  // `spikems convert --downsample F` on every sequence; the manifest copied, sensor sizes
  // divided (rounded up, as convert's pixel = floor(coord / F) gives).
  void downsample_simulated(size_t i, const DataSet& d, const fs::path& sim, const fs::path& dst) {
    fs::create_directories(dst);
    json m = read_json(sim / "manifest.json");
    if (!m.is_object()) fail((sim / "manifest.json").string(), "", "missing or not JSON");
    const int f = d.downsample;
    auto shrink = [f](json& wh) {
      if (wh.is_array() && wh.size() == 2 && wh[0].is_number_integer())
        wh = {(wh[0].get<int>() + f - 1) / f, (wh[1].get<int>() + f - 1) / f};
      else if (wh.is_array())
        for (auto& x : wh) x = json{(x[0].get<int>() + f - 1) / f, (x[1].get<int>() + f - 1) / f};
    };
    std::vector<std::string> files;
    for (auto& q : m["sequences"]) {
      files.push_back(q["file"].get<std::string>());
      if (q.contains("sensor")) shrink(q["sensor"]);
    }
    shrink(m["sensor"]);
    m["config"] = m.value("config", std::string()) + "; convert --downsample " + std::to_string(f);
    for (const auto& name : files) {
      stop_if_interrupted();
      Spawn sp;
      sp.argv = {spikems_,
                 "convert",
                 fs::relative(sim / name, out_).string(),
                 fs::relative(dst / name, out_).string(),
                 "--downsample",
                 std::to_string(f),
                 "-q"};
      spawn_or_fail(steps_[i], sp, "downsampling data set " + d.name);
    }
    write_file_atomic((dst / "manifest.json").string(), m.dump(2) + "\n");
  }

  // A user's labelled data as a simulator-style folder: 0/1 labels (mask frames turned into
  // labels as training does), at 1/downsample resolution, seq_NNNN.h5 and a manifest. A
  // simulator folder keeps its splits; anything else is all "train" (use split "all").
  void rewrite_set(const DataSet& d, const fs::path& dst) {
    std::vector<std::pair<std::string, std::string>> files;  // (file, split)
    std::error_code ec;
    if (fs::is_directory(d.path, ec) && fs::exists(fs::path(d.path) / "manifest.json", ec)) {
      for (const char* split : {"train", "val", "test"}) {
        DatasetSource src;
        src.path = d.path;
        src.split = split;
        try {
          for (const auto& f : sequence_files(src)) files.push_back({f, split});
        } catch (const Error&) {  // an empty split
        }
      }
    } else if (is_plain_folder(d.path)) {
      std::vector<std::string> found;
      for (const auto& e : fs::directory_iterator(d.path))
        if (e.is_regular_file() && e.path().filename().string()[0] != '.')
          found.push_back(e.path().string());
      std::sort(found.begin(), found.end());
      for (const auto& f : found) files.push_back({f, "train"});
    } else {
      files.push_back({d.path, "train"});
    }
    if (files.empty()) fail(d.path, "", "holds no sequences");
    fs::create_directories(dst);
    json splits = {{"train", json::array()}, {"val", json::array()}, {"test", json::array()}};
    json seqs = json::array();
    std::vector<std::pair<int, int>> sizes;
    BinningConfig geo;
    geo.downsample = d.downsample;
    for (size_t k = 0; k < files.size(); ++k) {
      stop_if_interrupted();
      LabelledSequence s = load_sequence(files[k].first, d.mask_dilation);
      Recording rec;
      rec.events = d.downsample > 1 ? remap_events(s.events, geo) : std::move(s.events);
      char name[32];
      std::snprintf(name, sizeof name, "seq_%04zu.h5", k);
      write_recording((dst / name).string(), rec);
      const std::pair<int, int> wh{rec.events.sensor.width, rec.events.sensor.height};
      if (std::find(sizes.begin(), sizes.end(), wh) == sizes.end()) sizes.push_back(wh);
      splits[files[k].second].push_back(name);
      seqs.push_back({{"file", name},
                      {"index", k},
                      {"source", files[k].first},
                      {"events", rec.events.size()},
                      {"sensor", {wh.first, wh.second}},
                      {"split", files[k].second}});
    }
    ojson m;
    m["generator"] = "spikems train --recipe";
    m["source"] = d.path;
    m["downsample"] = d.downsample;
    m["labels"] = "0/1 (1 = moving)";
    if (sizes.size() == 1) {
      m["sensor"] = {sizes[0].first, sizes[0].second};
    } else {
      std::sort(sizes.begin(), sizes.end());
      m["sensor"] = ojson::array();
      for (auto [w, h] : sizes) m["sensor"].push_back({w, h});
    }
    m["format"] = "spikems-h5";
    m["splits"] = ordered(splits);
    m["sequences"] = ordered(seqs);
    write_file_atomic((dst / "manifest.json").string(), m.dump(2) + "\n");
  }

  // ------------------------------------------------------------ train, calibrate, eval

  void run_train(size_t i) {
    const Step& s = steps_[i];
    const Stage& st = *s.stage;
    const fs::path folder = out_ / s.name;
    const std::string cfg_name = s.name + ".config.json";
    write_if_changed(out_ / cfg_name, st.train_config.dump(2) + "\n");
    const bool resume = st_[i].state == State::kResumable;
    if (root_ && !resume) {  // a fresh start: nothing of an older attempt is left
      std::error_code ec;
      fs::remove_all(folder, ec);
      fs::create_directories(folder);
      ojson sj;
      sj["hash"] = s.hash;
      sj["inputs"] = ordered(inputs(i));
      write_file_atomic((folder / "stage.json").string(), sj.dump(2) + "\n");
    }
    Spawn sp;
    sp.argv = {self_, "train"};
    if (resume)
      sp.argv.insert(sp.argv.end(), {"--resume", s.name});
    else
      sp.argv.insert(sp.argv.end(), {"--config", cfg_name, "--out", s.name});
    sp.argv.insert(sp.argv.end(), {"--threads", std::to_string(threads_)});
    if (!o_.device.empty()) sp.argv.insert(sp.argv.end(), {"--device", o_.device});
    if (o_.quiet) sp.argv.push_back("-q");
    if (o_.world_size > 1) {
      // Consecutive stages on consecutive ports: a store still closing never blocks the next.
      const int port = o_.master_port + int(i);
      if (port > 65535)
        fail("--master-port", std::to_string(o_.master_port),
             "plus the stage index passes 65535: choose a lower port");
      sp.argv.insert(sp.argv.end(), {"--world-size", std::to_string(o_.world_size), "--rank",
                                     std::to_string(o_.rank), "--master-port", std::to_string(port),
                                     "--dist-timeout", fmt("%g", o_.dist_timeout_s)});
      if (!o_.master_addr.empty()) sp.argv.insert(sp.argv.end(), {"--master-addr", o_.master_addr});
    }
    sp.env = progress_env(i, s.name);
    const auto t0 = std::chrono::steady_clock::now();
    spawn_or_fail(s, sp, "training");
    if (!root_) return;
    int64_t steps = -1;
    double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    try {
      const ModelSpec m = load_model((folder / "model.safetensors").string());
      steps = m.training.value("steps", int64_t(-1));
      wall = std::max(wall, m.training.value("wall_seconds", 0.0));
    } catch (const std::exception& e) {
      fail(r_.path, s.where, std::string("the trained model is unreadable: ") + e.what());
    }
    if (steps < st.train_steps)
      fail(r_.path, s.where,
           "training stopped at step " + std::to_string(steps) + " of " +
               std::to_string(st.train_steps) +
               "; run the same command again to continue from its checkpoint");
    if (!fs::exists(out_ / s.kept)) fail(r_.path, s.where, "training left no " + s.kept);
    if (s.makes_model) copy_atomic(out_ / s.kept, out_ / r_.model);
    write_done(i, wall, hash_file((out_ / s.kept).string()), folder / "done.json");
  }

  static void copy_atomic(const fs::path& from, const fs::path& to) {
    AtomicFile f(to.string());
    f.write(slurp(from));
    f.commit();
  }

  void run_calibrate(size_t i) {
    const Step& s = steps_[i];
    const fs::path folder = out_ / s.name;
    fs::create_directories(folder);
    Spawn sp;
    sp.argv = {spikems_, "calibrate", "--model", s.stage->from, "--out", r_.model};
    sp.argv.insert(sp.argv.end(), s.stage->args.begin(), s.stage->args.end());
    sp.argv.insert(sp.argv.end(), {"--threads", std::to_string(command_threads())});
    if (o_.quiet) sp.argv.push_back("--quiet");
    const fs::path table = folder / "calibration.txt";
    sp.stdout_path = table.string() + ".partial";
    sp.env = progress_env(i, s.name);
    const auto t0 = std::chrono::steady_clock::now();
    spawn_or_fail(s, sp, "calibration");
    fs::rename(sp.stdout_path, table);
    const double wall =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    write_done(i, wall, hash_file((out_ / r_.model).string()), folder / "done.json");
  }

  void run_eval(size_t i) {
    const Step& s = steps_[i];
    const fs::path folder = out_ / s.folder, partial = out_ / "eval" / ("." + s.name + ".partial");
    std::error_code ec;
    fs::remove_all(partial, ec);
    fs::create_directories(partial);
    Spawn sp;
    sp.argv = {spikems_, "eval", "--model", r_.model};
    sp.argv.insert(sp.argv.end(), s.stage->args.begin(), s.stage->args.end());
    sp.argv.insert(sp.argv.end(), {"--out", fs::relative(partial, out_).string(), "--threads",
                                   std::to_string(command_threads())});
    if (o_.quiet) sp.argv.push_back("--quiet");
    sp.env = progress_env(i, s.name);
    const auto t0 = std::chrono::steady_clock::now();
    spawn_or_fail(s, sp, "evaluation");
    const double wall =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    write_done(i, wall, hash_file((partial / "results.json").string()), partial / "done.json");
    fs::remove_all(folder, ec);
    fs::rename(partial, folder);
  }

  // ------------------------------------------------------------ --list and the summary

  void list() const {
    std::printf("recipe %s (%s), output %s: %zu stages\n", r_.name.c_str(), r_.path.c_str(),
                out_.c_str(), steps_.size());
    for (size_t i = 0; i < steps_.size(); ++i) {
      const StepState& t = st_[i];
      std::string state;
      switch (t.state) {
        case State::kDone:
          state = "done in " + about(t.done.value("wall_s", 0.0));
          break;
        case State::kResumable:
          state = "resumable at step " + std::to_string(t.step) + " of " + std::to_string(t.steps);
          break;
        case State::kChanged:
          state = "changed: " + t.why + "; --restart " + steps_[i].name;
          break;
        case State::kPending:
          state = "pending";
          break;
      }
      std::string eta = steps_[i].expected_s > 0 ? "~" : "-";
      if (steps_[i].expected_s > 0) eta += about(steps_[i].expected_s);
      std::printf("  %-7s %-16s %-9s %-9s %s\n", tag(i).c_str(), steps_[i].name.c_str(),
                  steps_[i].kind.c_str(), eta.c_str(), state.c_str());
    }
  }

  // Scores of an eval stage's results.json: one row per model and data set.
  static std::vector<ojson> score_rows(const std::string& stage, const json& res) {
    std::vector<ojson> rows;
    if (!res.is_object()) return rows;
    for (const auto& m : res.value("models", json::array())) {
      // The file name: a trained model's own name is its run folder's.
      const std::string model = fs::path(m.value("model", std::string())).filename().string();
      for (const auto& d : m.value("datasets", json::array())) {
        ojson r;
        r["eval"] = stage;
        r["model"] = model;
        r["data"] = d.value("data", std::string());
        r["split"] = ordered(d.value("split", json()));
        r["windows_ms"] = ojson::array();
        r["iou"] = ojson::array();
        r["detection"] = ojson::array();
        for (const auto& w : d.value("windows", json::array())) {
          if (!w.value("filter", json()).is_null()) continue;  // Kalman rows
          r["windows_ms"].push_back(w.value("window_ms", 0.0));
          r["iou"].push_back(ordered(w.value("iou_mean", json())));
          r["detection"].push_back(ordered(w.value("detection_rate", json())));
        }
        rows.push_back(r);
      }
    }
    return rows;
  }

  void write_summary() const {
    ojson j;
    j["recipe"] = r_.name;
    j["summary"] = r_.summary;
    j["model"] = r_.model;
    j["spikems_version"] = SPIKEMS_VERSION;
    j["hardware"] = {{"cpu", cpu_name()},
                     {"threads", threads_ > 0 ? threads_ : hardware_threads()}};
    if (!o_.device.empty()) j["hardware"]["device"] = o_.device;
    if (o_.world_size > 1) j["hardware"]["world_size"] = o_.world_size;
    double total = 0;
    j["stages"] = ojson::array();
    std::string md = "# Recipe " + r_.name + "\n\n";
    if (!r_.summary.empty()) md += r_.summary + "\n\n";
    md += "Made with `spikems train --recipe " + r_.name +
          ".recipe.toml --out OUT` (spikems " SPIKEMS_VERSION "). Model: `" + r_.model +
          "`. Hardware: " + j["hardware"]["cpu"].get<std::string>() + ", " +
          std::to_string(j["hardware"]["threads"].get<int>()) + " thread(s)" +
          (o_.device.empty() ? "" : ", device " + o_.device) +
          (o_.world_size > 1 ? ", " + std::to_string(o_.world_size) + " ranks" : "") + ".\n\n";
    md += "| stage | kind | kept | wall time |\n|---|---|---|---|\n";
    for (size_t i = 0; i < steps_.size(); ++i) {
      const double w = st_[i].done.value("wall_s", 0.0);
      total += w;
      std::string kept = steps_[i].kept;
      if (steps_[i].kind == "data") {
        std::vector<std::string> sets;
        for (const auto& d : r_.data) sets.push_back("data/" + d.name);
        kept = join(sets);
      }
      if (steps_[i].kind == "eval") kept = steps_[i].folder + "/";
      j["stages"].push_back(
          {{"stage", steps_[i].name}, {"kind", steps_[i].kind}, {"kept", kept}, {"wall_s", w}});
      md += "| " + steps_[i].name + " | " + steps_[i].kind + " | " +
            (kept.empty() ? "" : "`" + join(split_list(kept), "`, `") + "`") + " | " +
            wall_text(w) + " |\n";
    }
    j["total_wall_s"] = total;
    md += "\nTotal wall time: " + wall_text(total) + ".\n";
    j["scores"] = ojson::array();
    std::string table;
    auto cells = [](const ojson& a, const char* f) {
      std::vector<std::string> v;
      for (const auto& x : a) v.push_back(x.is_number() ? fmt(f, x.get<double>()) : "-");
      return join(v, " / ");
    };
    for (size_t i = 0; i < steps_.size(); ++i) {
      if (steps_[i].kind != "eval") continue;
      for (const auto& r :
           score_rows(steps_[i].name, read_json(out_ / steps_[i].folder / "results.json"))) {
        j["scores"].push_back(r);
        table += "| " + r["eval"].get<std::string>() + " | " + r["model"].get<std::string>() +
                 " | " + r["data"].get<std::string>() + " | " + cells(r["windows_ms"], "%g") +
                 " | " + cells(r["iou"], "%.1f") + " | " + cells(r["detection"], "%.1f") + " |\n";
      }
    }
    if (!table.empty())
      md +=
          "\n## Scores\n\nIoU and detection rate in %, at each window length (`spikems eval`; "
          "each eval stage's results in `eval/NAME/`).\n\n"
          "| eval | model | data | windows ms | IoU % | detection % |\n"
          "|---|---|---|---|---|---|\n" +
          table;
    // Named after the recipe: recipes that share an OUT each keep their own.
    write_file_atomic((out_ / (r_.name + ".summary.json")).string(), j.dump(2) + "\n");
    write_file_atomic((out_ / (r_.name + ".summary.md")).string(), md);
  }

  const RecipeRunOptions& o_;
  Recipe r_;
  fs::path out_;
  std::string spikems_, self_;
  int threads_ = 1;
  bool root_ = true;
  std::vector<Step> steps_;
  std::vector<StepState> st_;
  double measured_done_ = 0, expected_done_ = 0;
};

}  // namespace

void run_recipe(const RecipeRunOptions& o) {
  Runner(o).run();
}

}  // namespace spikems::cli
