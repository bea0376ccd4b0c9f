#include <gtest/gtest.h>

#include "core/eval/metrics.h"
#include "core/util/error.h"

using namespace spikems;

// 4x4 masks drawn by hand: P covers a 2x3 block, G a 2x2 block inside it.
static std::vector<uint8_t> mask(std::initializer_list<int> bits) {
  std::vector<uint8_t> m;
  for (int b : bits) m.push_back(uint8_t(b));
  return m;
}

TEST(Metrics, IoUOfNestedBlocks) {
  auto p = mask({1, 1, 1, 0, 1, 1, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0});
  auto g = mask({1, 1, 0, 0, 1, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0});
  MaskCounts c = count_masks(p, g);
  EXPECT_EQ(c.intersection, 4u);
  EXPECT_EQ(c.predicted, 6u);
  EXPECT_EQ(c.truth, 4u);
  EXPECT_EQ(c.union_(), 6u);
  EXPECT_DOUBLE_EQ(iou(c), 4.0 / 6.0);
  EXPECT_TRUE(is_detection(c));  // 4 > 2 and 4 > 2 false positives
}

TEST(Metrics, DetectionNeedsHalfOfTruthAndFewerFalsePositives) {
  // Covers exactly half of G: not a detection (strictly more than half is required).
  EXPECT_FALSE(is_detection(MaskCounts{2, 2, 4}));
  EXPECT_TRUE(is_detection(MaskCounts{3, 3, 4}));
  // Covers all of G but with as many false positives as hits: not a detection.
  EXPECT_FALSE(is_detection(MaskCounts{4, 8, 4}));
  EXPECT_TRUE(is_detection(MaskCounts{4, 7, 4}));
}

TEST(Metrics, WindowScoresSkipEmptyTruth) {
  WindowScores s;
  s.add(MaskCounts{1, 1, 1});  // IoU 1, detection
  s.add(MaskCounts{0, 3, 1});  // IoU 0
  s.add(MaskCounts{0, 5, 0});  // no truth: skipped
  EXPECT_EQ(s.windows(), 2u);
  EXPECT_EQ(s.skipped(), 1u);
  EXPECT_DOUBLE_EQ(s.mean_iou(), 0.5);
  EXPECT_DOUBLE_EQ(s.std_iou(), 0.5);
  EXPECT_DOUBLE_EQ(s.detection_rate(), 0.5);
}

TEST(Metrics, MismatchedSizesAreAnError) {
  EXPECT_THROW(count_masks(mask({1, 0}), mask({1})), Error);
}

TEST(Metrics, EnergyPerOperation) {
  EXPECT_DOUBLE_EQ(snn_energy_pj(1e8), 0.9e8);
  EXPECT_DOUBLE_EQ(ann_energy_pj(1e8), 4.6e8);
}
