// `spikems info FILE...`: what is in an event file, read chunk by chunk in bounded memory, or
// what a model file (.safetensors) holds.
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cinttypes>
#include <cstdio>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>

#include "cli/command.h"
#include "core/events/io.h"
#include "core/model/model_summary.h"
#include "core/util/duration.h"
#include "core/util/error.h"
#include "core/util/interrupt.h"
#include "core/util/progress.h"

namespace {

using spikems::EventStream;

struct InfoArgs {
  std::vector<std::string> files;
  spikems::cli::ReadFlags read;
  bool json = false;
};

// Statistics gathered while streaming.
struct Stats {
  std::string format;
  spikems::SensorSize sensor;
  uint64_t events = 0, on = 0;
  int64_t t_first = 0, t_last = 0, t_min = INT64_MAX, t_max = INT64_MIN;
  int max_x = -1, max_y = -1;
  bool has_labels = false;
  std::map<uint16_t, uint64_t> per_label;
  spikems::Recording extras;  // masks, intrinsics, metadata (events left empty)
};

Stats gather(const std::string& path, const spikems::ReadOptions& ro) {
  Stats s;
  auto reader = spikems::open_reader(path, ro);
  s.format = reader->format_name();
  struct stat st {};
  bool big = ::stat(path.c_str(), &st) == 0 && st.st_size > (64 << 20);
  spikems::ProgressBar bar("info " + path, 0, "ev", big && isatty(fileno(stderr)));
  EventStream chunk;
  std::vector<uint64_t> label_count(65536, 0);
  while (true) {
    chunk.clear();
    size_t n = reader->read(chunk, spikems::kReadChunk);
    if (n == 0) break;
    if (spikems::interrupted()) spikems::fail(path, "", "interrupted");
    if (s.events == 0) s.t_first = chunk.t.front();
    s.t_last = chunk.t.back();
    for (size_t i = 0; i < n; ++i) {
      s.on += chunk.p[i];
      s.t_min = std::min(s.t_min, chunk.t[i]);
      s.t_max = std::max(s.t_max, chunk.t[i]);
      s.max_x = std::max<int>(s.max_x, chunk.x[i]);
      s.max_y = std::max<int>(s.max_y, chunk.y[i]);
    }
    if (chunk.has_labels()) {
      s.has_labels = true;
      for (size_t i = 0; i < n; ++i) ++label_count[chunk.label[i]];
    }
    s.events += n;
    bar.update(s.events);
  }
  bar.finish();
  s.sensor = reader->sensor();
  if (!s.sensor.known() && chunk.sensor.known()) s.sensor = chunk.sensor;
  reader->read_extras(s.extras);
  for (size_t id = 0; id < label_count.size(); ++id)
    if (label_count[id]) s.per_label[uint16_t(id)] = label_count[id];
  return s;
}

bool is_moving(const Stats& s, uint16_t id) {
  if (id == 0) return false;
  const auto& m = s.extras.moving_ids;
  return m.empty() || std::find(m.begin(), m.end(), id) != m.end();
}

nlohmann::json to_json(const std::string& path, const Stats& s) {
  nlohmann::json j;
  j["file"] = path;
  j["format"] = s.format;
  j["width"] = s.sensor.width;
  j["height"] = s.sensor.height;
  j["events"] = s.events;
  if (s.events) {
    double dur = double(s.t_max - s.t_min) * 1e-6;
    j["t_first_us"] = s.t_first;
    j["t_last_us"] = s.t_last;
    j["t_min_us"] = s.t_min;
    j["t_max_us"] = s.t_max;
    j["duration_s"] = dur;
    j["rate_ev_per_s"] = dur > 0 ? double(s.events) / dur : 0.0;
    j["on_fraction"] = double(s.on) / double(s.events);
    j["max_x"] = s.max_x;
    j["max_y"] = s.max_y;
  }
  j["labelled"] = s.has_labels;
  if (s.has_labels) {
    nlohmann::json per = nlohmann::json::object();
    uint64_t fg = 0;
    for (auto [id, n] : s.per_label) {
      per[std::to_string(id)] = n;
      if (is_moving(s, id)) fg += n;
    }
    j["events_per_label"] = per;
    j["foreground_fraction"] = s.events ? double(fg) / double(s.events) : 0.0;
  }
  j["moving_ids"] = s.extras.moving_ids;
  const auto& m = s.extras.masks;
  j["mask_frames"] = m.size();
  if (m.size() >= 2) {
    double span = double(m.back().t_us - m.front().t_us) * 1e-6;
    j["mask_rate_hz"] = span > 0 ? double(m.size() - 1) / span : 0.0;
    j["mask_t_first_us"] = m.front().t_us;
    j["mask_t_last_us"] = m.back().t_us;
  }
  if (s.extras.intrinsics && s.extras.intrinsics->known()) {
    const auto& k = *s.extras.intrinsics;
    j["intrinsics"] = {
        {"fx", k.fx}, {"fy", k.fy}, {"cx", k.cx}, {"cy", k.cy}, {"distortion", k.distortion}};
  }
  j["poses"] = s.extras.poses.size();
  return j;
}

void print_text(const std::string& path, const Stats& s) {
  std::printf("%s\n", path.c_str());
  std::printf("  format        %s\n", s.format.c_str());
  if (s.sensor.known())
    std::printf("  resolution    %d x %d\n", s.sensor.width, s.sensor.height);
  else
    std::printf("  resolution    unknown (largest x, y seen: %d, %d)\n", s.max_x, s.max_y);
  std::printf("  events        %" PRIu64 " (%s)\n", s.events,
              spikems::human_count(double(s.events)).c_str());
  if (s.events) {
    double dur = double(s.t_max - s.t_min) * 1e-6;
    std::printf("  time          %" PRId64 " us .. %" PRId64 " us\n", s.t_min, s.t_max);
    std::printf("  duration      %s\n", spikems::format_duration_us(s.t_max - s.t_min).c_str());
    std::printf("  rate          %s ev/s\n",
                dur > 0 ? spikems::human_count(double(s.events) / dur).c_str() : "-");
    std::printf("  polarity      %.1f %% ON, %.1f %% OFF\n",
                100.0 * double(s.on) / double(s.events),
                100.0 * double(s.events - s.on) / double(s.events));
  }
  if (s.has_labels) {
    uint64_t fg = 0;
    std::printf("  labels        events per object id:");
    for (auto [id, n] : s.per_label) {
      std::printf(" %u:%" PRIu64, unsigned(id), n);
      if (is_moving(s, id)) fg += n;
    }
    std::printf("\n  foreground    %.2f %% of events%s\n",
                s.events ? 100.0 * double(fg) / double(s.events) : 0.0,
                s.extras.moving_ids.empty() ? " (every non-zero id)" : " (moving ids only)");
  } else {
    std::printf("  labels        none\n");
  }
  if (!s.extras.moving_ids.empty()) {
    std::printf("  moving ids   ");
    for (auto id : s.extras.moving_ids) std::printf(" %u", unsigned(id));
    std::printf("\n");
  }
  const auto& m = s.extras.masks;
  if (m.empty()) {
    std::printf("  mask frames   none\n");
  } else if (m.size() == 1) {
    std::printf("  mask frames   1 (t = %" PRId64 " us)\n", m.front().t_us);
  } else {
    double span = double(m.back().t_us - m.front().t_us) * 1e-6;
    std::printf("  mask frames   %zu (%.1f Hz, %" PRId64 " us .. %" PRId64 " us)\n", m.size(),
                span > 0 ? double(m.size() - 1) / span : 0.0, m.front().t_us, m.back().t_us);
  }
  if (s.extras.intrinsics && s.extras.intrinsics->known()) {
    const auto& k = *s.extras.intrinsics;
    std::printf("  intrinsics    fx %.3f fy %.3f cx %.3f cy %.3f", k.fx, k.fy, k.cx, k.cy);
    if (!k.distortion.empty()) {
      std::printf(", distortion");
      for (double d : k.distortion) std::printf(" %.5g", d);
    }
    std::printf("\n");
  }
  if (!s.extras.poses.empty()) std::printf("  poses         %zu samples\n", s.extras.poses.size());
}

void add(CLI::App& app) {
  static InfoArgs args;
  auto* cmd = app.add_subcommand(
      "info",
      "Describe event files: format, resolution, event count, duration, rate, polarity balance, "
      "labels, mask frames, intrinsics (streams the file: bounded memory); or model files "
      "(.safetensors): layers, time step, output threshold and gate, calibration, training");
  cmd->add_option("files", args.files, "Event files, dataset folders or model files")->required();
  cmd->add_flag("--json", args.json, "Print one JSON object per file (a JSON array)");
  spikems::cli::add_read_flags(cmd, args.read);
  cmd->footer(
      "Examples:\n  spikems info recording.raw\n"
      "  spikems info events.txt --width 346 --height 260 --json\n"
      "  spikems info models/spikems-default.safetensors");
  cmd->callback([] {
    spikems::install_interrupt_flag();
    spikems::ReadOptions ro;
    ro.mask_planes = false;  // the frames' count and times, not their pixels
    ro.sort = args.read.sort;
    ro.time_unit = args.read.time_unit;
    ro.format = args.read.format;
    ro.sensor = {args.read.width, args.read.height};
    if (!ro.sensor.known()) ro.sensor = {};
    nlohmann::json all = nlohmann::json::array();
    int failed = 0;
    for (size_t i = 0; i < args.files.size(); ++i) {
      const auto& f = args.files[i];
      try {
        if (f.size() > 12 && f.compare(f.size() - 12, 12, ".safetensors") == 0) {
          const spikems::ModelSpec m = spikems::load_model(f);  // validates, names the file
          if (args.json) {
            nlohmann::json j = spikems::model_summary(m);
            j["file"] = f;
            all.push_back(std::move(j));
          } else {
            if (i) std::printf("\n");
            std::fputs(spikems::model_summary_text(f, m).c_str(), stdout);
          }
          continue;
        }
        Stats s = gather(f, ro);
        if (args.json)
          all.push_back(to_json(f, s));
        else {
          if (i) std::printf("\n");
          print_text(f, s);
        }
      } catch (const spikems::Error& e) {
        std::fflush(stdout);
        std::cerr << "spikems: error: " << e.what() << "\n";
        ++failed;
      }
    }
    if (args.json) std::printf("%s\n", all.dump(2).c_str());
    std::fflush(stdout);
    if (failed) throw CLI::RuntimeError(1);
  });
}

}  // namespace

SPIKEMS_COMMAND(info, 10, add);
