// ZIP archives for NumPy .npz files, on libzip (https://libzip.org, Debian's libzip-dev).
//
// libzip parses the end records (ZIP64 included, which numpy writes for large arrays), the
// central directory and the local headers, inflates, and checks each member's CRC-32 and size.
// This layer adds what the npz readers need on top: errors that name the file and the reason,
// a magic-byte check, and size checks before any allocation (a corrupt header cannot make a
// reader allocate more than the archive could hold).
#pragma once

#include <cstdint>
#include <cstdio>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <vector>

struct zip;         // libzip's zip_t
struct zip_source;  // libzip's zip_source_t

namespace spikems {

class AtomicFile;

struct ZipEntry {
  std::string name;
  uint64_t index = 0;   // position in the central directory
  uint16_t method = 0;  // 0 stored, 8 deflate
  uint32_t crc32 = 0;
  uint64_t compressed_size = 0;
  uint64_t uncompressed_size = 0;
};

// A read-only archive, its member list read once.
class ZipArchive {
 public:
  // From a file: libzip reads only the end records and the central directory, then each
  // member on demand (EV-IMO npz files hold gigabytes beside a small member).
  explicit ZipArchive(const std::string& path);
  // From memory, not copied: the caller keeps data alive. `source` names it in errors.
  ZipArchive(const uint8_t* data, size_t n, std::string source);
  ~ZipArchive();
  ZipArchive(const ZipArchive&) = delete;
  ZipArchive& operator=(const ZipArchive&) = delete;

  const std::vector<ZipEntry>& entries() const { return entries_; }
  const ZipEntry* find(const std::string& name) const;  // null when absent
  // The member's bytes, decompressed; its size and CRC-32 checked. Thread-safe.
  std::vector<uint8_t> read(const ZipEntry& e) const;
  const std::string& source() const { return source_; }

 private:
  void index();
  std::string source_;
  uint64_t size_ = 0;  // archive bytes
  zip* za_ = nullptr;
  std::vector<ZipEntry> entries_;
  mutable std::mutex mu_;  // libzip handles are not thread-safe
};

// Lists the members of a ZIP file (cheap: end records and central directory only).
std::vector<ZipEntry> zip_list_file(const std::string& path);

// Writes an archive into an AtomicFile (nothing else may have been written to it); finish()
// writes it, then the caller commits. Members have a fixed DOS date (1980-01-01), so the same
// arrays always give the same bytes.
class ZipWriter {
 public:
  ZipWriter(AtomicFile& out, bool deflate, int level = 6);
  ~ZipWriter();
  ZipWriter(const ZipWriter&) = delete;
  ZipWriter& operator=(const ZipWriter&) = delete;
  // One member made of `pieces` in order. Not copied: they must stay alive until finish().
  void add(const std::string& name, const std::vector<std::span<const uint8_t>>& pieces);
  void add(const std::string& name, const uint8_t* data, size_t n) { add(name, {{data, n}}); }
  // One member: the content of an open file from its current position, read during finish(),
  // so that a member larger than memory streams through. The writer owns and closes `f`.
  // libzip records the file's mode in the member's attributes (a buffer's are rw-rw-rw-).
  void add_file(const std::string& name, std::FILE* f);
  void finish();  // call once, before out.commit()

 private:
  void set_member(const std::string& name, zip_source* src);  // adds src, its method and date
  AtomicFile& out_;
  bool deflate_;
  int level_;
  zip* za_ = nullptr;
  size_t count_ = 0;
  bool finished_ = false;
};

}  // namespace spikems
