// LabelColumnWriter: the label column alone, as .npy (uint8) or .txt lines, streamed and atomic.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "common/test_paths.h"
#include "core/events/formats/label_column.h"
#include "core/events/formats/npy.h"
#include "core/util/error.h"

namespace spikems {
namespace {

std::string slurp(const std::string& p) {
  std::ifstream f(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), {});
}

EventStream stream(std::vector<uint16_t> labels, bool with_labels = true) {
  EventStream s;
  for (size_t i = 0; i < labels.size(); ++i) {
    if (with_labels)
      s.push_back(int64_t(i), 1, 2, 1, labels[i]);
    else
      s.push_back(int64_t(i), 1, 2, 1);
  }
  return s;
}

// Chunks with and without labels append in order; the header names the total count.
TEST(LabelColumn, NpyHoldsEveryChunkInOrder) {
  const std::string p = test::scratch_dir() + "/l.npy";
  {
    LabelColumnWriter w(p);
    w.write(stream({1, 0, 1}));
    w.write(stream({}));
    w.write(stream({7, 7}, /*with_labels=*/false));  // no labels: zeros
    w.write(stream({255}));
    EXPECT_FALSE(std::filesystem::exists(p));  // only at close
    w.close();
    EXPECT_EQ(w.count(), 6u);
  }
  const NpyArray a = read_npy(p);
  EXPECT_EQ(a.descr, "|u1");
  EXPECT_EQ(a.shape, std::vector<int64_t>{6});
  EXPECT_EQ(a.to<int>(), (std::vector<int>{1, 0, 1, 0, 0, 255}));
  EXPECT_EQ(std::filesystem::file_size(p), 128u + 6u);
}

TEST(LabelColumn, EmptyStreamGivesAnEmptyArray) {
  const std::string p = test::scratch_dir() + "/e.npy";
  LabelColumnWriter w(p);
  w.close();
  const NpyArray a = read_npy(p);
  EXPECT_EQ(a.shape, std::vector<int64_t>{0});
  EXPECT_TRUE(a.data.empty());
}

TEST(LabelColumn, TextHasOneLabelPerLine) {
  const std::string p = test::scratch_dir() + "/l.txt";
  LabelColumnWriter w(p);
  w.write(stream({0, 1, 1}));
  w.write(stream({12, 0, 65535}));  // ids above 9 take their decimal digits
  w.write(stream({3}, false));
  w.close();
  EXPECT_EQ(slurp(p), "0\n1\n1\n12\n0\n65535\n0\n");
}

// An id above 255 does not fit the uint8 column: an error that names the event, and whatever
// was at the path stays.
TEST(LabelColumn, NpyRefusesIdsAbove255AndKeepsTheOldFile) {
  const std::string p = test::scratch_dir() + "/old.npy";
  std::ofstream(p) << "old";
  try {
    LabelColumnWriter w(p);
    w.write(stream({0, 0}));
    w.write(stream({1, 300, 2}));
    FAIL() << "no error";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("event 3"), std::string::npos) << m;
    EXPECT_NE(m.find("label 300"), std::string::npos) << m;
  }
  EXPECT_EQ(slurp(p), "old");
}

TEST(LabelColumn, OtherExtensionsAreRefused) {
  const std::string d = test::scratch_dir();
  for (const char* name : {"/l.csv", "/l.npz", "/l"}) {
    try {
      LabelColumnWriter w(d + name);
      FAIL() << name;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(".npy"), std::string::npos) << e.what();
    }
  }
  LabelColumnWriter upper(d + "/L.NPY");  // extensions are case-blind
  upper.close();
  EXPECT_EQ(read_npy(d + "/L.NPY").shape, std::vector<int64_t>{0});
}

}  // namespace
}  // namespace spikems
