#include "core/eval/evaluation.h"

#include <filesystem>

#include "core/dataset/sequence.h"
#include "core/eval/sequence_scorer.h"
#include "core/util/error.h"
#include "core/util/interrupt.h"
#include "core/util/progress.h"

namespace spikems {

namespace fs = std::filesystem;

EvalResults evaluate(const EvalOptions& opt) {
  if (opt.model_path.empty()) fail("spikems eval", "", "no model given (--model FILE)");
  if (opt.data.empty()) fail("spikems eval", "", "no data given (--data PATH)");
  ModelSpec model = load_model(opt.model_path);
  if (opt.iir) model = with_iir_neurons(std::move(model), opt.model_path);
  check_windows(opt.windows_us, time_step_us(model), opt.model_path);

  // Every source's sequence list first, so that a bad path or an empty split fails at once.
  struct Source {
    DatasetSource src;
    std::vector<std::string> files;
    bool folder = false;  // a simulator folder with splits
  };
  std::vector<Source> sources;
  size_t total = 0;
  for (const auto& path : opt.data) {
    Source s;
    s.src.path = path;
    s.src.split = opt.split;
    s.files = sequence_files(s.src);
    s.folder = !(s.files.size() == 1 && s.files[0] == path);
    total += s.files.size();
    sources.push_back(std::move(s));
  }

  EvalResults r;
  r.command_line = opt.command_line;
  r.date = utc_now_iso8601();
  std::error_code ec;
  r.working_directory = fs::current_path(ec).string();
  r.max_seconds = opt.max_seconds;
  r.windows_us = opt.windows_us;
  ModelResult m;
  m.path = opt.model_path;
  m.name = model.name;
  m.time_step_ms = double(time_step_us(model)) / 1000.0;
  m.iir = opt.iir;

  ProgressBar bar("eval", total, "seq", opt.progress);
  SequenceScoreOptions so;
  so.threads = opt.threads;
  so.max_us = opt.max_seconds > 0 ? int64_t(opt.max_seconds * 1e6 + 0.5) : 0;
  size_t done = 0;
  for (const auto& s : sources) {
    std::vector<SequenceScore> scores;
    for (const auto& f : s.files) {
      if (interrupted()) break;
      const std::string name = fs::path(f).filename().string();
      bar.set_status(name + " loading");
      bar.update(done);
      const LabelledSequence seq = load_sequence(f, s.src.mask_dilation);
      const uint64_t n = seq.events.size();
      so.progress = [&](uint64_t k) {
        bar.set_status(name + " " + std::to_string(n ? 100 * k / n : 100) + " %");
        bar.update(done);
        return !interrupted();
      };
      SequenceScore sc = score_sequence(model, seq, opt.windows_us, so);
      if (!sc.complete) break;
      scores.push_back(std::move(sc));
      bar.update(++done);
    }
    if (!scores.empty() || !interrupted())
      m.datasets.push_back(dataset_result(s.src.path, s.folder ? opt.split : "", scores));
    if (interrupted()) {
      r.interrupted = true;
      break;
    }
  }
  bar.set_status("");
  bar.finish();
  r.models.push_back(std::move(m));
  return r;
}

}  // namespace spikems
