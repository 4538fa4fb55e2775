// PDS3 and ordinary images: the real 16-bit MER frames, and small 8/16-bit PDS3 files written here.
#include <cstdint>
#include <fstream>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "ground/cli/Cli.hpp"
#include "ground/io/ImageFile.hpp"
#include "ground/io/Pds3Label.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

// A PDS3 file: a label padded to `records` records of `record_bytes`, then the pixels (first `keep`
// bytes of them; all when keep < 0).
std::string writePds3(const std::string& path, int lines, int samples, int bits, const std::string& type,
                      const std::vector<uint16_t>& pixels, long keep = -1) {
  const int record_bytes = 256, records = 4;
  std::string label = "PDS_VERSION_ID = PDS3\r\nRECORD_TYPE = FIXED_LENGTH\r\nRECORD_BYTES = " +
                      std::to_string(record_bytes) + "\r\n^IMAGE = " + std::to_string(records + 1) +
                      "\r\nOBJECT = IMAGE\r\n  LINES = " + std::to_string(lines) +
                      "\r\n  LINE_SAMPLES = " + std::to_string(samples) + "\r\n  SAMPLE_TYPE = " + type +
                      "\r\n  SAMPLE_BITS = " + std::to_string(bits) +
                      "\r\n  SAMPLE_BIT_MASK = 2#0000111111111111#\r\nEND_OBJECT = IMAGE\r\nEND\r\n";
  label.resize(static_cast<std::size_t>(record_bytes * records), ' ');
  std::string data;
  for (uint16_t v : pixels) {
    if (bits == 8) {
      data += static_cast<char>(v);
    } else if (type.rfind("LSB", 0) == 0) {
      data += static_cast<char>(v & 0xFF);
      data += static_cast<char>(v >> 8);
    } else {
      data += static_cast<char>(v >> 8);
      data += static_cast<char>(v & 0xFF);
    }
  }
  if (keep >= 0) data.resize(static_cast<std::size_t>(keep));
  std::ofstream(path, std::ios::binary) << label << data;
  return path;
}

}  // namespace

TEST_GROUP(ImageFile){};

TEST(ImageFile, ReadsRealMer16BitFramesAndMatchesTheLabelStatistics) {
  if (!test::requireSharedData("mer-opportunity-navcam-sol4087")) return;
  const std::string dir = test::sharedDataDir() + "/mer-opportunity-navcam-sol4087/";
  for (const char* name : {"1N491020376ILFCNY9P0706L0M1.IMG", "1N491020519ILFCNY9P0706L0M1.IMG"}) {
    const std::string path = dir + name;
    const io::Pds3ImageInfo info = io::readPds3ImageInfo(path);
    CHECK_EQUAL(43008u, info.offset_bytes);  // RECORD_BYTES 2048 x (^IMAGE 22 - 1)
    CHECK_EQUAL(4095u, info.valid_max);
    const cv::Mat img = io::readPds3Image(path);
    CHECK_EQUAL(CV_16UC1, img.type());
    CHECK_EQUAL(1024, img.rows);
    CHECK_EQUAL(1024, img.cols);
    // The label's own statistics (IMAGE.MINIMUM/MAXIMUM, over the valid, non-zero pixels) are an
    // independent check of the byte order and the offset.
    const io::Pds3Label label = io::Pds3Label::read(path);
    double lo = 1e9, hi = 0.0;
    for (int r = 0; r < img.rows; ++r) {
      for (int c = 0; c < img.cols; ++c) {
        const double v = img.at<uint16_t>(r, c);
        if (v > 0.0) lo = std::min(lo, v);
        hi = std::max(hi, v);
      }
    }
    std::printf("\n%s: min %.0f max %.0f (label %s / %s)", name, lo, hi,
                label.find("MINIMUM", "IMAGE")->c_str(), label.find("MAXIMUM", "IMAGE")->c_str());
    DOUBLES_EQUAL(label.number("MINIMUM", "IMAGE"), lo, 0.0);
    DOUBLES_EQUAL(label.number("MAXIMUM", "IMAGE"), hi, 0.0);
    const cv::Mat img8 = io::loadImage8(path);
    CHECK_EQUAL(CV_8UC1, img8.type());
    // The documented rule: round(v * 255 / 4095).
    const uint16_t v = img.at<uint16_t>(500, 600);
    CHECK_EQUAL(static_cast<int>(std::lround(v * 255.0 / 4095.0)),
                static_cast<int>(img8.at<uint8_t>(500, 600)));
  }
  std::printf("\n");
}

