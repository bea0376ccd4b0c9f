// `spikems render FILE --from T --window DT --out frame.png`: one event frame, with the ground
// truth outlined, to look at data and labels.
#include <algorithm>
#include <cstdio>

#include "cli/command.h"
#include "core/events/io.h"
#include "core/events/labels.h"
#include "core/util/duration.h"
#include "core/util/error.h"
#include "core/viz/event_frame.h"

namespace {

using spikems::EventStream;

struct RenderArgs {
  std::string file, from = "0", window = "10ms", out;
  int scale = 1;
  bool labels = false, mask_from_labels = false, no_outline = false, absolute = false;
  spikems::cli::ReadFlags read;
};

// Footprint of the labelled (moving) events of a window as a mask frame.
spikems::MaskFrame label_footprint(const EventStream& ev, const std::vector<uint16_t>& moving,
                                   spikems::SensorSize s) {
  spikems::MaskFrame m;
  m.width = s.width;
  m.height = s.height;
  m.ids.assign(size_t(s.width) * size_t(s.height), 0);
  for (size_t i = 0; i < ev.size(); ++i) {
    uint16_t id = ev.label[i];
    if (id == 0 || (!moving.empty() && std::find(moving.begin(), moving.end(), id) == moving.end()))
      continue;
    m.ids[size_t(ev.y[i]) * size_t(s.width) + ev.x[i]] = id;
  }
  return m;
}

void run(const RenderArgs& a) {
  int64_t from = spikems::parse_duration_us(a.from);
  int64_t window = spikems::parse_duration_us(a.window);
  if (window <= 0) spikems::fail(a.file, "", "--window must be positive (got " + a.window + ")");
  spikems::ReadOptions ro;
  ro.sort = a.read.sort;
  ro.time_unit = a.read.time_unit;
  ro.format = a.read.format;
  if (a.read.width > 0 && a.read.height > 0) ro.sensor = {a.read.width, a.read.height};
  auto reader = spikems::open_reader(a.file, ro);

  // Stream until the window has passed (time-ordered input); --sort reads everything.
  EventStream win, chunk;
  int64_t t0 = 0, t1 = 0;
  bool have_base = false;
  uint64_t total = 0;
  while (true) {
    chunk.clear();
    if (reader->read(chunk, spikems::kReadChunk) == 0) break;
    if (a.read.sort) {
      win.append(chunk);
      continue;
    }
    if (!have_base) {
      int64_t base = a.absolute ? 0 : chunk.t.front();
      t0 = base + from;
      t1 = t0 + window;
      have_base = true;
    }
    total += chunk.size();
    auto [b, e] = chunk.time_range(t0, t1);
    win.append(chunk, b, e);
    if (chunk.t.back() >= t1) break;
  }
  if (a.read.sort) {
    win.sort_by_time();
    int64_t base = a.absolute || win.empty() ? 0 : win.t.front();
    t0 = base + from;
    t1 = t0 + window;
    total = win.size();
    win = win.slice_time(t0, t1);
  }
  spikems::SensorSize sensor = reader->sensor();
  if (!sensor.known()) sensor = chunk.sensor.known() ? chunk.sensor : win.sensor;
  if (!sensor.known()) spikems::fail(a.file, "", "sensor size unknown; pass --width and --height");
  win.sensor = sensor;
  if (total == 0) spikems::fail(a.file, "", "the file holds no events");

  spikems::Recording extras;
  reader->read_extras(extras);
  const auto& moving = extras.moving_ids;
  // Labels for the tint: the file's own, else derived from the mask frames.
  if (a.labels && !win.has_labels() && !extras.masks.empty() && !win.empty()) {
    spikems::LabelOptions lo;
    lo.moving_ids = moving;
    spikems::label_from_masks(win, extras.masks, lo);
  }
  // The outline: nearest mask frame to the window centre, or the footprint of labelled events.
  spikems::MaskFrame mask;
  std::string mask_note = "none";
  bool have_mask = false;
  int64_t centre = t0 + window / 2;
  if (!a.mask_from_labels && !extras.masks.empty()) {
    const spikems::MaskFrame* best = &extras.masks.front();
    for (const auto& m : extras.masks)
      if (std::llabs(m.t_us - centre) < std::llabs(best->t_us - centre)) best = &m;
    mask = spikems::filter_mask_ids(*best, moving);
    have_mask = true;
    mask_note = "mask frame at t = " + std::to_string(best->t_us) + " us";
  } else if (win.has_labels()) {
    mask = label_footprint(win, moving, sensor);
    have_mask = true;
    mask_note = "footprint of labelled events";
  } else if (a.mask_from_labels) {
    spikems::fail(a.file, "", "--mask-from-labels: the events carry no labels");
  }
  spikems::RenderOptions opt;
  opt.scale = a.scale;
  opt.show_labels = a.labels;
  opt.outline_mask = !a.no_outline;
  spikems::Image img =
      spikems::render_events(win, t0, t1, sensor, have_mask ? &mask : nullptr, opt);
  spikems::write_png(a.out, img);
  uint64_t on = 0;
  for (uint8_t p : win.p) on += p;
  std::printf("%s: %zu events in [%lld us, %lld us) (%llu ON, %llu OFF), %dx%d px, outline: %s\n",
              a.out.c_str(), win.size(), static_cast<long long>(t0), static_cast<long long>(t1),
              static_cast<unsigned long long>(on), static_cast<unsigned long long>(win.size() - on),
              img.width, img.height, a.no_outline ? "off" : mask_note.c_str());
}

void add(CLI::App& app) {
  static RenderArgs a;
  auto* cmd = app.add_subcommand(
      "render",
      "Draw the events of one time window as a PNG: ON red, OFF blue (both: purple), the "
      "ground-truth mask outlined in green");
  cmd->add_option("file", a.file, "Event file or dataset folder")->required();
  cmd->add_option("--from", a.from,
                  "Window start, from the first event (e.g. 1.5s, 250ms, 1200us; plain number = "
                  "seconds)")
      ->capture_default_str();
  cmd->add_option("--window", a.window, "Window length (e.g. 10ms)")->capture_default_str();
  cmd->add_option("-o,--out", a.out, "Output PNG")->required();
  cmd->add_option("--scale", a.scale, "Enlarge by this integer factor")
      ->check(CLI::Range(1, 16))
      ->capture_default_str();
  cmd->add_flag("--labels", a.labels,
                "Colour labelled events by object id (labels from the file, else from its mask "
                "frames)");
  cmd->add_flag("--mask-from-labels", a.mask_from_labels,
                "Outline the footprint of the labelled events instead of the nearest mask frame");
  cmd->add_flag("--no-outline", a.no_outline, "Do not draw the ground-truth outline");
  cmd->add_flag("--absolute", a.absolute,
                "--from is the file's own timestamp, not an offset from the first event");
  spikems::cli::add_read_flags(cmd, a.read);
  cmd->footer(
      "Examples:\n  spikems render seq.npz --from 1.5s --window 10ms --out frame.png --scale 2\n"
      "  spikems render events.txt --from 0 --window 25ms --out f.png --labels");
  cmd->callback([] { run(a); });
}

}  // namespace

SPIKEMS_COMMAND(render, 30, add);
