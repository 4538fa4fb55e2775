#include "tests/fuzz/FuzzSupport.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>

#include "firmware_core/base/Capacities.hpp"

namespace areomap::fuzz {

const std::string& scratchFolder() {
  static const std::string folder = [] {
    const char* tmp = std::getenv("TMPDIR");
    std::string dir = std::string(tmp != nullptr && tmp[0] != '\0' ? tmp : "/tmp") + "/areomap-fuzz-" +
                      std::to_string(static_cast<long>(::getpid()));
    if (::mkdir(dir.c_str(), 0700) != 0 && errno != EEXIST) {
      std::perror(dir.c_str());
      std::abort();
    }
    return dir;
  }();
  return folder;
}

void writeFile(const std::string& path, const uint8_t* data, std::size_t size) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (f == nullptr || (size > 0 && std::fwrite(data, 1, size, f) != size) || std::fclose(f) != 0) {
    std::perror(path.c_str());
    std::abort();
  }
}

void fail(const char* target, const char* what) {
  std::fprintf(stderr, "fuzz %s: invariant broken: %s\n", target, what);
  std::abort();
}

void exerciseModel(const CameraModel& model, const char* target) {
  const char* field = "";
  if (!ok(validateModel(model, field))) return;
  Vec2 pixel;
  (void)project(model, model.c + 10.0 * model.a, pixel);
  Vec3 origin, direction;
  (void)unproject(model, Vec2(0.5 * model.width, 0.5 * model.height), origin, direction);
  char text[kModelTextBytes];
  const std::size_t n = formatModelText(model, text, sizeof text);
  if (n == 0) fail(target, "a valid model does not fit kModelTextBytes");
  CameraModel back;
  if (!ok(parseModelText(text, n, back, field))) fail(target, "formatModelText wrote text that does not parse");
  const Vec3* a[] = {&model.c, &model.a, &model.h, &model.v, &model.o, &model.r, &model.e};
  const Vec3* b[] = {&back.c, &back.a, &back.h, &back.v, &back.o, &back.r, &back.e};
  const int components = model.type == CameraType::kCahv ? 4 : (model.type == CameraType::kCahvor ? 6 : 7);
  for (int k = 0; k < components; ++k) {
    if (*a[k] != *b[k]) fail(target, "the text form does not round-trip a component");
  }
  if (back.type != model.type) fail(target, "the text form does not round-trip the type");
  // The text form writes the size only when both sides are known ("Dimensions = W H"); a model with one
  // side 0 (unknown) reads back as 0 x 0 (noted in tests/README.md, left as it is).
  const bool sized = model.width > 0 && model.height > 0;
  if ((sized && (back.width != model.width || back.height != model.height)) ||
      (!sized && (back.width != 0 || back.height != 0))) {
    fail(target, "the text form does not round-trip the size");
  }
}

}  // namespace areomap::fuzz
