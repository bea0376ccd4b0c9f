// Readers and writers of event files behind one interface. The format is recognised from the
// file's content (magic bytes, header) and only then from its extension.
//
// Each format provides a FormatInfo (see formats/registry.cpp). Readers stream: read() hands
// out chunks, so a recording larger than memory is processed in bounded memory.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/events/event_stream.h"
#include "core/events/recording.h"
#include "core/util/byte_source.h"

namespace spikems {

struct ReadOptions {
  bool sort = false;               // accept out-of-order timestamps and sort them (else an error)
  std::string time_unit = "auto";  // text formats: "auto", "s", "us"
  SensorSize sensor;               // override or supply the sensor size where a file lacks it
  std::string format;              // force a format by name (empty: detect)
  // read_extras(): false gives the mask frames' times and sizes without their pixels (ids
  // empty), so describing a long recording does not load every mask into memory.
  bool mask_planes = true;
};

class EventReader {
 public:
  virtual ~EventReader() = default;
  virtual std::string format_name() const = 0;
  // Sensor size from the header (may be unknown until the end for headerless formats).
  virtual SensorSize sensor() const = 0;
  // Appends up to max_events events to out (out.sensor is set); returns how many were
  // appended, 0 at the end of the file. Errors throw spikems::Error with the byte offset.
  virtual size_t read(EventStream& out, size_t max_events) = 0;
  // Mask frames, intrinsics, metadata where the format has them (default: none).
  virtual void read_extras(Recording& rec) {}
};

class EventWriter {
 public:
  virtual ~EventWriter() = default;  // an unclosed writer leaves no file behind
  virtual void write(const EventStream& chunk) = 0;
  // Writes mask frames etc. where the format can hold them (default: ignored).
  virtual void write_extras(const Recording& rec) {}
  // Finishes the file and renames it into place (atomic).
  virtual void close() = 0;
};

struct WriteOptions {
  std::string compression = "";  // format-specific: "lz4", "zstd", "deflate", "none"
  int level = -1;                // compression level (-1: format default)
  std::string time_unit = "us";  // text formats
};

struct FormatInfo {
  std::string name;                     // e.g. "evt3", "aedat4", "text"
  std::string description;              // one line for --help and `spikems formats`
  std::vector<std::string> extensions;  // e.g. {".raw"}; lower-case with dot
  // Score how sure we are the content is this format: 0 no, 100 magic matched.
  std::function<int(const std::vector<uint8_t>& head, const std::string& path)> detect;
  std::function<std::unique_ptr<EventReader>(std::unique_ptr<ByteSource>, const ReadOptions&)>
      open_bytes;  // null for formats read by path only (HDF5, folders)
  std::function<std::unique_ptr<EventReader>(const std::string& path, const ReadOptions&)>
      open_path;  // null when open_bytes suffices
  std::function<std::unique_ptr<EventWriter>(const std::string& path, SensorSize,
                                             const WriteOptions&)>
      open_writer;             // null: read-only format
  bool compresses = false;     // the writer takes WriteOptions::compression and ::level
  bool writes_extras = false;  // the writer keeps mask frames, intrinsics, poses, metadata
};

const std::vector<FormatInfo>& formats();
const FormatInfo* find_format(const std::string& name);
// A path's extension, lower-case with its dot (".npy"; "" without one).
std::string lower_extension(const std::string& path);

// Detects the format of a path (file or folder) from content, then extension.
const FormatInfo& detect_format(const std::string& path);
const FormatInfo& format_for_output(const std::string& path, const std::string& forced = "");

std::unique_ptr<EventReader> open_reader(const std::string& path, const ReadOptions& opt = {});
std::unique_ptr<EventWriter> open_writer(const std::string& path, SensorSize sensor,
                                         const WriteOptions& opt = {},
                                         const std::string& format = "");

// Reads a whole file (events and extras); validates and, with opt.sort, sorts.
Recording read_recording(const std::string& path, const ReadOptions& opt = {});
EventStream read_events(const std::string& path, const ReadOptions& opt = {});
void write_recording(const std::string& path, const Recording& rec, const WriteOptions& opt = {},
                     const std::string& format = "");

// Chunk size used by streaming commands.
inline constexpr size_t kReadChunk = 1 << 20;

}  // namespace spikems
