// `spikems convert IN OUT`: any readable format to any writable one, chunk by chunk.
#include <unistd.h>

#include <algorithm>
#include <cstdio>

#include "cli/command.h"
#include "core/events/event_ops.h"
#include "core/events/io.h"
#include "core/util/duration.h"
#include "core/util/error.h"
#include "core/util/interrupt.h"
#include "core/util/progress.h"

namespace {

using spikems::EventStream;

struct ConvertArgs {
  std::string in, out, out_format, compression, from, to, out_time_unit = "us";
  std::string in_format, time_unit = "auto";
  std::string crop, denoise, refractory;
  bool flip_x = false, flip_y = false;
  int downsample = 1;
  int level = -1, width = 0, height = 0;
  bool sort = false, absolute = false, quiet = false;
};

// Keeps events of `c` with t in [lo, hi).
void keep_range(EventStream& c, int64_t lo, int64_t hi) {
  if (c.empty() || (c.t.front() >= lo && c.t.back() < hi)) return;
  auto [b, e] = c.time_range(lo, hi);
  c = c.slice_index(b, e);
}

// "X,Y,W,H" -> crop fields of cfg.
void parse_crop(const std::string& text, spikems::BinningConfig& cfg) {
  int v[4];
  char tail;
  if (std::sscanf(text.c_str(), "%d,%d,%d,%d%c", &v[0], &v[1], &v[2], &v[3], &tail) != 4 ||
      v[2] <= 0 || v[3] <= 0)
    spikems::fail("--crop '" + text + "'", "", "expected X,Y,W,H (e.g. 109,66,128,128)");
  cfg.crop_x = v[0];
  cfg.crop_y = v[1];
  cfg.crop_w = v[2];
  cfg.crop_h = v[3];
}

void run(const ConvertArgs& a) {
  spikems::install_interrupt_flag();
  spikems::ReadOptions ro;
  ro.sort = a.sort;
  ro.time_unit = a.time_unit;
  ro.format = a.in_format;
  if (a.width > 0 && a.height > 0) ro.sensor = {a.width, a.height};
  spikems::WriteOptions wo;
  wo.compression = a.compression == "none" ? "none" : a.compression;
  wo.level = a.level;
  wo.time_unit = a.out_time_unit;
  // Check the output format before reading anything.
  spikems::format_for_output(a.out, a.out_format);
  bool has_from = !a.from.empty(), has_to = !a.to.empty();
  int64_t from = has_from ? spikems::parse_duration_us(a.from) : 0;
  int64_t to = has_to ? spikems::parse_duration_us(a.to) : 0;
  if (has_from && has_to && to <= from)
    spikems::fail(a.out, "", "--to (" + a.to + ") must be after --from (" + a.from + ")");

  auto reader = spikems::open_reader(a.in, ro);
  spikems::ProgressBar bar("convert", 0, "ev", !a.quiet && isatty(fileno(stderr)));
  EventStream chunk;
  size_t n = reader->read(chunk, spikems::kReadChunk);
  // Whole-file mode: sorting needs every event, and a headerless input (text) only knows its
  // sensor size at the end.
  spikems::SensorSize sensor = reader->sensor();
  if (!sensor.known()) sensor = chunk.sensor;
  bool whole = a.sort || !sensor.known();
  if (whole) {
    while (n > 0) {
      if (spikems::interrupted()) spikems::fail(a.in, "", "interrupted; no output written");
      bar.update(chunk.size());
      n = reader->read(chunk, spikems::kReadChunk);
    }
    if (a.sort) chunk.sort_by_time();
    sensor = reader->sensor();
    if (!sensor.known()) sensor = chunk.sensor;
    if (!sensor.known()) {  // from the largest coordinates seen
      int mx = 0, my = 0;
      for (size_t i = 0; i < chunk.size(); ++i) {
        mx = std::max<int>(mx, chunk.x[i] + 1);
        my = std::max<int>(my, chunk.y[i] + 1);
      }
      sensor = {mx, my};
      std::fprintf(stderr,
                   "spikems: note: %s does not state its sensor size; using %dx%d from the "
                   "largest coordinates (pass --width/--height to set it)\n",
                   a.in.c_str(), mx, my);
    }
    chunk.sensor = sensor;
  }
  // Times on the command line are relative to the first event unless --absolute.
  int64_t base = a.absolute || chunk.empty() ? 0 : chunk.t.front();
  int64_t lo = has_from ? base + from : INT64_MIN, hi = has_to ? base + to : INT64_MAX;

  // Optional processing, in this order: denoise, refractory, geometry (crop, flip, downsample).
  spikems::BinningConfig geo;
  if (!a.crop.empty()) parse_crop(a.crop, geo);
  geo.flip_x = a.flip_x;
  geo.flip_y = a.flip_y;
  geo.downsample = a.downsample;
  const bool remap = !a.crop.empty() || a.flip_x || a.flip_y || a.downsample != 1;
  spikems::SensorSize out_sensor = sensor;
  if (remap) {
    auto [h, w] = spikems::binned_size(sensor, geo);
    out_sensor = {w, h};
  }
  std::unique_ptr<spikems::BackgroundActivityFilter> ba;
  std::unique_ptr<spikems::RefractoryFilter> rf;
  if (!a.denoise.empty())
    ba = std::make_unique<spikems::BackgroundActivityFilter>(sensor,
                                                             spikems::parse_duration_us(a.denoise));
  if (!a.refractory.empty())
    rf = std::make_unique<spikems::RefractoryFilter>(sensor,
                                                     spikems::parse_duration_us(a.refractory));

  auto writer = spikems::open_writer(a.out, out_sensor, wo, a.out_format);
  uint64_t read_total = 0, written = 0;
  auto emit = [&](EventStream& c) {
    read_total += c.size();
    keep_range(c, lo, hi);
    c.sensor = sensor;
    if (ba) c = ba->apply(c);
    if (rf) c = rf->apply(c);
    if (remap) c = spikems::remap_events(c, geo);
    c.sensor = out_sensor;
    if (!c.empty()) writer->write(c);
    written += c.size();
    bar.update(read_total);
  };
  if (whole) {
    emit(chunk);
  } else {
    while (n > 0) {
      if (spikems::interrupted()) spikems::fail(a.in, "", "interrupted; no output written");
      bool past_end = !chunk.empty() && chunk.t.front() >= hi;
      if (past_end) break;  // time-ordered input: nothing later can fall in the range
      emit(chunk);
      chunk.clear();
      chunk.sensor = sensor;  // emit may have remapped it; the reader checks against it
      n = reader->read(chunk, spikems::kReadChunk);
    }
  }
  bar.finish();
  spikems::Recording extras;
  // Only a format that keeps them gets the masks, intrinsics and poses: reading a simulated
  // recording's masks was half of converting it to EVT 3.0.
  if (spikems::format_for_output(a.out, a.out_format).writes_extras) reader->read_extras(extras);
  // Keep the mask frames and poses of the selected time range.
  auto in_range = [&](int64_t t) { return t >= lo && t < hi; };
  std::erase_if(extras.masks, [&](const spikems::MaskFrame& m) { return !in_range(m.t_us); });
  std::erase_if(extras.poses, [&](const spikems::PoseSample& p) { return !in_range(p.t_us); });
  extras.events.sensor = out_sensor;
  if (remap && !extras.masks.empty()) {
    // Mask frames follow the events through the same geometry (nearest pixel: the first
    // sensor pixel of each output pixel).
    const spikems::PixelMap pm(sensor, geo);
    for (auto& m : extras.masks) {
      spikems::MaskFrame o;
      o.t_us = m.t_us;
      o.width = out_sensor.width;
      o.height = out_sensor.height;
      o.ids.assign(size_t(o.width) * size_t(o.height), 0);
      for (int y = m.height - 1; y >= 0; --y)
        for (int x = m.width - 1; x >= 0; --x) {
          int ox, oy;
          if (pm.map(x, y, ox, oy)) o.ids[size_t(oy) * size_t(o.width) + size_t(ox)] = m.at(x, y);
        }
      m = std::move(o);
    }
  }
  if (remap) extras.intrinsics.reset();  // no longer the camera's pixel grid
  writer->write_extras(extras);
  writer->close();
  if (!a.quiet)
    std::printf("%s -> %s: %llu events written (%llu read), %zu mask frames\n", a.in.c_str(),
                a.out.c_str(), static_cast<unsigned long long>(written),
                static_cast<unsigned long long>(read_total), extras.masks.size());
}

void add(CLI::App& app) {
  static ConvertArgs a;
  auto* cmd = app.add_subcommand(
      "convert",
      "Convert an event file to another format, chunk by chunk (mask frames, intrinsics and "
      "metadata are carried over where both formats hold them); the output appears atomically");
  cmd->add_option("input", a.in, "Input event file or dataset folder")->required();
  cmd->add_option("output", a.out, "Output file (format from the extension or --format)")
      ->required();
  cmd->add_option("--format", a.out_format, "Output format (see `spikems formats`)");
  cmd->add_option("--compression", a.compression, "Output compression where the format has it")
      ->check(CLI::IsMember({"lz4", "zstd", "deflate", "none"}));
  cmd->add_option("--level", a.level, "Compression level (format default when absent)");
  cmd->add_option("--from", a.from,
                  "Keep events from this time on (e.g. 1.5s, 250ms; from the first event)");
  cmd->add_option("--to", a.to, "Keep events before this time (same units as --from)");
  cmd->add_flag("--absolute", a.absolute,
                "--from/--to are the file's own timestamps, not offsets from the first event");
  cmd->add_flag("--sort", a.sort,
                "Accept out-of-order timestamps and sort them (reads the whole file into memory)");
  cmd->add_option("--in-format", a.in_format, "Force the input format");
  cmd->add_option("--time-unit", a.time_unit, "Text input: unit of t (auto, s, us)")
      ->check(CLI::IsMember({"auto", "s", "us"}));
  cmd->add_option("--out-time-unit", a.out_time_unit, "Text output: unit of t (us, s)")
      ->check(CLI::IsMember({"us", "s"}));
  cmd->add_option("--width", a.width, "Sensor width where the input does not say")
      ->check(CLI::Range(1, 65535));
  cmd->add_option("--height", a.height, "Sensor height where the input does not say")
      ->check(CLI::Range(1, 65535));
  cmd->add_option("--denoise", a.denoise,
                  "Background-activity filter: keep events with a neighbour event at most this "
                  "long before (e.g. 1ms)");
  cmd->add_option("--refractory", a.refractory,
                  "Drop events closer than this to the previous kept event of their pixel");
  cmd->add_option("--crop", a.crop, "Keep the region X,Y,W,H (sensor pixels)");
  cmd->add_flag("--flip-x", a.flip_x, "Mirror left-right (after the crop)");
  cmd->add_flag("--flip-y", a.flip_y, "Mirror top-bottom (after the crop)");
  cmd->add_option("--downsample", a.downsample, "Integer factor: pixel = floor(coord / f)")
      ->check(CLI::Range(1, 64));
  cmd->add_flag("-q,--quiet", a.quiet, "No progress bar or summary line");
  cmd->footer(
      "Examples:\n  spikems convert recording.raw recording.h5\n"
      "  spikems convert seq.npz events.txt --from 2s --to 3.5s\n"
      "  spikems convert in.aedat4 out.raw --format evt3");
  cmd->callback([] {
    if ((a.width > 0) != (a.height > 0)) spikems::fail(a.in, "", "pass both --width and --height");
    run(a);
  });
}

}  // namespace

SPIKEMS_COMMAND(convert, 20, add);