TEST(ImageFile, ReadsSmall8And16BitPds3FilesInBothByteOrders) {
  const std::string dir = test::scratchDir("image_file_pds");
  std::vector<uint16_t> px;
  for (int i = 0; i < 6 * 5; ++i) px.push_back(static_cast<uint16_t>(i * 131 % 4096));
  for (const char* type : {"MSB_UNSIGNED_INTEGER", "LSB_UNSIGNED_INTEGER", "MSB_INTEGER"}) {
    const cv::Mat img = io::readPds3Image(writePds3(dir + "/s16.img", 5, 6, 16, type, px));
    CHECK_EQUAL(CV_16UC1, img.type());
    CHECK_EQUAL(5, img.rows);
    CHECK_EQUAL(6, img.cols);
    for (int i = 0; i < 30; ++i) CHECK_EQUAL(px[static_cast<std::size_t>(i)], img.at<uint16_t>(i / 6, i % 6));
  }
  std::vector<uint16_t> px8;
  for (int i = 0; i < 30; ++i) px8.push_back(static_cast<uint16_t>(i * 7));
  const cv::Mat img8 = io::loadImage8(writePds3(dir + "/s8.img", 5, 6, 8, "UNSIGNED_INTEGER", px8));
  CHECK_EQUAL(CV_8UC1, img8.type());
  CHECK_EQUAL(7 * 29, static_cast<int>(img8.at<uint8_t>(4, 5)));
  const cv::Mat wide = io::loadImage16(dir + "/s8.img");
  CHECK_EQUAL(CV_16UC1, wide.type());
  CHECK_EQUAL(7 * 29, static_cast<int>(wide.at<uint16_t>(4, 5)));
}

TEST(ImageFile, TruncatedOrBadImagesNameTheField) {
  const std::string dir = test::scratchDir("image_file_bad");
  std::vector<uint16_t> px(64 * 64, 1000);
  const std::string truncated = writePds3(dir + "/t.img", 64, 64, 16, "MSB_INTEGER", px, 64 * 64 * 2 - 10);
  try {
    (void)io::loadImage8(truncated);
    FAIL("a truncated image must not load");
  } catch (const cli::InputError& e) {
    std::printf("\ntruncated: %s\n", e.what());
    STRCMP_EQUAL("^IMAGE", e.field().c_str());
  }
  const std::string bits = writePds3(dir + "/b.img", 4, 4, 12, "MSB_INTEGER", std::vector<uint16_t>(16, 1));
  try {
    (void)io::readPds3Image(bits);
    FAIL("12-bit samples are not supported");
  } catch (const cli::InputError& e) {
    STRCMP_EQUAL("IMAGE.SAMPLE_BITS", e.field().c_str());
  }
  std::ofstream(dir + "/junk.png") << "not an image";
  try {
    (void)io::loadImage8(dir + "/junk.png");
    FAIL("junk must not load");
  } catch (const cli::InputError& e) {
    STRCMP_EQUAL("image", e.field().c_str());
  }
}

// Every size, pointer and record count of the label is checked before it is narrowed or
// multiplied. Each file here read "successfully" before the checks: LINES 2^32 + 8 narrowed to 8, a
// pointer whose byte offset wrapped around to 0 (RECORD_BYTES 2^39 x 2^25 = 2^64), a pointer of 1e300
// bytes (undefined conversion), and a detached data file outside the label's folder.
TEST(ImageFile, LabelSizesAndPointersAreCheckedBeforeUse) {
  const std::string dir = test::scratchDir("image_file_limits");
  auto image = [&](const std::string& name, const std::string& record_bytes, const std::string& pointer,
                   const std::string& lines) {
    std::string label =
        "PDS_VERSION_ID = PDS3\r\nRECORD_TYPE = FIXED_LENGTH\r\nRECORD_BYTES = " + record_bytes +
        "\r\n^IMAGE = " + pointer + "\r\nOBJECT = IMAGE\r\n  LINES = " + lines +
        "\r\n  LINE_SAMPLES = 8\r\n  SAMPLE_TYPE = UNSIGNED_INTEGER\r\n  SAMPLE_BITS = 8\r\n"
        "END_OBJECT = IMAGE\r\nEND\r\n";
    label.resize(512, ' ');
    std::ofstream(dir + "/" + name, std::ios::binary) << label << std::string(64, '\x7f');
    return dir + "/" + name;
  };
  // The well-formed reference: 8 x 8 pixels after 512 label bytes.
  const cv::Mat ok = io::readPds3Image(image("ok.img", "512", "2", "8"));
  CHECK_EQUAL(8, ok.rows);
  CHECK_EQUAL(0x7f, static_cast<int>(ok.at<uint8_t>(7, 7)));
  struct Case {
    const char* name;
    std::string path;
    const char* field;
  };
  const Case cases[] = {
      {"lines 2^32 + 8", image("lines.img", "512", "2", "4294967304"), "IMAGE.LINES"},
      {"offset wraps to 0", image("wrap.img", "549755813888", "33554433", "8"), "^IMAGE"},
      {"pointer 1e300 bytes", image("far.img", "512", "1e300 <BYTES>", "8"), "^IMAGE"},
      {"detached ../", image("up.img", "512", "(\"../ok.img\", 2)", "8"), "^IMAGE"},
      {"detached /abs", image("abs.img", "512", "(\"" + dir + "/ok.img\", 2)", "8"), "^IMAGE"},
  };
  for (const Case& c : cases) {
    try {
      (void)io::readPds3Image(c.path);
      FAIL(c.name);
    } catch (const cli::InputError& e) {
      std::printf("\n%-20s -> %s", c.name, e.what());
      STRCMP_EQUAL(c.field, e.field().c_str());
    }
  }
  std::printf("\n");
}

