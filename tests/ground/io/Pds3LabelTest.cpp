// The PDS3 label parser: values continued over lines, and its work bounded by the input (a long
// unclosed value made the parse quadratic, found while fuzzing), and the reader's stop at the first NUL.
#include <fstream>
#include <string>

#include "ground/cli/Cli.hpp"
#include "ground/io/Pds3Label.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

constexpr const char* kHead =
    "PDS_VERSION_ID = PDS3\r\nOBJECT = IMAGE\r\n  LINES = 4\r\nEND_OBJECT = IMAGE\r\n";

// "KEY = (0,\r\n1,\r\n2,\r\n…" over `lines` lines, closed by ")" or not.
std::string longTuple(int lines, bool closed) {
  std::string text = std::string(kHead) + "KEY = (0,\r\n";
  for (int i = 1; i < lines; ++i) text += std::to_string(i % 10) + ",\r\n";
  text += closed ? "9)\r\nEND\r\n" : "9,\r\n";
  return text;
}

}  // namespace

TEST_GROUP(Pds3Label){};

// Before the fix the balance of the value was re-checked over the whole value at every new line: for this
// 200 000-line value that is ~2 * 10^11 characters looked at (minutes); now each character once.
TEST(Pds3Label, LongUnclosedValueIsAnErrorAfterLinearWork) {
  const std::string text = longTuple(200000, false);
  io::Pds3ParseWork work;
  try {
    (void)io::Pds3Label::parse(text, "open.lbl", &work);
    FAIL("an unclosed value parsed");
  } catch (const cli::InputError& e) {
    STRCMP_EQUAL("END", e.field().c_str());
    STRCMP_CONTAINS("the value of KEY is not closed", e.what());
  }
  CHECK(work.balance_chars > 200000u);  // the value was scanned (the counter counts)
  CHECK(work.balance_chars <= text.size());
}

TEST(Pds3Label, LongClosedValueParsesWholeInLinearWork) {
  const std::string text = longTuple(200000, true);
  io::Pds3ParseWork work;
  const io::Pds3Label label = io::Pds3Label::parse(text, "long.lbl", &work);
  CHECK(work.balance_chars <= text.size());
  const std::string* value = label.find("KEY", "");
  CHECK(value != nullptr);
  const std::vector<std::string> items = io::Pds3Label::tuple(*value);
  LONGS_EQUAL(200001, static_cast<long>(items.size()));
  STRCMP_EQUAL("0", items.front().c_str());
  STRCMP_EQUAL("1", items[1].c_str());
  STRCMP_EQUAL("9", items.back().c_str());
  STRCMP_EQUAL("4", label.required("LINES", "IMAGE").c_str());
}

// The balance carried from line to line decides as the whole-value check did: quotes hide brackets, a
// value closes when its brackets and quotes do, a surplus ")" closes at once.
TEST(Pds3Label, ContinuationFollowsBracketsAndQuotes) {
  const std::string text = std::string(kHead) +
                           "A = \"one (\r\n two\"\r\n"
                           "B = (1, \"a)\r\n b\", {2,\r\n 3})\r\n"
                           "C = ) (\r\n"
                           "D = 5 /* ( in a comment */\r\n"
                           "END\r\n";
  const io::Pds3Label label = io::Pds3Label::parse(text, "x.lbl");
  STRCMP_EQUAL("\"one ( two\"", label.required("A", "").c_str());
  STRCMP_EQUAL("(1, \"a) b\", {2, 3})", label.required("B", "").c_str());
  STRCMP_EQUAL(") (", label.required("C", "").c_str());
  STRCMP_EQUAL("5", label.required("D", "").c_str());
}

// read(): the text up to the first NUL (an attached label's image data follows), also when the label is
// longer than the reader's 64 KiB chunk; a file without END names END.
TEST(Pds3Label, ReadStopsAtTheFirstNulAcrossChunks) {
  const std::string dir = test::scratchDir("pds3_label_read");
  std::string body = std::string(kHead);
  while (body.size() < 150000) body += "/* padding padding padding padding padding padding padding */\r\n";
  body += "LAST = 7\r\nEND\r\n";
  const std::string attached = dir + "/attached.IMG";
  {
    std::ofstream f(attached, std::ios::binary);
    f << body << std::string(1, '\0') << "END\r\nAFTER = 1\r\n" << std::string(300000, 'x');
  }
  const io::Pds3Label label = io::Pds3Label::read(attached);
  STRCMP_EQUAL("7", label.required("LAST", "").c_str());
  CHECK(label.find("AFTER", "") == nullptr);
  STRCMP_EQUAL(attached.c_str(), label.file().c_str());

  const std::string open = dir + "/open.lbl";
  std::ofstream(open, std::ios::binary) << std::string(kHead) << std::string(200000, ' ');
  try {
    (void)io::Pds3Label::read(open);
    FAIL("a label without END parsed");
  } catch (const cli::InputError& e) {
    STRCMP_EQUAL("END", e.field().c_str());
  }
  try {
    (void)io::Pds3Label::read(dir + "/missing.lbl");
    FAIL("a missing file parsed");
  } catch (const cli::InputError& e) {
    STRCMP_EQUAL("file", e.field().c_str());
  }
}
