#include "firmware_core/camera/Binning.hpp"

#include "firmware_core/base/Capacities.hpp"

namespace areomap {

CameraModel rescaledModel(const CameraModel& model, double scale, const Vec2& offset_px, int32_t width,
                          int32_t height) {
  CameraModel m = model;
  m.h = (model.h - offset_px.x() * model.a) / scale;
  m.v = (model.v - offset_px.y() * model.a) / scale;
  m.width = width;
  m.height = height;
  return m;
}

int32_t binningFactor(int32_t width, int32_t height) {
  // floor(n / b) <= cap  <=>  n < b (cap + 1)  <=>  b >= floor(n / (cap + 1)) + 1.
  const int32_t bw = (width > 0 ? width : 0) / (kMaxImageWidth + 1) + 1;
  const int32_t bh = (height > 0 ? height : 0) / (kMaxImageHeight + 1) + 1;
  return bw > bh ? bw : bh;
}

CameraModel binnedModel(const CameraModel& model, int32_t b) {
  if (b <= 1) return model;
  const double offset = 0.5 * (b - 1);
  return rescaledModel(model, b, Vec2(offset, offset), model.width / b, model.height / b);
}

CameraModel unbinnedModel(const CameraModel& binned, int32_t b, int32_t width, int32_t height) {
  if (b <= 1) {
    CameraModel m = binned;
    m.width = width;
    m.height = height;
    return m;
  }
  // x = b x_b + o  <=>  x = (x_b - (-o / b)) / (1 / b).
  const double offset = -0.5 * (b - 1) / b;
  return rescaledModel(binned, 1.0 / b, Vec2(offset, offset), width, height);
}

}  // namespace areomap
