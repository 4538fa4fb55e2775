// fuzz_seeds OUT_DIR: writes small valid inputs for the fuzz targets, made with the project's own encoders,
// into OUT_DIR/<target>/ (tests/fuzz/run.sh calls it; the corpus lives in the build folder, not in git):
//   lcm_message/  every message type (fixtures of tests/platform/MessageFixtures.cpp), the type byte first;
//                 stereo pairs carry real small JPEGs and valid CAHVOR models
//   lcm_log/      LCM logs of such pairs, a status and an end-of-panorama marker
//   jpeg/         gray JPEGs of a textured pattern at several sizes and qualities
//   camera_file/  the JPL text form of CAHV, CAHVOR and CAHVORE models
//   site/         site announcements of a 3-site traverse (first, a traversing stop, last) and a truncated
//   one
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "areomap/camera_model_t.hpp"
#include "areomap/coarse_dem_t.hpp"
#include "areomap/eo_entry_t.hpp"
#include "areomap/eo_solution_t.hpp"
#include "areomap/product_t.hpp"
#include "areomap/rover_status_t.hpp"
#include "areomap/site_t.hpp"
#include "areomap/stereo_image_t.hpp"
#include "areomap/stereo_pair_t.hpp"
#include "areomap/tiepoints_t.hpp"
#include "firmware_core/base/Capacities.hpp"
#include "firmware_core/camera/CameraModel.hpp"
#include "msgs/Channels.hpp"
#include "msgs/adapters/MessageAdapters.hpp"
#include "platform/posix/TurboJpegCodec.hpp"
#include "tests/msgs/SiteFixture.hpp"
#include "tests/platform/MessageFixtures.hpp"

namespace {

using Bytes = std::vector<uint8_t>;
std::string g_out;

void write(const std::string& target, const std::string& name, const Bytes& bytes) {
  const std::string dir = g_out + "/" + target;
  std::filesystem::create_directories(dir);
  std::FILE* f = std::fopen((dir + "/" + name).c_str(), "wb");
  if (f == nullptr || std::fwrite(bytes.data(), 1, bytes.size(), f) != bytes.size() || std::fclose(f) != 0) {
    std::perror((dir + "/" + name).c_str());
    std::exit(1);
  }
}

template <class Message>
void writeMessage(uint8_t type_byte, const std::string& name, const Message& m) {
  Bytes bytes = areomap::test::encode(m);
  bytes.insert(bytes.begin(), type_byte);
  write("lcm_message", name, bytes);
}

Bytes jpeg(int width, int height, int quality, int seed) {
  static areomap::platform::TurboJpegCodec codec;
  static const bool opened = areomap::ok(codec.open());
  std::vector<uint8_t> pixels(static_cast<std::size_t>(width) * static_cast<std::size_t>(height));
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      pixels[static_cast<std::size_t>(y * width + x)] =
          static_cast<uint8_t>((x * 7 + y * 13 + seed * 31 + ((x / 4 + y / 4) % 2) * 90) & 0xFF);
    }
  }
  Bytes out(codec.maxEncodedBytes(width, height));
  std::size_t used = 0;
  if (!opened ||
      !areomap::ok(codec.encodeGray(pixels.data(), width, height, quality, out.data(), out.size(), used))) {
    std::fprintf(stderr, "fuzz_seeds: JPEG encoding failed\n");
    std::exit(1);
  }
  out.resize(used);
  return out;
}

areomap::CameraModel model(areomap::CameraType type, int seed) {
  areomap::CameraModel m;
  m.type = type;
  m.c = areomap::Vec3(0.1 * seed, 0.2, -1.5);
  m.a = areomap::Vec3(1.0, 0.0, 0.0);
  m.h = areomap::Vec3(32.0, 40.0, 0.0);
  m.v = areomap::Vec3(24.0, 0.0, 40.0);
  m.width = 64;
  m.height = 48;
  if (type != areomap::CameraType::kCahv) {
    m.o = m.a;
    m.r = areomap::Vec3(0.0, 1e-3 * seed, -2e-4);
  }
  if (type == areomap::CameraType::kCahvore) {
    m.e = areomap::Vec3(0.01, 0.001, 0.0);
    m.cahvore_kind = areomap::CahvoreKind::kGeneral;
    m.linearity = 0.5;
  }
  return m;
}

areomap::stereo_pair_t pair(int sequence, bool right) {
  areomap::stereo_pair_t p = areomap::test::makeStereoPair(sequence, 0);
  p.sequence = sequence;
  p.kind = areomap::stereo_pair_t::KIND_PAIR;
  p.has_right = right;
  areomap::stereo_image_t* sides[] = {&p.left, &p.right};
  for (int s = 0; s < (right ? 2 : 1); ++s) {
    areomap::stereo_image_t& side = *sides[s];
    side.jpeg = jpeg(64, 48, 90, sequence + s);
    side.jpeg_bytes = static_cast<int32_t>(side.jpeg.size());
    side.width_px = 64;
    side.height_px = 48;
    areomap::toMessage(model(areomap::CameraType::kCahvor, sequence + s), side.model);
  }
  if (!right) {
    p.right.jpeg.clear();
    p.right.jpeg_bytes = 0;
  }
  return p;
}

