#include <gtest/gtest.h>

#include "core/util/duration.h"
#include "core/util/error.h"

using namespace spikems;

TEST(Duration, UnitsAndPlainSeconds) {
  EXPECT_EQ(parse_duration_us("1.5s"), 1500000);
  EXPECT_EQ(parse_duration_us("250ms"), 250000);
  EXPECT_EQ(parse_duration_us("1200us"), 1200);
  EXPECT_EQ(parse_duration_us("1200\xC2\xB5s"), 1200);
  EXPECT_EQ(parse_duration_us("2min"), 120000000);
  EXPECT_EQ(parse_duration_us("2"), 2000000);
  EXPECT_EQ(parse_duration_us("0"), 0);
  EXPECT_EQ(parse_duration_us(" 10 ms "), 10000);
  EXPECT_EQ(parse_duration_us("0.0005"), 500);
  EXPECT_EQ(parse_duration_us("0.5us"), 1);  // rounded to the nearest microsecond
  EXPECT_EQ(parse_duration_us("-3ms"), -3000);
  EXPECT_EQ(parse_duration_us(".5s"), 500000);
}

TEST(Duration, ErrorsNameTheText) {
  for (const char* bad :
       {"", "ms", "abc", "1.2.3s", "5 parsecs", "1e400", "nan", "inf", "1h", "1,5s", "--1s"}) {
    try {
      parse_duration_us(bad);
      ADD_FAILURE() << "accepted '" << bad << "'";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(std::string("'") + bad + "'"), std::string::npos)
          << e.what();
    }
  }
}

TEST(Duration, Format) {
  EXPECT_EQ(format_duration_us(1500000), "1.500 s");
  EXPECT_EQ(format_duration_us(2500), "2.500 ms");
  EXPECT_EQ(format_duration_us(12), "12 us");
}
