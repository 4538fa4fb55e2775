// The conversion's agreement measure, shared by the firmware and ground (real data) tests: over a 32 x 32 grid
// of cell centres of the image and ranges 2..50 m, a point on each pixel's ray (the model's own inverse)
// is projected directly and through the converted model; RMS and max of the pixel distance.
#pragma once

#include <cmath>

#include "firmware_core/camera/CameraConversion.hpp"

namespace areomap::test {

struct Agreement {
  double rms_px = 0.0;
  double max_px = 0.0;
  int points = 0;
};

constexpr double kAgreementRanges_m[] = {2.0, 5.0, 10.0, 20.0, 50.0};

template <typename SecondProjection>
Agreement agreementOver(const CameraModel& model, SecondProjection second) {
  Agreement g;
  double sum2 = 0.0;
  for (int j = 0; j < 32; ++j) {
    for (int i = 0; i < 32; ++i) {
      const Vec2 pixel(-0.5 + model.width * (i + 0.5) / 32.0, -0.5 + model.height * (j + 0.5) / 32.0);
      Vec3 origin, dir;
      if (unproject(model, pixel, origin, dir) != Status::kOk) continue;
      for (double range : kAgreementRanges_m) {
        const Vec3 point = origin + range * dir;
        Vec2 direct, converted;
        if (project(model, point, direct) != Status::kOk) continue;
        if (second(point, converted) != Status::kOk) continue;
        const double e = (direct - converted).norm();
        sum2 += e * e;
        g.max_px = std::fmax(g.max_px, e);
        ++g.points;
      }
    }
  }
  g.rms_px = g.points > 0 ? std::sqrt(sum2 / g.points) : 0.0;
  return g;
}

inline Agreement agreementOverImage(const CameraModel& model, const PhotogrammetricCamera& cam) {
  return agreementOver(model, [&](const Vec3& p, Vec2& px) { return projectPhotogrammetric(cam, p, px); });
}

inline Agreement agreementBetweenModels(const CameraModel& model, const CameraModel& other) {
  return agreementOver(model, [&](const Vec3& p, Vec2& px) { return project(other, p, px); });
}

}  // namespace areomap::test
