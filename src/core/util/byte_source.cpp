#include "core/util/byte_source.h"

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "core/util/error.h"

namespace spikems {

void ByteSource::read_exact(void* dst, size_t n, const char* what) {
  uint64_t start = offset_;
  size_t got = 0;
  auto* d = static_cast<uint8_t*>(dst);
  while (got < n) {
    size_t r = read_some(d + got, n - got);
    if (r == 0)
      fail_at_byte(name_, start,
                   std::string("file is truncated: expected ") + std::to_string(n) + " bytes of " +
                       what + ", found " + std::to_string(got));
    got += r;
  }
}

bool ByteSource::read_line(std::string& line, size_t max_len) {
  line.clear();
  char c;
  bool any = false;
  while (read_some(&c, 1) == 1) {
    any = true;
    if (c == '\n') return true;
    line.push_back(c);
    if (line.size() > max_len)
      fail_at_byte(name_, offset_, "line longer than " + std::to_string(max_len) + " bytes");
  }
  return any;
}

std::vector<uint8_t> ByteSource::head(size_t n) {
  uint64_t pos = offset_;
  std::vector<uint8_t> h(n);
  size_t got = 0;
  while (got < n) {
    size_t r = read_some(h.data() + got, n - got);
    if (r == 0) break;
    got += r;
  }
  h.resize(got);
  seek(pos);
  return h;
}

namespace {

class FileSource final : public ByteSource {
 public:
  explicit FileSource(const std::string& path) {
    name_ = path;
    f_ = std::fopen(path.c_str(), "rb");
    if (!f_) fail(path, "", std::string("cannot open: ") + std::strerror(errno));
    std::setvbuf(f_, nullptr, _IOFBF, 1 << 20);
    if (std::fseek(f_, 0, SEEK_END) == 0) {
      long s = std::ftell(f_);
      size_ = s < 0 ? UINT64_MAX : uint64_t(s);
      std::fseek(f_, 0, SEEK_SET);
    }
  }
  ~FileSource() override {
    if (f_) std::fclose(f_);
  }
  size_t read_some(void* dst, size_t n) override {
    size_t r = std::fread(dst, 1, n, f_);
    if (r == 0 && std::ferror(f_)) fail_at_byte(name_, offset_, std::strerror(errno));
    offset_ += r;
    return r;
  }
  uint64_t size() const override { return size_; }
  void seek(uint64_t off) override {
    if (std::fseek(f_, long(off), SEEK_SET) != 0) fail_at_byte(name_, off, "seek failed");
    offset_ = off;
  }

 private:
  std::FILE* f_ = nullptr;
  uint64_t size_ = UINT64_MAX;
};

class MemorySource final : public ByteSource {
 public:
  MemorySource(const uint8_t* d, size_t n, std::string name) : d_(d), n_(n) {
    name_ = std::move(name);
  }
  size_t read_some(void* dst, size_t n) override {
    size_t r = std::min<uint64_t>(n, n_ - std::min<uint64_t>(offset_, n_));
    if (r) std::memcpy(dst, d_ + offset_, r);
    offset_ += r;
    return r;
  }
  uint64_t size() const override { return n_; }
  void seek(uint64_t off) override { offset_ = std::min<uint64_t>(off, n_); }

 private:
  const uint8_t* d_;
  size_t n_;
};

// Reads stdin and keeps its first kKeep bytes so that head() can seek back over them.
class StdinSource final : public ByteSource {
 public:
  StdinSource() { name_ = "<stdin>"; }
  size_t read_some(void* dst, size_t n) override {
    auto* d = static_cast<uint8_t*>(dst);
    size_t got = 0;
    if (offset_ < kept_.size()) {  // replay what head() already consumed
      got = std::min<size_t>(n, kept_.size() - size_t(offset_));
      std::memcpy(d, kept_.data() + offset_, got);
      offset_ += got;
      if (got == n) return got;
    }
    size_t r = std::fread(d + got, 1, n - got, stdin);
    if (r == 0 && std::ferror(stdin)) fail_at_byte(name_, offset_, std::strerror(errno));
    if (offset_ < kKeep) {
      size_t keep = std::min<size_t>(r, kKeep - size_t(offset_));
      kept_.insert(kept_.end(), d + got, d + got + keep);
    }
    offset_ += r;
    return got + r;
  }
  uint64_t size() const override { return UINT64_MAX; }
  void seek(uint64_t off) override {
    if (off == offset_) return;
    if (off > kept_.size() || offset_ > kept_.size())
      fail_at_byte(name_, off, "cannot seek in standard input");
    offset_ = off;
  }

 private:
  static constexpr size_t kKeep = 64 * 1024;
  std::vector<uint8_t> kept_;
};

}  // namespace

std::unique_ptr<ByteSource> open_stdin_source() {
  return std::make_unique<StdinSource>();
}

std::unique_ptr<ByteSource> open_file_source(const std::string& path) {
  return std::make_unique<FileSource>(path);
}
std::unique_ptr<ByteSource> open_memory_source(const uint8_t* data, size_t n, std::string name) {
  return std::make_unique<MemorySource>(data, n, std::move(name));
}

std::vector<uint8_t> read_file_bytes(const std::string& path) {
  auto src = open_file_source(path);
  if (src->size() == UINT64_MAX) fail(path, "", "cannot determine file size");
  std::vector<uint8_t> out(src->size());
  src->read_exact(out.data(), out.size(), "file contents");
  return out;
}

}  // namespace spikems
