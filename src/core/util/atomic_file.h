// Atomic file output: data goes to a temporary file beside the target, which is renamed over
// the target only on commit(). A crash, an exception or Ctrl-C never leaves a half-written
// target, and whatever the user had at that path survives until the new file is complete.
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>

namespace spikems {

class AtomicFile {
 public:
  explicit AtomicFile(std::string target);
  ~AtomicFile();  // removes the temporary file if commit() was not reached
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  // Path of the temporary file, for libraries that open files by name (HDF5, libpng).
  const std::string& temp_path() const { return temp_; }
  const std::string& target() const { return target_; }
  // A stdio handle on the temporary file, opened on first use ("wb").
  std::FILE* handle();
  void write(const void* data, size_t n);
  void write(const std::string& s) { write(s.data(), s.size()); }
  // Replaces n bytes already written at `offset` (a header whose content is known only at the
  // end); the next write() still appends.
  void overwrite(uint64_t offset, const void* data, size_t n);
  // Flushes, fsyncs, closes and renames over the target.
  void commit();
  bool committed() const { return committed_; }

 private:
  std::string target_;
  std::string temp_;
  std::FILE* f_ = nullptr;
  bool committed_ = false;
  uint64_t written_ = 0;  // bytes handed to write()
  uint64_t flushed_ = 0;  // bytes whose writeback to disk has been started
  void start_writeback();
  void fail_sync(int err) const;  // err: an fsync's errno, 0 when it succeeded
};

// Writes a whole buffer atomically.
void write_file_atomic(const std::string& path, const std::string& bytes);

// Registers temp files so a SIGINT/SIGTERM handler can remove them before exiting.
void install_interrupt_cleanup();

}  // namespace spikems
