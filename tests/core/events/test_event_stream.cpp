// EventStream's block writer: resize_labelled() keeps what was there and zeroes the rest.
#include <gtest/gtest.h>

#include "core/events/event_stream.h"

using namespace spikems;

TEST(EventStream, ResizeLabelledKeepsEventsAndZeroesNewOnes) {
  EventStream s;
  s.push_back(10, 1, 2, 1);  // no labels yet
  s.push_back(20, 3, 4, 0);
  ASSERT_FALSE(s.has_labels());
  s.resize_labelled(4);
  ASSERT_EQ(s.size(), 4u);
  ASSERT_EQ(s.label.size(), 4u);
  EXPECT_EQ(s.t[1], 20);
  EXPECT_EQ(s.x[1], 3);
  EXPECT_EQ(s.y[1], 4);
  EXPECT_EQ(s.p[0], 1);
  for (size_t i = 0; i < 4; ++i) EXPECT_EQ(s.label[i], 0) << i;
  for (size_t i = 2; i < 4; ++i) {
    EXPECT_EQ(s.t[i], 0);
    EXPECT_EQ(s.x[i], 0);
    EXPECT_EQ(s.y[i], 0);
    EXPECT_EQ(s.p[i], 0);
  }
  // Labels already present are kept; shrinking drops the tail of every array.
  s.label[1] = 7;
  s.resize_labelled(2);
  ASSERT_EQ(s.size(), 2u);
  EXPECT_EQ(s.label.size(), 2u);
  EXPECT_EQ(s.label[1], 7);
  EXPECT_EQ(s.t[0], 10);
}