// One LCM log event (the format of lcm-logger: sync word, event number, utime, lengths, channel, data).
void appendEvent(Bytes& log, int64_t number, const char* channel, const Bytes& data) {
  auto be = [&](uint64_t v, int bytes) {
    for (int i = bytes - 1; i >= 0; --i) log.push_back(static_cast<uint8_t>(v >> (8 * i)));
  };
  be(0xEDA1DA01u, 4);
  be(static_cast<uint64_t>(number), 8);
  be(static_cast<uint64_t>(1000000 * number), 8);
  const std::string ch = channel;
  be(ch.size(), 4);
  be(data.size(), 4);
  log.insert(log.end(), ch.begin(), ch.end());
  log.insert(log.end(), data.begin(), data.end());
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2 || std::string(argv[1]) == "--help") {
    std::fprintf(argc == 2 ? stdout : stderr, "usage: fuzz_seeds OUT_DIR\n");
    return argc == 2 ? 0 : 2;
  }
  g_out = argv[1];
  using namespace areomap;
  // Messages: the type byte of LcmMessageFuzz.cpp first (0 pair, 1 image, 2 model, 3 ties, 4 EO, 5 EO entry,
  // 6 DEM, 7 status, 8 product).
  const stereo_pair_t p0 = pair(0, true);
  writeMessage(0, "stereo_pair", p0);
  writeMessage(0, "stereo_pair_left_only", pair(1, false));
  stereo_pair_t end = test::makeStereoPair(2, 0);
  end.kind = stereo_pair_t::KIND_END_OF_PANORAMA;
  end.has_right = false;
  writeMessage(0, "end_of_panorama", end);
  writeMessage(1, "stereo_image", p0.left);
  camera_model_t cm;
  toMessage(model(CameraType::kCahvore, 3), cm);
  writeMessage(2, "camera_model_cahvore", cm);
  writeMessage(2, "camera_model_fixture", test::makeCameraModel(4));
  writeMessage(3, "tiepoints", test::makeTiePoints(5, 6));
  const eo_solution_t eo = test::makeEoSolution(6, 2);
  writeMessage(4, "eo_solution", eo);
  writeMessage(5, "eo_entry", eo.images.at(0));
  writeMessage(6, "coarse_dem", test::makeCoarseDem(7, 3, 4));
  writeMessage(7, "rover_status", test::makeRoverStatus(8));
  writeMessage(8, "product", test::makeProduct(9, 2));

  // Site announcements (SiteFuzz.cpp: the encoded site_t alone).
  for (int k = 0; k < 3; ++k) {
    site_t s = test::makeSite(k, 3);
    if (k == 1) s.kind = site_t::KIND_STOP;  // a traversing stop between the two panorama sites
    const Bytes bytes = test::encode(s);
    write("site", "site_" + std::to_string(k + 1) + "_of_3", bytes);
    if (k == 1)
      write("site", "site_2_of_3_truncated",
            Bytes(bytes.begin(), bytes.begin() + static_cast<long>(bytes.size() / 2)));
  }

  // Logs.
  Bytes log;
  appendEvent(log, 0, channels::kStereoPair, test::encode(p0));
  appendEvent(log, 1, channels::kRoverStatus, test::encode(test::makeRoverStatus(1)));
  appendEvent(log, 2, channels::kStereoPair, test::encode(pair(1, false)));
  appendEvent(log, 3, channels::kStereoPair, test::encode(end));
  write("lcm_log", "pairs_status_end.lcm", log);
  Bytes small;
  appendEvent(small, 0, channels::kRoverStatus, test::encode(test::makeRoverStatus(2)));
  appendEvent(small, 1, "OTHER_CHANNEL", Bytes{1, 2, 3});
  write("lcm_log", "status_other.lcm", small);

  // JPEGs.
  write("jpeg", "64x48_q90.jpg", jpeg(64, 48, 90, 1));
  write("jpeg", "16x16_q50.jpg", jpeg(16, 16, 50, 2));
  write("jpeg", "33x7_q10.jpg", jpeg(33, 7, 10, 3));
  write("jpeg", "1x1_q100.jpg", jpeg(1, 1, 100, 4));

  // Camera model text.
  const CameraType types[] = {CameraType::kCahv, CameraType::kCahvor, CameraType::kCahvore};
  const char* names[] = {"model.cahv", "model.cahvor", "model.cahvore"};
  for (int i = 0; i < 3; ++i) {
    char text[kModelTextBytes];
    const std::size_t n = formatModelText(model(types[i], i), text, sizeof text);
    write("camera_file", names[i], Bytes(text, text + n));
  }
  std::printf("fuzz_seeds: wrote seeds into %s\n", g_out.c_str());
  return 0;
}
