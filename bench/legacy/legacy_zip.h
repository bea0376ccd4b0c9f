// The hand-written ZIP reader that libzip replaced, kept only so bench_formats_libs can compare
// both in one process; not part of any shipped target. Writer removed.
// A small ZIP reader and writer, enough for NumPy .npz archives (PKWARE APPNOTE 6.3.x:
// https://pkware.cachefly.net/webdocs/casestudies/APPNOTE.TXT).
//
// Reader: end-of-central-directory record (with ZIP64 EOCD and ZIP64 extra fields, which numpy
// writes for large arrays), central directory, local headers; methods 0 (stored) and 8
// (deflate); CRC-32 checked. Every size and offset is checked against the archive before use,
// so a corrupt header cannot make the reader allocate or read out of bounds.
// Writer: stored or deflate members with CRC; no ZIP64 (members or archives of 4 GiB and more
// are refused with an error rather than written corrupt).
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace spikems::legacy {

struct ZipEntry {
  std::string name;
  uint16_t method = 0;  // 0 stored, 8 deflate
  uint16_t flags = 0;
  uint32_t crc32 = 0;
  uint64_t compressed_size = 0;
  uint64_t uncompressed_size = 0;
  uint64_t local_header_offset = 0;
};

// Lists the members of an in-memory archive from its central directory.
std::vector<ZipEntry> zip_list(const uint8_t* data, size_t n, const std::string& source);
// The same from a file, reading only its end records and central directory (cheap detection).
std::vector<ZipEntry> zip_list_file(const std::string& path);
// Decompresses one member and checks its size and CRC-32.
std::vector<uint8_t> zip_extract(const uint8_t* data, size_t n, const ZipEntry& e,
                                 const std::string& source);

// A stored (method 0) member in place, after its CRC-32 check: {pointer into data, size}.
std::pair<const uint8_t*, size_t> zip_stored_view(const uint8_t* data, size_t n, const ZipEntry& e,
                                                  const std::string& source);

}  // namespace spikems::legacy
