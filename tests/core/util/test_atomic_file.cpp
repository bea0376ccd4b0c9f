#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "common/test_paths.h"
#include "core/util/atomic_file.h"
#include "core/util/byte_source.h"
#include "core/util/error.h"

using namespace spikems;

static std::string slurp(const std::string& p) {
  std::ifstream f(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), {});
}

TEST(AtomicFile, CommitReplacesTarget) {
  auto dir = test::scratch_dir();
  std::string p = dir + "/out.bin";
  write_file_atomic(p, "old");
  {
    AtomicFile f(p);
    f.write("new contents");
    EXPECT_EQ(slurp(p), "old");  // target untouched until commit
    f.commit();
  }
  EXPECT_EQ(slurp(p), "new contents");
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir), {}), 1);  // no temp left
}

// A large output written in pieces (its writeback started chunk by chunk as it grows, on
// Linux) is committed whole and in order, over an older file.
TEST(AtomicFile, LargeOutputWrittenInPiecesIsCommittedWhole) {
  auto dir = test::scratch_dir();
  std::string p = dir + "/big.bin";
  write_file_atomic(p, "old");
  std::string want;
  {
    AtomicFile f(p);
    std::string piece(size_t(1) << 20, '\0');
    for (int i = 0; i < 19; ++i) {  // 19 MiB plus a ragged end: several chunks and a rest
      for (size_t j = 0; j < piece.size(); ++j) piece[j] = char((j * 31 + size_t(i) * 7) & 0xff);
      f.write(piece);
      want += piece;
      EXPECT_EQ(slurp(p), "old");
    }
    f.write("tail");
    want += "tail";
    f.commit();
  }
  EXPECT_EQ(slurp(p), want);
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir), {}), 1);
}

TEST(AtomicFile, AbandonedWriteKeepsOldFileAndLeavesNoTemp) {
  auto dir = test::scratch_dir();
  std::string p = dir + "/out.bin";
  write_file_atomic(p, "precious");
  try {
    AtomicFile f(p);
    f.write("partial");
    throw std::runtime_error("simulated failure");
  } catch (const std::runtime_error&) {
  }
  EXPECT_EQ(slurp(p), "precious");
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir), {}), 1);
}

TEST(ByteSource, ReadExactReportsTruncationWithOffset) {
  const uint8_t data[5] = {1, 2, 3, 4, 5};
  auto src = open_memory_source(data, 5, "mem.bin");
  uint8_t buf[4];
  src->read_exact(buf, 3, "header");
  EXPECT_EQ(src->offset(), 3u);
  try {
    src->read_exact(buf, 4, "record");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    std::string m = e.what();
    EXPECT_NE(m.find("mem.bin"), std::string::npos);
    EXPECT_NE(m.find("byte 3"), std::string::npos);
    EXPECT_NE(m.find("truncated"), std::string::npos);
  }
}

TEST(ByteSource, EndianLoads) {
  const uint8_t b[8] = {0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x07, 0x08};
  EXPECT_EQ(load_le16(b), 0x0201);
  EXPECT_EQ(load_be16(b), 0x0102);
  EXPECT_EQ(load_le32(b), 0x04030201u);
  EXPECT_EQ(load_be32(b), 0x01020304u);
  EXPECT_EQ(load_le64(b), 0x0807060504030201ull);
}

// overwrite() replaces bytes already written (a header known only at the end); later writes
// still append; a range past the written bytes is an error.
TEST(AtomicFile, OverwriteReplacesWrittenBytes) {
  auto dir = test::scratch_dir();
  std::string p = dir + "/hdr.bin";
  AtomicFile f(p);
  f.write("....body");
  f.overwrite(0, "HEAD", 4);
  f.write("+tail");
  EXPECT_THROW(f.overwrite(10, "xyzw", 4), Error);
  f.commit();
  EXPECT_EQ(slurp(p), "HEADbody+tail");
}
