#include <string>

#include "firmware_core/base/FixedVector.hpp"
#include "firmware_core/base/Status.hpp"

#include <CppUTest/TestHarness.h>

TEST_GROUP(FixedVector){};

TEST(FixedVector, PushUntilFullThenCountsOverflow) {
  areomap::FixedVector<int, 3> v;
  CHECK_TRUE(v.push(1));
  CHECK_TRUE(v.push(2));
  CHECK_TRUE(v.push(3));
  CHECK_FALSE(v.push(4));
  CHECK_FALSE(v.push(5));
  LONGS_EQUAL(3, v.size());
  LONGS_EQUAL(2, v.overflowCount());
  LONGS_EQUAL(3, v.back());
  v.clear();
  LONGS_EQUAL(0, v.size());
  LONGS_EQUAL(2, v.overflowCount());
  v.reset();
  LONGS_EQUAL(0, v.overflowCount());
}

TEST_GROUP(Status){};

TEST(Status, EveryCodeHasADistinctName) {
  for (int i = 0; i < static_cast<int>(areomap::Status::kCount); ++i) {
    const char* a = areomap::statusName(static_cast<areomap::Status>(i));
    STRCMP_CONTAINS("", a);
    CHECK(std::string(a) != "unknown");
    for (int j = 0; j < i; ++j) {
      CHECK(std::string(a) != areomap::statusName(static_cast<areomap::Status>(j)));
    }
  }
}
