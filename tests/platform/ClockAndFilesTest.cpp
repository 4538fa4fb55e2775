#include <cstdio>
#include <string>

#include "platform/heap/HeapCounter.hpp"
#include "platform/posix/PosixClock.hpp"
#include "platform/posix/PosixFileReader.hpp"
#include "platform/stub/ManualClock.hpp"
#include "platform/stub/MemoryFileReader.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

#include <ctime>
#include <unistd.h>

using areomap::Status;

namespace {
int code(Status s) {
  return static_cast<int>(s);
}
}  // namespace

TEST_GROUP(Clock){};

TEST(Clock, PosixClockTicksAndMatchesTime) {
  areomap::platform::PosixClock clock;
  const int64_t m0 = clock.monotonicUtime();
  usleep(20000);
  const int64_t m1 = clock.monotonicUtime();
  CHECK(m1 - m0 >= 19000);
  CHECK(m1 - m0 < 2000000);
  // Wall time against time(): the same second, give or take one.
  const int64_t wall_s = clock.wallUtime() / 1000000;
  const int64_t now_s = static_cast<int64_t>(std::time(nullptr));
  CHECK(wall_s - now_s >= -1 && wall_s - now_s <= 1);
}

TEST(Clock, ManualClockAdvancesByHand) {
  areomap::platform::ManualClock clock(1000, 5);
  clock.advance(250);
  CHECK_EQUAL(1250, clock.wallUtime());
  CHECK_EQUAL(255, clock.monotonicUtime());
}

TEST_GROUP(FileReader){};

TEST(FileReader, PosixReadsWholeFilesAndSaysWhyNot) {
  const std::string dir = areomap::test::scratchDir("file_reader");
  const std::string path = dir + "/data.bin";
  std::FILE* f = std::fopen(path.c_str(), "wb");
  CHECK(f != nullptr);
  for (int i = 0; i < 100000; ++i) std::fputc(i % 251, f);
  std::fclose(f);
  static uint8_t buffer[200000];
  areomap::platform::PosixFileReader reader;
  std::size_t bytes = 0;
  {
    areomap::HeapAllocationScope scope;
    CHECK(ok(reader.readAll(path.c_str(), buffer, sizeof(buffer), bytes)));
    CHECK_EQUAL(0u, scope.allocations());
  }
  CHECK_EQUAL(100000u, bytes);
  CHECK_EQUAL(99999 % 251, buffer[99999]);
  CHECK(ok(reader.fileSize(path.c_str(), bytes)));
  CHECK_EQUAL(100000u, bytes);
  CHECK_EQUAL(code(Status::kCapacityExceeded), code(reader.readAll(path.c_str(), buffer, 99999, bytes)));
  CHECK_EQUAL(code(Status::kIoError),
              code(reader.readAll((dir + "/missing").c_str(), buffer, sizeof(buffer), bytes)));
  CHECK_EQUAL(code(Status::kIoError),
              code(reader.readAll(dir.c_str(), buffer, sizeof(buffer), bytes)));  // a folder
  CHECK_EQUAL(code(Status::kInvalidArgument), code(reader.readAll(nullptr, buffer, sizeof(buffer), bytes)));
}

TEST(FileReader, MemoryStubServesRegisteredFiles) {
  static const uint8_t content[] = {1, 2, 3, 4, 5};
  areomap::platform::MemoryFileReader reader;
  CHECK(reader.add("a/b.cahvor", content, sizeof(content)));
  uint8_t out[8] = {0};
  std::size_t bytes = 0;
  CHECK(ok(reader.readAll("a/b.cahvor", out, sizeof(out), bytes)));
  CHECK_EQUAL(5u, bytes);
  CHECK_EQUAL(5, out[4]);
  CHECK_EQUAL(code(Status::kCapacityExceeded), code(reader.readAll("a/b.cahvor", out, 4, bytes)));
  CHECK_EQUAL(code(Status::kIoError), code(reader.readAll("nope", out, sizeof(out), bytes)));
}
