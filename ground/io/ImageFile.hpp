// Images for the ground side and the tools: PNG/JPEG/PGM through OpenCV, PDS3 .IMG (attached label,
// 8- or 16-bit, MSB or LSB integers, first band) read directly.
//
// 16 -> 8 bit rule (loadImage8 on a 16-bit PDS3 image): a fixed linear scale by the label's valid maximum,
// 8-bit = round(value * 255 / max), where max comes from SAMPLE_BIT_MASK (2#0000111111111111# -> 4095 for
// the 12-bit MER data) or else 2^SAMPLE_BITS - 1; values above max saturate. A fixed rule (no per-image
// stretch) keeps the two images of a pair and the frames of a panorama radiometrically comparable.
#pragma once

#include <cstdint>
#include <string>

#include <opencv2/core.hpp>

namespace areomap::io {

class Pds3Label;

// The largest image side (lines or samples) a label or metadata file may declare: 2^20 px, beyond every rover
// and orbiter frame read here, so that sizes fit int and byte counts fit size_t with room (every size read
// from a file is checked before use).
constexpr long kMaxImageSidePx = 1L << 20;

struct Pds3ImageInfo {
  int lines = 0;
  int samples = 0;
  int sample_bits = 0;  // 8 or 16
  bool big_endian = true;
  bool is_signed = false;
  int bands = 1;
  std::size_t offset_bytes = 0;  // RECORD_BYTES * (^IMAGE - 1), or the <BYTES> offset
  uint32_t valid_max = 0;        // SAMPLE_BIT_MASK, or 2^bits - 1
  std::string data_file;         // the file that holds the pixels (the label's own, or a detached one)
};

// The IMAGE object of a PDS3 label; checks that the file is long enough (field "^IMAGE"/"LINES").
Pds3ImageInfo readPds3ImageInfo(const std::string& path);
// The same from a label already parsed (label.file() is the file it came from: a detached data file is
// beside it), so that a caller that also needs the label's other groups parses it once.
Pds3ImageInfo readPds3ImageInfo(const Pds3Label& label);

// The pixels of a PDS3 image: CV_8UC1 or CV_16UC1 (first band; signed data clamped at 0).
cv::Mat readPds3Image(const std::string& path);
// The same for an IMAGE object already read (no second parse of the label).
cv::Mat readPds3Image(const Pds3ImageInfo& info);
// The pixels as 8-bit grey by the 16 -> 8 bit rule above (what loadImage8 gives for a PDS3 file).
cv::Mat readPds3Image8(const Pds3ImageInfo& info);

// True for a file that starts with a PDS3 label (PDS_VERSION_ID).
bool isPds3File(const std::string& path);

// The pixel size of an image from its header alone (PNG IHDR, JPEG SOF, PGM/PPM, PDS3 label); another format
// is decoded whole by OpenCV. Throws cli::InputError(path, "image", …) on a file it cannot tell.
struct ImageSize {
  int width = 0;
  int height = 0;
};
ImageSize readImageSize(const std::string& path);

// Any supported image as 8-bit grey (colour is converted to grey; 16-bit PDS3 by the rule above,
// 16-bit PNG by >> 8). Throws cli::InputError(path, "image", …).
cv::Mat loadImage8(const std::string& path);
// A decoded image (8-bit, 16-bit or float; 1, 3 or 4 channels) as 8-bit grey. Colour: the ITU-R BT.601
// luma 0.299 R + 0.587 G + 0.114 B (OpenCV's cvtColor). Wider data: scaled by 255 / (2^k - 1) with k the
// smallest of 8, 10, 12, 14, 16 whose range holds the image's largest value (12-bit data in 16-bit words
// -> 4095), saturating; a fixed rule per bit depth, not a per-image stretch, so that the two eyes of a pair
// stay comparable.
cv::Mat toGrey8(const cv::Mat& decoded);

// Any supported image as 16-bit grey with its native values (8-bit images are widened, not scaled).
cv::Mat loadImage16(const std::string& path);

}  // namespace areomap::io
