#include "core/util/atomic_file.h"

#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstring>
#include <mutex>
#include <random>
#include <set>

#include "core/util/error.h"

namespace spikems {
namespace {

constexpr uint64_t kWritebackChunk = uint64_t(4) << 20;

std::mutex g_mu;
std::set<std::string>& live_temps() {
  static std::set<std::string> s;
  return s;
}

std::string make_temp_name(const std::string& target) {
  static std::atomic<unsigned> counter{0};
  std::random_device rd;
  return target + ".tmp." + std::to_string(getpid()) + "." + std::to_string(rd() % 100000) + "." +
         std::to_string(counter++);
}

}  // namespace

AtomicFile::AtomicFile(std::string target) : target_(std::move(target)) {
  if (target_.empty()) throw Error("output path is empty");
  temp_ = make_temp_name(target_);
  std::lock_guard<std::mutex> lock(g_mu);
  live_temps().insert(temp_);
}

AtomicFile::~AtomicFile() {
  if (f_) std::fclose(f_);
  if (!committed_) std::remove(temp_.c_str());
  std::lock_guard<std::mutex> lock(g_mu);
  live_temps().erase(temp_);
}

std::FILE* AtomicFile::handle() {
  if (!f_) {
    f_ = std::fopen(temp_.c_str(), "wb");
    if (!f_)
      fail(target_, "", std::string("cannot create temporary file: ") + std::strerror(errno));
  }
  return f_;
}

void AtomicFile::write(const void* data, size_t n) {
  if (n == 0) return;
  if (std::fwrite(data, 1, n, handle()) != n)
    fail(target_, "", std::string("write failed: ") + std::strerror(errno));
  written_ += n;
  if (written_ - flushed_ >= kWritebackChunk) start_writeback();
}

void AtomicFile::overwrite(uint64_t offset, const void* data, size_t n) {
  if (offset + n > written_)
    fail(target_, "",
         "internal: overwrite past the bytes written (" + std::to_string(offset + n) + " > " +
             std::to_string(written_) + ")");
  if (std::fflush(handle()) != 0 ||
      ::pwrite(fileno(f_), data, n, off_t(offset)) != static_cast<ssize_t>(n))
    fail(target_, "", std::string("write failed: ") + std::strerror(errno));
}

// commit() must have the data on disk before the rename (below). Waiting for all of a large
// output there costs as long as the disk takes to write it (tens of MB of text labels: a tenth
// of `segment`'s time), so the writeback of each finished chunk is started as the output
// grows, and runs beside the program's own work; commit()'s fsync then waits only for the
// last chunk. Linux only (sync_file_range); elsewhere the fsync does it all. Failures here are
// ignored: the fsync reports them.
void AtomicFile::start_writeback() {
#if defined(__linux__)
  if (f_ && std::fflush(f_) == 0)
    ::sync_file_range(fileno(f_), off64_t(flushed_), off64_t(written_ - flushed_),
                      SYNC_FILE_RANGE_WRITE);
#endif
  flushed_ = written_;
}

// The temporary file's data on disk before the rename makes it the target: after a crash the
// target holds the old content or the new, never a truncated file. A failed fsync (EIO, a full
// disk on a network file system) means the data may not be there, so the target is not
// replaced. File systems without fsync (EINVAL, ENOSYS) leave nothing more to do.
namespace {
int fsync_error(int fd) {
  if (::fsync(fd) == 0 || errno == EINVAL || errno == ENOSYS || errno == ENOTSUP) return 0;
  return errno;
}
}  // namespace

void AtomicFile::fail_sync(int err) const {
  if (err != 0)
    fail(target_, "", std::string("cannot write to disk (fsync): ") + std::strerror(err));
}

void AtomicFile::commit() {
  if (committed_) return;
  if (f_) {
    if (std::fflush(f_) != 0)
      fail(target_, "", std::string("flush failed: ") + std::strerror(errno));
    fail_sync(fsync_error(fileno(f_)));
    const int closed = std::fclose(f_);
    f_ = nullptr;
    if (closed != 0) fail(target_, "", std::string("close failed: ") + std::strerror(errno));
  } else if (access(temp_.c_str(), F_OK) != 0) {
    handle();  // an empty output is still an output
    std::fclose(f_);
    f_ = nullptr;
  } else {
    // Written by a library that opens files by name (HDF5, libzip, libpng): synced here too.
    const int fd = ::open(temp_.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0)
      fail(target_, "", std::string("cannot reopen the temporary file: ") + std::strerror(errno));
    const int err = fsync_error(fd);
    ::close(fd);
    fail_sync(err);
  }
  if (std::rename(temp_.c_str(), target_.c_str()) != 0)
    fail(target_, "",
         std::string("cannot rename temporary file into place: ") + std::strerror(errno));
  committed_ = true;
}

void write_file_atomic(const std::string& path, const std::string& bytes) {
  AtomicFile f(path);
  f.write(bytes);
  f.commit();
}

namespace {
extern "C" void cleanup_on_signal(int sig) {
  // Best effort: unlink is async-signal-safe; the set is not locked (we are exiting).
  for (const auto& p : live_temps()) unlink(p.c_str());
  std::signal(sig, SIG_DFL);
  std::raise(sig);
}
}  // namespace

void install_interrupt_cleanup() {
  std::signal(SIGINT, cleanup_on_signal);
  std::signal(SIGTERM, cleanup_on_signal);
}

}  // namespace spikems
