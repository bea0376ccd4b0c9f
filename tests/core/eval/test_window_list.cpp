// `--windows` lists: values, ranges, order, and each kind of bad text.
#include <gtest/gtest.h>

#include "core/eval/window_list.h"
#include "core/util/error.h"

namespace spikems {
namespace {

TEST(EvalWindowList, ValuesAndRanges) {
  EXPECT_EQ(parse_window_list_ms("20,100"), (std::vector<int64_t>{20000, 100000}));
  EXPECT_EQ(parse_window_list_ms("100,20,20"), (std::vector<int64_t>{20000, 100000}));
  auto r = parse_window_list_ms("1:25");
  ASSERT_EQ(r.size(), 25u);
  EXPECT_EQ(r.front(), 1000);
  EXPECT_EQ(r[9], 10000);
  EXPECT_EQ(r.back(), 25000);
  EXPECT_EQ(parse_window_list_ms("5:20:5,100"),
            (std::vector<int64_t>{5000, 10000, 15000, 20000, 100000}));
  EXPECT_EQ(parse_window_list_ms("0.5,2.5"), (std::vector<int64_t>{500, 2500}));
  EXPECT_EQ(parse_window_list_ms("3:3"), (std::vector<int64_t>{3000}));
}

TEST(EvalWindowList, BadListsNameTheItem) {
  for (const char* bad : {"", "20,", ",20", "20,,100", "abc", "20ms", "0", "-5", "1:0", "1:2:3:4",
                          ":5", "0.0001", "1:100000", "inf", " 20"}) {
    try {
      parse_window_list_ms(bad);
      ADD_FAILURE() << "accepted '" << bad << "'";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("--windows"), std::string::npos) << e.what();
    }
  }
  try {
    parse_window_list_ms("20,abc");
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("'abc'"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace spikems
