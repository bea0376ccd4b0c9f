#include "legacy/legacy_zip.h"

#include <zlib.h>

#include <algorithm>
#include <cstring>

#include "core/util/byte_source.h"
#include "core/util/error.h"

namespace spikems::legacy {
namespace {

constexpr uint32_t kLocalSig = 0x04034b50;
constexpr uint32_t kCentralSig = 0x02014b50;
constexpr uint32_t kEocdSig = 0x06054b50;
constexpr uint32_t kEocd64Sig = 0x06064b50;
constexpr uint32_t kEocd64LocatorSig = 0x07064b50;
constexpr uint32_t k32 = 0xFFFFFFFFu;

// Deflate cannot expand more than about 1032:1; a larger declared size is a corrupt header.
constexpr uint64_t kMaxDeflateRatio = 1040;

uint32_t crc32_of(const uint8_t* p, size_t n) {
  uLong c = crc32(0L, Z_NULL, 0);
  while (n > 0) {
    uInt chunk = uInt(std::min<size_t>(n, 1u << 30));
    c = crc32(c, p, chunk);
    p += chunk;
    n -= chunk;
  }
  return uint32_t(c);
}

// Bounds-checked view of the archive bytes.
struct View {
  const uint8_t* d;
  size_t n;
  const std::string& src;
  void need(uint64_t off, uint64_t len, const char* what) const {
    if (off > n || len > n - off)
      fail_at_byte(src, off,
                   std::string("ZIP archive is truncated or corrupt: ") + what + " (" +
                       std::to_string(len) + " bytes) runs past the end of the " +
                       std::to_string(n) + "-byte file");
  }
};

// Replaces 0xFFFFFFFF fields of a central-directory entry from its ZIP64 extra field.
void apply_zip64_extra(const View& v, uint64_t extra_off, uint16_t extra_len, ZipEntry& e,
                       bool usize32, bool csize32, bool off32) {
  uint64_t p = extra_off, end = extra_off + extra_len;
  while (p + 4 <= end) {
    uint16_t id = load_le16(v.d + p), len = load_le16(v.d + p + 2);
    if (p + 4 + len > end) fail_at_byte(v.src, p, "ZIP extra field runs past its entry");
    if (id == 0x0001) {
      uint64_t q = p + 4, qend = q + len;
      auto take = [&](uint64_t& field) {
        if (q + 8 > qend) fail_at_byte(v.src, q, "ZIP64 extra field is too short");
        field = load_le64(v.d + q);
        q += 8;
      };
      if (usize32) take(e.uncompressed_size);
      if (csize32) take(e.compressed_size);
      if (off32) take(e.local_header_offset);
      return;
    }
    p += 4 + len;
  }
  if (usize32 || csize32 || off32)
    fail_at_byte(v.src, extra_off,
                 "ZIP entry '" + e.name + "' needs a ZIP64 extra field, found none");
}

}  // namespace

namespace {

struct Directory {
  uint64_t count = 0, offset = 0, size = 0;
};

// Finds the central directory from the archive's last bytes. `tail` holds the file's last
// tail_n bytes; `file_n` is the whole file size.
Directory find_directory(const uint8_t* tail, size_t tail_n, uint64_t file_n,
                         const std::string& source) {
  const uint64_t base = file_n - tail_n;  // file offset of tail[0]
  if (file_n < 22)
    fail_at_byte(source, 0,
                 "not a ZIP archive: file is " + std::to_string(file_n) + " bytes, too short");
  uint64_t eocd = UINT64_MAX;
  for (uint64_t p = tail_n - 22;; --p) {
    if (load_le32(tail + p) == kEocdSig && p + 22 + load_le16(tail + p + 20) == tail_n) {
      eocd = p;
      break;
    }
    if (p == 0) break;
  }
  if (eocd == UINT64_MAX)
    fail_at_byte(source, file_n, "ZIP end-of-central-directory record not found (file truncated?)");
  Directory d;
  d.count = load_le16(tail + eocd + 10);
  d.size = load_le32(tail + eocd + 12);
  d.offset = load_le32(tail + eocd + 16);
  if (d.count == 0xFFFF || d.size == k32 || d.offset == k32) {
    if (eocd < 20 || load_le32(tail + eocd - 20) != kEocd64LocatorSig)
      fail_at_byte(source, base + eocd,
                   "ZIP64 archive without a ZIP64 end-of-central-directory locator");
    uint64_t z64 = load_le64(tail + eocd - 20 + 8);
    if (z64 < base || z64 > base + tail_n - 56)
      fail_at_byte(source, base + eocd, "ZIP64 end-of-central-directory record is out of place");
    const uint8_t* r = tail + (z64 - base);
    if (load_le32(r) != kEocd64Sig)
      fail_at_byte(source, z64, "bad ZIP64 end-of-central-directory signature");
    d.count = load_le64(r + 32);
    d.size = load_le64(r + 40);
    d.offset = load_le64(r + 48);
  }
  if (d.offset > file_n || d.size > file_n - d.offset)
    fail_at_byte(source, base + eocd,
                 "ZIP central directory (" + std::to_string(d.size) + " bytes at " +
                     std::to_string(d.offset) + ") runs past the end of the " +
                     std::to_string(file_n) + "-byte file (truncated?)");
  if (d.count > d.size / 46)
    fail_at_byte(source, base + eocd,
                 "ZIP claims " + std::to_string(d.count) +
                     " entries, more than its central directory can hold");
  return d;
}

// Parses `count` entries from the central directory bytes cd (file offset cd_off).
std::vector<ZipEntry> parse_directory(const uint8_t* cd, uint64_t cd_size, uint64_t cd_off,
                                      uint64_t count, const std::string& source) {
  View v{cd, size_t(cd_size), source};
  std::vector<ZipEntry> out;
  out.reserve(count);
  uint64_t p = 0;
  for (uint64_t i = 0; i < count; ++i) {
    if (p + 46 > cd_size || load_le32(cd + p) != kCentralSig)
      fail_at_byte(source, cd_off + p, "bad ZIP central directory entry " + std::to_string(i));
    ZipEntry e;
    e.flags = load_le16(cd + p + 8);
    e.method = load_le16(cd + p + 10);
    e.crc32 = load_le32(cd + p + 16);
    e.compressed_size = load_le32(cd + p + 20);
    e.uncompressed_size = load_le32(cd + p + 24);
    uint16_t name_len = load_le16(cd + p + 28), extra_len = load_le16(cd + p + 30),
             comment_len = load_le16(cd + p + 32);
    e.local_header_offset = load_le32(cd + p + 42);
    if (p + 46 + name_len + extra_len + comment_len > cd_size)
      fail_at_byte(source, cd_off + p, "ZIP central directory entry runs past the directory");
    e.name.assign(reinterpret_cast<const char*>(cd + p + 46), name_len);
    bool u32 = e.uncompressed_size == k32, c32 = e.compressed_size == k32,
         o32 = e.local_header_offset == k32;
    apply_zip64_extra(v, p + 46 + name_len, extra_len, e, u32, c32, o32);
    out.push_back(std::move(e));
    p += 46 + name_len + extra_len + comment_len;
  }
  return out;
}

}  // namespace

std::vector<ZipEntry> zip_list(const uint8_t* data, size_t n, const std::string& source) {
  if (n < 22)
    fail_at_byte(source, 0,
                 "not a ZIP archive: file is " + std::to_string(n) + " bytes, too short");
  if (load_le32(data) != kLocalSig && load_le32(data) != kEocdSig)
    fail_at_byte(source, 0, "not a ZIP archive (npz): wrong magic bytes");
  size_t tail_n = std::min<size_t>(n, 22 + 65535 + 20 + 56);
  Directory d = find_directory(data + n - tail_n, tail_n, n, source);
  return parse_directory(data + d.offset, d.size, d.offset, d.count, source);
}

std::vector<ZipEntry> zip_list_file(const std::string& path) {
  auto src = open_file_source(path);
  const uint64_t n = src->size();
  if (n == UINT64_MAX) fail(path, "", "cannot determine file size");
  if (n < 22)
    fail_at_byte(path, 0, "not a ZIP archive: file is " + std::to_string(n) + " bytes, too short");
  uint8_t magic[4];
  src->read_exact(magic, 4, "ZIP signature");
  if (load_le32(magic) != kLocalSig && load_le32(magic) != kEocdSig)
    fail_at_byte(path, 0, "not a ZIP archive (npz): wrong magic bytes");
  size_t tail_n = size_t(std::min<uint64_t>(n, 22 + 65535 + 20 + 56));
  std::vector<uint8_t> tail(tail_n);
  src->seek(n - tail_n);
  src->read_exact(tail.data(), tail_n, "ZIP end records");
  Directory d = find_directory(tail.data(), tail_n, n, path);
  std::vector<uint8_t> cd(d.size);
  src->seek(d.offset);
  src->read_exact(cd.data(), cd.size(), "ZIP central directory");
  return parse_directory(cd.data(), d.size, d.offset, d.count, path);
}

namespace {

// Checks a member's local header and returns the offset of its data, which lies inside the file.
uint64_t member_data_start(const uint8_t* data, size_t n, const ZipEntry& e,
                           const std::string& source, const std::string& who) {
  View v{data, n, source};
  v.need(e.local_header_offset, 30, "local header");
  const uint8_t* lh = data + e.local_header_offset;
  if (load_le32(lh) != kLocalSig)
    fail_at_byte(source, e.local_header_offset, "bad local header signature for " + who);
  if (e.flags & 1) fail_at_byte(source, e.local_header_offset, who + " is encrypted");
  // Sizes come from the central directory: numpy's ZIP64 local headers hold placeholders.
  uint64_t start = e.local_header_offset + 30 + load_le16(lh + 26) + load_le16(lh + 28);
  v.need(start, e.compressed_size, (who + " data").c_str());
  return start;
}

}  // namespace

std::vector<uint8_t> zip_extract(const uint8_t* data, size_t n, const ZipEntry& e,
                                 const std::string& source) {
  const std::string who = "ZIP member '" + e.name + "'";
  const uint64_t start = member_data_start(data, n, e, source, who);
  const uint8_t* src = data + start;
  std::vector<uint8_t> out;
  if (e.method == 0) {
    if (e.compressed_size != e.uncompressed_size)
      fail_at_byte(source, start, who + " is stored but its two sizes differ");
    out.assign(src, src + e.compressed_size);
  } else if (e.method == 8) {
    if (e.uncompressed_size > e.compressed_size * kMaxDeflateRatio + 1024)
      fail_at_byte(source, start,
                   who + " declares " + std::to_string(e.uncompressed_size) +
                       " bytes, impossible for " + std::to_string(e.compressed_size) +
                       " deflated bytes (corrupt header)");
    out.resize(e.uncompressed_size);
    z_stream zs{};
    if (inflateInit2(&zs, -15) != Z_OK) fail(source, "", "zlib inflateInit2 failed");
    uint64_t in_left = e.compressed_size, out_left = out.size();
    uint8_t dummy = 0;  // zlib rejects a null output pointer, even for empty members
    zs.next_in = const_cast<Bytef*>(src);
    zs.next_out = out.empty() ? &dummy : out.data();
    int rc = Z_OK;
    while (rc == Z_OK) {
      if (zs.avail_in == 0 && in_left) {
        zs.avail_in = uInt(std::min<uint64_t>(in_left, 1u << 30));
        in_left -= zs.avail_in;
      }
      if (zs.avail_out == 0 && out_left) {
        zs.avail_out = uInt(std::min<uint64_t>(out_left, 1u << 30));
        out_left -= zs.avail_out;
      }
      rc = inflate(&zs, Z_NO_FLUSH);
      if (rc == Z_BUF_ERROR && (zs.avail_in == 0 && in_left == 0)) break;  // input ended early
      if (rc == Z_BUF_ERROR && zs.avail_out == 0 && out_left == 0) break;  // more than declared
      if (rc == Z_BUF_ERROR) rc = Z_OK;
    }
    uint64_t produced = zs.total_out;
    inflateEnd(&zs);
    if (rc != Z_STREAM_END)
      fail_at_byte(source, start,
                   who + " has corrupt or truncated deflate data" +
                       (zs.msg ? std::string(" (") + zs.msg + ")" : std::string()));
    if (produced != e.uncompressed_size)
      fail_at_byte(source, start,
                   who + " inflates to " + std::to_string(produced) + " bytes, header says " +
                       std::to_string(e.uncompressed_size));
  } else {
    fail_at_byte(source, e.local_header_offset,
                 who + " uses compression method " + std::to_string(e.method) +
                     "; only stored (0) and deflate (8) are supported");
  }
  if (crc32_of(out.data(), out.size()) != e.crc32)
    fail_at_byte(source, start, who + " fails its CRC-32 check (corrupt data)");
  return out;
}

std::pair<const uint8_t*, size_t> zip_stored_view(const uint8_t* data, size_t n, const ZipEntry& e,
                                                  const std::string& source) {
  const std::string who = "ZIP member '" + e.name + "'";
  if (e.method != 0)
    fail_at_byte(source, e.local_header_offset, who + " is not a plain stored member");
  if (e.compressed_size != e.uncompressed_size)
    fail_at_byte(source, e.local_header_offset, who + " is stored but its two sizes differ");
  const uint64_t start = member_data_start(data, n, e, source, who);
  if (crc32_of(data + start, e.compressed_size) != e.crc32)
    fail_at_byte(source, start, who + " fails its CRC-32 check (corrupt data)");
  return {data + start, size_t(e.compressed_size)};
}

}  // namespace spikems::legacy
