#include "core/events/formats/zip.h"

#include <sys/stat.h>
#include <zip.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>

#include "core/util/atomic_file.h"
#include "core/util/byte_source.h"
#include "core/util/error.h"

namespace spikems {
namespace {

// Deflate cannot expand more than about 1032:1; a larger declared size is a corrupt header.
constexpr uint64_t kMaxDeflateRatio = 1040;
constexpr size_t kEocdSize = 22;

std::string zip_error_text(zip_error_t* ze) {
  std::string s = zip_error_strerror(ze);
  zip_error_fini(ze);
  return s;
}

std::string zip_error_text(int code) {
  zip_error_t ze;
  zip_error_init_with_code(&ze, code);
  return zip_error_text(&ze);
}

// The magic bytes of a local header ("PK\3\4") or of an empty archive's end record ("PK\5\6").
void check_magic(const uint8_t* head, uint64_t n, const std::string& source) {
  if (n < kEocdSize)
    fail_at_byte(source, 0,
                 "not a ZIP archive: file is " + std::to_string(n) + " bytes, too short");
  const uint32_t m = load_le32(head);
  if (m != 0x04034b50 && m != 0x06054b50)
    fail_at_byte(source, 0, "not a ZIP archive (npz): wrong magic bytes");
}

[[noreturn]] void fail_open(const std::string& source, const std::string& why) {
  fail(source, "", "ZIP archive is truncated or corrupt: " + why);
}

}  // namespace

ZipArchive::ZipArchive(const std::string& path) : source_(path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0)
    fail(path, "", std::string("cannot open: ") + strerror(errno));
  if (!S_ISREG(st.st_mode)) fail(path, "", "not a regular file");
  size_ = uint64_t(st.st_size);
  uint8_t head[4] = {};
  if (size_ >= kEocdSize) {
    auto src = open_file_source(path);
    src->read_exact(head, 4, "ZIP signature");
  }
  check_magic(head, size_, path);
  int err = 0;
  za_ = zip_open(path.c_str(), ZIP_RDONLY, &err);
  if (!za_) fail_open(path, zip_error_text(err));
  index();
}

ZipArchive::ZipArchive(const uint8_t* data, size_t n, std::string source)
    : source_(std::move(source)), size_(n) {
  check_magic(data, n, source_);
  zip_error_t ze;
  zip_error_init(&ze);
  zip_source_t* src = zip_source_buffer_create(data, n, 0, &ze);
  if (!src) fail(source_, "", "libzip: " + zip_error_text(&ze));
  za_ = zip_open_from_source(src, ZIP_RDONLY, &ze);
  if (!za_) {
    zip_source_free(src);
    fail_open(source_, zip_error_text(&ze));
  }
  zip_error_fini(&ze);
  index();
}

ZipArchive::~ZipArchive() {
  if (za_) zip_discard(za_);  // read-only: nothing to write
}

void ZipArchive::index() {
  try {
    const zip_int64_t n = zip_get_num_entries(za_, 0);
    if (n < 0) fail_open(source_, zip_strerror(za_));
    entries_.reserve(size_t(n));
    for (zip_int64_t i = 0; i < n; ++i) {
      zip_stat_t st;
      zip_stat_init(&st);
      if (zip_stat_index(za_, zip_uint64_t(i), ZIP_FL_ENC_RAW, &st) != 0)
        fail_open(source_, "entry " + std::to_string(i) + ": " + zip_strerror(za_));
      const zip_uint64_t need =
          ZIP_STAT_NAME | ZIP_STAT_SIZE | ZIP_STAT_COMP_SIZE | ZIP_STAT_COMP_METHOD | ZIP_STAT_CRC;
      if ((st.valid & need) != need)
        fail_open(source_, "entry " + std::to_string(i) + " lacks its name, sizes or CRC");
      ZipEntry e;
      e.name = st.name;
      e.index = zip_uint64_t(i);
      e.method = uint16_t(st.comp_method);
      e.crc32 = st.crc;
      e.compressed_size = st.comp_size;
      e.uncompressed_size = st.size;
      if ((st.valid & ZIP_STAT_ENCRYPTION_METHOD) && st.encryption_method != ZIP_EM_NONE)
        fail(source_, "", "ZIP member '" + e.name + "' is encrypted");
      entries_.push_back(std::move(e));
    }
  } catch (...) {
    zip_discard(za_);
    za_ = nullptr;
    throw;
  }
}

const ZipEntry* ZipArchive::find(const std::string& name) const {
  for (const auto& e : entries_)
    if (e.name == name) return &e;
  return nullptr;
}

