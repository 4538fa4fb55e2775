#include "ground/io/ImageFile.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "ground/cli/Cli.hpp"
#include "ground/io/Pds3Label.hpp"

namespace areomap::io {
namespace {

std::size_t fileSize(const std::string& path) {
  std::error_code ec;
  const auto n = std::filesystem::file_size(path, ec);
  if (ec) throw cli::InputError(path, "file", "cannot read its size");
  return static_cast<std::size_t>(n);
}

// "2#0000111111111111#" -> 4095.
bool parseBitMask(const std::string& text, uint32_t& mask) {
  const std::size_t a = text.find('#');
  const std::size_t b = text.rfind('#');
  if (a == std::string::npos || b == a) return false;
  const std::string base = text.substr(0, a);
  const std::string digits = text.substr(a + 1, b - a - 1);
  if (base != "2" && base != "16" && base != "8") return false;
  char* end = nullptr;
  const unsigned long v = std::strtoul(digits.c_str(), &end, std::stoi(base));
  if (end == digits.c_str() || v == 0 || v > 0xFFFFFFFFul) return false;
  mask = static_cast<uint32_t>(v);
  return true;
}

uint32_t bigEndian(const unsigned char* p, int bytes) {
  uint32_t v = 0;
  for (int i = 0; i < bytes; ++i) v = (v << 8) | p[i];
  return v;
}

// PNG: the signature, then the IHDR chunk (length, "IHDR", width, height as 32-bit big-endian).
bool pngSize(const std::string& head, ImageSize& size) {
  const unsigned char* p = reinterpret_cast<const unsigned char*>(head.data());
  if (head.size() < 24 || head.compare(0, 8, "\x89PNG\r\n\x1a\n") != 0 || head.compare(12, 4, "IHDR") != 0) {
    return false;
  }
  size.width = static_cast<int>(std::min<uint32_t>(bigEndian(p + 16, 4), 0x7fffffffu));
  size.height = static_cast<int>(std::min<uint32_t>(bigEndian(p + 20, 4), 0x7fffffffu));
  return true;
}

// JPEG: the segments after SOI up to a start-of-frame marker (C0-CF except C4 DHT, C8 JPG, CC DAC), whose
// payload is precision (1 byte), lines (2), samples (2).
bool jpegSize(std::ifstream& f, ImageSize& size) {
  unsigned char b[9];
  f.seekg(0);
  if (!f.read(reinterpret_cast<char*>(b), 2) || b[0] != 0xFF || b[1] != 0xD8) return false;
  // Bounded: a JPEG header has a few dozen segments; 10000 covers any file a camera writes.
  for (int segment = 0; segment < 10000; ++segment) {
    if (!f.read(reinterpret_cast<char*>(b), 4) || b[0] != 0xFF) return false;
    const unsigned marker = b[1];
    const uint32_t length = bigEndian(b + 2, 2);
    if (length < 2) return false;
    const bool sof = marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC;
    if (sof) {
      if (!f.read(reinterpret_cast<char*>(b), 5)) return false;
      size.height = static_cast<int>(bigEndian(b + 1, 2));
      size.width = static_cast<int>(bigEndian(b + 3, 2));
      return true;
    }
    f.seekg(static_cast<std::streamoff>(length - 2), std::ios::cur);
  }
  return false;
}

// PGM/PPM/PBM (P1-P6): magic, then width and height as decimal text, '#' comments between tokens.
bool netpbmSize(const std::string& head, ImageSize& size) {
  if (head.size() < 3 || head[0] != 'P' || head[1] < '1' || head[1] > '6') return false;
  long values[2] = {0, 0};
  std::size_t i = 2;
  for (long& v : values) {
    while (i < head.size() && (std::isspace(static_cast<unsigned char>(head[i])) || head[i] == '#')) {
      if (head[i] == '#') i = head.find('\n', i);
      if (i == std::string::npos) return false;
      ++i;
    }
    const std::size_t start = i;
    while (i < head.size() && std::isdigit(static_cast<unsigned char>(head[i])) && i - start < 9) {
      v = 10 * v + (head[i++] - '0');
    }
    if (i == start) return false;
  }
  size.width = static_cast<int>(values[0]);
  size.height = static_cast<int>(values[1]);
  return true;
}

}  // namespace

ImageSize readImageSize(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw cli::InputError(path, "image", "cannot open");
  std::string head(512, '\0');
  f.read(head.data(), static_cast<std::streamsize>(head.size()));
  head.resize(static_cast<std::size_t>(f.gcount()));
  f.clear();
  ImageSize size;
  bool known = pngSize(head, size) || netpbmSize(head, size) || jpegSize(f, size);
  if (!known && head.find("PDS_VERSION_ID") != std::string::npos) {
    const Pds3ImageInfo info = readPds3ImageInfo(path);
    size = ImageSize{info.samples, info.lines};
    known = true;
  }
  if (!known) {
    const cv::Mat img = cv::imread(path, cv::IMREAD_UNCHANGED);
    if (img.empty()) throw cli::InputError(path, "image", "cannot read as PNG/JPEG/PGM or PDS3");
    size = ImageSize{img.cols, img.rows};
  }
  if (size.width < 1 || size.height < 1 || size.width > kMaxImageSidePx || size.height > kMaxImageSidePx) {
    throw cli::InputError(path, "image",
                          "header gives a size " + std::to_string(size.width) + "x" +
                              std::to_string(size.height) + " outside 1.." + std::to_string(kMaxImageSidePx) +
                              " px");
  }
  return size;
}

bool isPds3File(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  char head[64] = {};
  f.read(head, sizeof head - 1);
  return std::strstr(head, "PDS_VERSION_ID") != nullptr;
}

Pds3ImageInfo readPds3ImageInfo(const std::string& path) {
  return readPds3ImageInfo(Pds3Label::read(path));
}

Pds3ImageInfo readPds3ImageInfo(const Pds3Label& label) {
  const std::string& path = label.file();
  Pds3ImageInfo info;
  // Sizes are checked against kMaxImageSidePx before they are narrowed to int.
  const long lines = label.integer("LINES", "IMAGE");
  const long samples = label.integer("LINE_SAMPLES", "IMAGE");
  const long bands = label.find("BANDS", "IMAGE") != nullptr ? label.integer("BANDS", "IMAGE") : 1;
  if (lines <= 0 || samples <= 0 || bands <= 0) {
    throw cli::InputError(path, "IMAGE.LINES", "image size must be positive");
  }
  if (lines > kMaxImageSidePx || samples > kMaxImageSidePx || bands > kMaxImageSidePx) {
    throw cli::InputError(path, "IMAGE.LINES",
                          "image size above " + std::to_string(kMaxImageSidePx) + " px per side");
  }
  info.lines = static_cast<int>(lines);
  info.samples = static_cast<int>(samples);
  info.bands = static_cast<int>(bands);
  const long bits = label.integer("SAMPLE_BITS", "IMAGE");
  info.sample_bits = bits == 8 || bits == 16 ? static_cast<int>(bits) : 0;
  if (info.sample_bits == 0) {
    throw cli::InputError(path, "IMAGE.SAMPLE_BITS",
                          "only 8 and 16 are supported, found " + std::to_string(bits));
  }
  const std::string type = Pds3Label::unquote(label.required("SAMPLE_TYPE", "IMAGE"));
  if (type.rfind("LSB", 0) == 0 || type.rfind("PC_", 0) == 0 || type.rfind("VAX", 0) == 0) {
    info.big_endian = false;
  } else if (type.rfind("MSB", 0) == 0 || type == "UNSIGNED_INTEGER" || type == "INTEGER" ||
             type.rfind("SUN_", 0) == 0 || type.rfind("MAC_", 0) == 0) {
    info.big_endian = true;
  } else {
    throw cli::InputError(path, "IMAGE.SAMPLE_TYPE", "unsupported sample type '" + type + "'");
  }
  info.is_signed = type.find("UNSIGNED") == std::string::npos && type.find("INTEGER") != std::string::npos;
  if (info.sample_bits == 8) info.is_signed = false;  // 8-bit PDS3 images are unsigned bytes in practice
  info.valid_max = (1u << info.sample_bits) - 1u;
  if (const std::string* mask = label.find("SAMPLE_BIT_MASK", "IMAGE")) {
    uint32_t m = 0;
    if (parseBitMask(Pds3Label::unquote(*mask), m)) info.valid_max = std::min(m, info.valid_max);
  }

  // ^IMAGE = n (records, 1-based) | n <BYTES> (1-based byte) | ("FILE", n) (detached).
  const std::string pointer = label.required("^IMAGE", "");
  info.data_file = path;
  std::string where = pointer;
  // A detached data file is a plain file name beside the label (safe inputs: no folder, no "..").
  auto detached = [&](const std::string& name) {
    if (name.empty() || name == "." || name == ".." || name.find('/') != std::string::npos) {
      throw cli::InputError(
          path, "^IMAGE", "a detached data file must be a file name beside the label, found '" + name + "'");
    }
    return (std::filesystem::path(path).parent_path() / name).string();
  };
  if (pointer.find('(') != std::string::npos) {
    const std::vector<std::string> items = Pds3Label::tuple(pointer);
    if (items.empty()) throw cli::InputError(path, "^IMAGE", "malformed pointer '" + pointer + "'");
    info.data_file = detached(items[0]);
    where = items.size() > 1 ? items[1] : "1";
  } else if (!pointer.empty() && pointer[0] == '"') {
    info.data_file = detached(Pds3Label::unquote(pointer));
    where = "1";
  }
  char* end = nullptr;
  const double at = std::strtod(Pds3Label::unquote(where).c_str(), &end);
  if (!(at >= 1.0)) throw cli::InputError(path, "^IMAGE", "malformed pointer '" + pointer + "'");
  // The offset and the end of the image in double first: a pointer or record size from the label may be
  // any number, and only one within the file is narrowed to size_t (no overflow, no wrap-around).
  const std::size_t have = fileSize(info.data_file);
  double offset = at - 1.0;
  if (where.find("<BYTES>") == std::string::npos) {
    const long record_bytes = label.integer("RECORD_BYTES", "");
    if (record_bytes <= 0) throw cli::InputError(path, "RECORD_BYTES", "must be positive");
    offset = static_cast<double>(record_bytes) * std::floor(offset);
  }
  const double image_bytes = static_cast<double>(info.lines) * static_cast<double>(info.samples) *
                             static_cast<double>(info.sample_bits / 8);
  if (offset + image_bytes > static_cast<double>(have)) {
    char what[200];
    std::snprintf(what, sizeof what,
                  "file truncated: the label's image (LINES %d x LINE_SAMPLES %d x %d bit at byte %.0f) "
                  "needs %.0f bytes, the file has %zu",
                  info.lines, info.samples, info.sample_bits, offset, offset + image_bytes, have);
    throw cli::InputError(info.data_file, "^IMAGE", what);
  }
  info.offset_bytes = static_cast<std::size_t>(offset);
  return info;
}

cv::Mat readPds3Image(const std::string& path) {
  return readPds3Image(readPds3ImageInfo(path));
}

cv::Mat readPds3Image(const Pds3ImageInfo& info) {
  const std::size_t bytes_per = static_cast<std::size_t>(info.sample_bits / 8);
  const std::size_t n = static_cast<std::size_t>(info.lines) * static_cast<std::size_t>(info.samples);
  std::vector<unsigned char> raw(n * bytes_per);
  std::ifstream f(info.data_file, std::ios::binary);
  f.seekg(static_cast<std::streamoff>(info.offset_bytes));
  f.read(reinterpret_cast<char*>(raw.data()), static_cast<std::streamsize>(raw.size()));
  if (static_cast<std::size_t>(f.gcount()) != raw.size()) {
    throw cli::InputError(info.data_file, "^IMAGE", "short read");
  }
  if (info.sample_bits == 8) {
    cv::Mat img(info.lines, info.samples, CV_8UC1);
    std::memcpy(img.data, raw.data(), raw.size());
    return img;
  }
  cv::Mat img(info.lines, info.samples, CV_16UC1);
  uint16_t* out = img.ptr<uint16_t>(0);
  for (std::size_t i = 0; i < n; ++i) {
    const unsigned char b0 = raw[2 * i], b1 = raw[2 * i + 1];
    const uint16_t v =
        info.big_endian ? static_cast<uint16_t>((b0 << 8) | b1) : static_cast<uint16_t>((b1 << 8) | b0);
    out[i] = info.is_signed && (v & 0x8000u) != 0 ? 0 : v;
  }
  return img;
}

cv::Mat loadImage16(const std::string& path) {
  if (isPds3File(path)) {
    cv::Mat img = readPds3Image(path);
    if (img.type() == CV_16UC1) return img;
    cv::Mat wide;
    img.convertTo(wide, CV_16UC1);
    return wide;
  }
  cv::Mat img = cv::imread(path, cv::IMREAD_ANYDEPTH | cv::IMREAD_GRAYSCALE);
  if (img.empty()) throw cli::InputError(path, "image", "cannot read as PNG/JPEG/PGM or PDS3");
  if (img.depth() != CV_16U) {
    cv::Mat wide;
    img.convertTo(wide, CV_16UC1);
    return wide;
  }
  return img;
}

cv::Mat readPds3Image8(const Pds3ImageInfo& info) {
  cv::Mat img = readPds3Image(info);
  if (img.type() == CV_8UC1) return img;
  cv::Mat out;
  img.convertTo(out, CV_8UC1, 255.0 / static_cast<double>(info.valid_max));  // rounds and saturates
  return out;
}

cv::Mat toGrey8(const cv::Mat& decoded) {
  cv::Mat grey = decoded;
  if (decoded.channels() == 3) cv::cvtColor(decoded, grey, cv::COLOR_BGR2GRAY);
  if (decoded.channels() == 4) cv::cvtColor(decoded, grey, cv::COLOR_BGRA2GRAY);
  if (grey.depth() == CV_8U) return grey;
  double lo = 0.0, hi = 0.0;
  cv::minMaxLoc(grey, &lo, &hi);
  double top = 255.0;
  for (int bits = 8; bits <= 16; bits += 2) {
    top = std::ldexp(1.0, bits) - 1.0;
    if (hi <= top) break;
  }
  cv::Mat out;
  grey.convertTo(out, CV_8U, 255.0 / top);  // saturating
  return out;
}

cv::Mat loadImage8(const std::string& path) {
  if (isPds3File(path)) return readPds3Image8(readPds3ImageInfo(path));  // the label read once
  cv::Mat img = cv::imread(path, cv::IMREAD_GRAYSCALE);
  if (img.empty()) throw cli::InputError(path, "image", "cannot read as PNG/JPEG/PGM or PDS3");
  return img;
}

}  // namespace areomap::io