TEST(ImageFile, LoadsPngThroughOpenCv) {
  if (!test::requireSharedData("m2020-navcam-cahvore")) return;
  const cv::Mat img =
      io::loadImage8(test::sharedDataDir() +
                     "/m2020-navcam-cahvore/NLF_0670_0726421423_362ECM_N0320604NCAM08111_01_095J01.png");
  CHECK_EQUAL(CV_8UC1, img.type());
  CHECK_EQUAL(1288, img.cols);
  CHECK_EQUAL(968, img.rows);
}

// readImageSize from headers only, against the size OpenCV decodes (PNG, baseline and progressive JPEG,
// binary and text PGM with a comment, colour PPM, TIFF through OpenCV, PDS3), over several sizes; a file
// that is no image names the field.
TEST(ImageFile, ImageSizeFromTheHeaderAgreesWithTheDecodedImage) {
  const std::string dir = test::scratchDir("image_size");
  const int sizes[][2] = {{1, 1}, {37, 5}, {640, 480}, {1288, 968}, {3, 2000}};
  for (const auto& s : sizes) {
    const cv::Mat img(s[1], s[0], CV_8UC3, cv::Scalar(10, 200, 30));
    const std::string stem = dir + "/i" + std::to_string(s[0]) + "x" + std::to_string(s[1]);
    std::vector<std::string> paths;
    for (const char* ext : {".png", ".jpg", ".pgm", ".ppm", ".tif"}) {
      const std::string p = stem + ext;
      const bool grey = std::string(ext) == ".pgm";
      CHECK(cv::imwrite(p, grey ? cv::Mat(s[1], s[0], CV_8UC1, cv::Scalar(3)) : img));
      paths.push_back(p);
    }
    const std::string progressive = stem + "-progressive.jpg";
    CHECK(cv::imwrite(progressive, img, {cv::IMWRITE_JPEG_PROGRESSIVE, 1}));
    paths.push_back(progressive);
    const std::string text_pgm = stem + "-text.pgm";
    std::ofstream(text_pgm) << "P2\n# a comment\n" << s[0] << " " << s[1] << "\n255\n0\n";
    paths.push_back(writePds3(stem + ".img", s[1], s[0], 8, "UNSIGNED_INTEGER",
                              std::vector<uint16_t>(static_cast<std::size_t>(s[0] * s[1]), 9)));
    for (const std::string& p : paths) {
      const io::ImageSize got = io::readImageSize(p);
      CHECK_TEXT(got.width == s[0] && got.height == s[1], p.c_str());
      if (p != text_pgm && p.find(".img") == std::string::npos) {
        const cv::Mat decoded = cv::imread(p, cv::IMREAD_UNCHANGED);
        CHECK_TEXT(decoded.cols == got.width && decoded.rows == got.height, p.c_str());
      }
    }
  }
  const std::string junk = dir + "/junk.png";
  std::ofstream(junk) << "not an image";
  try {
    (void)io::readImageSize(junk);
    FAIL("junk read");
  } catch (const cli::InputError& e) {
    STRCMP_EQUAL("image", e.field().c_str());
  }
}