std::vector<uint8_t> ZipArchive::read(const ZipEntry& e) const {
  const std::string who = "ZIP member '" + e.name + "'";
  // Sizes are checked before allocating: libzip would notice a lie only while reading.
  if (e.method != ZIP_CM_STORE && e.method != ZIP_CM_DEFLATE)
    fail(source_, "",
         who + " uses compression method " + std::to_string(e.method) +
             "; only stored (0) and deflate (8) are supported");
  if (e.compressed_size > size_)
    fail(source_, "",
         who + " claims " + std::to_string(e.compressed_size) +
             " compressed bytes, more than the " + std::to_string(size_) +
             "-byte archive (truncated or corrupt)");
  if (e.method == ZIP_CM_STORE && e.compressed_size != e.uncompressed_size)
    fail(source_, "", who + " is stored but its two sizes differ");
  if (e.method == ZIP_CM_DEFLATE &&
      e.uncompressed_size > e.compressed_size * kMaxDeflateRatio + 1024)
    fail(source_, "",
         who + " declares " + std::to_string(e.uncompressed_size) + " bytes, impossible for " +
             std::to_string(e.compressed_size) + " deflated bytes (corrupt header)");

  std::lock_guard<std::mutex> lock(mu_);
  zip_file_t* f = zip_fopen_index(za_, e.index, 0);
  if (!f) fail(source_, "", who + " cannot be opened: " + zip_strerror(za_));
  std::vector<uint8_t> out(size_t(e.uncompressed_size));
  uint64_t got = 0;
  std::string why;
  while (got < out.size()) {
    zip_int64_t r = zip_fread(f, out.data() + got, out.size() - got);
    if (r < 0) {
      why = zip_file_strerror(f);
      break;
    }
    if (r == 0) {
      why = "its data ends after " + std::to_string(got) + " of " + std::to_string(out.size()) +
            " bytes";
      break;
    }
    got += uint64_t(r);
  }
  // One more read reaches the end of the member, where libzip checks its CRC-32 and size.
  if (why.empty()) {
    uint8_t extra;
    zip_int64_t r = zip_fread(f, &extra, 1);
    if (r < 0)
      why = zip_file_strerror(f);
    else if (r > 0)
      why = "it holds more than the " + std::to_string(out.size()) + " bytes its header declares";
  }
  zip_fclose(f);
  if (!why.empty()) fail(source_, "", who + " is truncated or corrupt: " + why);
  return out;
}

std::vector<ZipEntry> zip_list_file(const std::string& path) {
  return ZipArchive(path).entries();
}

ZipWriter::ZipWriter(AtomicFile& out, bool deflate, int level)
    : out_(out), deflate_(deflate), level_(level < 1 ? 6 : std::min(level, 9)) {
  // libzip writes the archive beside temp_path() and renames it onto temp_path() in
  // zip_close(); AtomicFile then renames that onto the target on commit().
  int err = 0;
  za_ = zip_open(out_.temp_path().c_str(), ZIP_CREATE | ZIP_TRUNCATE, &err);
  if (!za_) fail(out_.target(), "", "cannot create the ZIP archive: " + zip_error_text(err));
}

ZipWriter::~ZipWriter() {
  if (za_) zip_discard(za_);  // finish() not reached: write nothing
}

void ZipWriter::add(const std::string& name, const std::vector<std::span<const uint8_t>>& pieces) {
  if (finished_) throw Error("ZipWriter::add after finish");
  std::vector<zip_buffer_fragment_t> frags;
  for (const auto& p : pieces)
    if (!p.empty()) frags.push_back({const_cast<zip_uint8_t*>(p.data()), p.size()});
  zip_error_t ze;
  zip_error_init(&ze);
  zip_source_t* src = zip_source_buffer_fragment_create(frags.empty() ? nullptr : frags.data(),
                                                        frags.size(), 0, &ze);
  if (!src) fail(out_.target(), "", "ZIP member '" + name + "': " + zip_error_text(&ze));
  zip_error_fini(&ze);
  set_member(name, src);
}

void ZipWriter::set_member(const std::string& name, zip_source* src) {
  const zip_int64_t i = zip_file_add(za_, name.c_str(), src, 0);
  if (i < 0) {
    zip_source_free(src);
    fail(out_.target(), "", "cannot add ZIP member '" + name + "': " + zip_strerror(za_));
  }
  const zip_uint64_t idx = zip_uint64_t(i);
  if (zip_set_file_compression(za_, idx, deflate_ ? ZIP_CM_DEFLATE : ZIP_CM_STORE,
                               deflate_ ? zip_uint32_t(level_) : 0) != 0 ||
      zip_file_set_dostime(za_, idx, 0, 0x0021, 0) != 0)  // 00:00, 1980-01-01
    fail(out_.target(), "", "ZIP member '" + name + "': " + zip_strerror(za_));
  ++count_;
}

void ZipWriter::add_file(const std::string& name, std::FILE* f) {
  if (finished_) {
    std::fclose(f);
    throw Error("ZipWriter::add_file after finish");
  }
  zip_source_t* src = zip_source_filep(za_, f, 0, -1);  // owns f from here on, if made
  if (!src) {
    std::fclose(f);
    fail(out_.target(), "", "ZIP member '" + name + "': " + zip_strerror(za_));
  }
  set_member(name, src);
}

void ZipWriter::finish() {
  if (finished_) return;
  finished_ = true;
  zip_t* za = za_;
  za_ = nullptr;
  if (zip_close(za) != 0) {
    std::string why = zip_strerror(za);
    zip_discard(za);
    fail(out_.target(), "", "cannot write the ZIP archive: " + why);
  }
  if (count_ == 0) {
    // libzip writes no file for an empty archive; numpy writes a bare end record.
    uint8_t eocd[kEocdSize] = {};
    store_le32(eocd, 0x06054b50);
    out_.write(eocd, sizeof eocd);
    return;
  }
}

}  // namespace spikems
