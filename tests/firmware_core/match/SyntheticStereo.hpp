// Test scenes for the matcher: a rover mast stereo pair (CAHV, baseline along image x) looking down at a
// textured ground plane Z = 0 of the site frame (Z down), rendered by ray casting with 3x3 supersampling.
// The truth of a left pixel is its ray's intersection with the plane.
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include "firmware_core/base/EigenTypes.hpp"
#include "firmware_core/base/ImageView.hpp"
#include "firmware_core/camera/CameraModel.hpp"

namespace areomap::test {

inline double latticeValue(int64_t i, int64_t j, uint32_t seed) {
  uint64_t h = static_cast<uint64_t>(i) * 0x9E3779B97F4A7C15ull ^ (static_cast<uint64_t>(j) + 0x632BE59BD9B4E019ull) * 0xC2B2AE3D27D4EB4Full ^ seed * 0x165667B19E3779F9ull;
  h ^= h >> 31;
  h *= 0xBF58476D1CE4E5B9ull;
  h ^= h >> 29;
  return static_cast<double>(h & 0xFFFFFF) / static_cast<double>(0xFFFFFF);
}

inline double valueNoise(double u, double v, uint32_t seed) {
  const double fu = std::floor(u), fv = std::floor(v);
  const int64_t i = static_cast<int64_t>(fu), j = static_cast<int64_t>(fv);
  double a = u - fu, b = v - fv;
  a = a * a * (3.0 - 2.0 * a);
  b = b * b * (3.0 - 2.0 * b);
  const double v00 = latticeValue(i, j, seed), v10 = latticeValue(i + 1, j, seed);
  const double v01 = latticeValue(i, j + 1, seed), v11 = latticeValue(i + 1, j + 1, seed);
  return (1 - a) * (1 - b) * v00 + a * (1 - b) * v10 + (1 - a) * b * v01 + a * b * v11;
}

// Ground texture (grey 0..255) at site (X, Y) metres.
inline double groundTexture(double x, double y, uint32_t seed) {
  return 255.0 * (0.45 * valueNoise(x / 0.012, y / 0.012, seed) + 0.35 * valueNoise(x / 0.04, y / 0.04, seed + 1) +
                  0.20 * valueNoise(x / 0.15, y / 0.15, seed + 2));
}

// A CAHV camera at `centre` looking along azimuth `azimuth_rad` (from north towards east) and tilted
// down by `tilt_rad`, focal `f_px`, principal point at the image centre.
inline CameraModel mastCamera(const Vec3& centre, double azimuth_rad, double tilt_rad, double f_px, int32_t size) {
  const Vec3 forward(std::cos(azimuth_rad) * std::cos(tilt_rad), std::sin(azimuth_rad) * std::cos(tilt_rad),
                     std::sin(tilt_rad));
  const Vec3 right(-std::sin(azimuth_rad), std::cos(azimuth_rad), 0.0);
  const Vec3 down = forward.cross(right) * -1.0;  // image down: +Z component
  const double c0 = 0.5 * (size - 1);
  CameraModel m;
  m.type = CameraType::kCahv;
  m.c = centre;
  m.a = forward;
  m.h = f_px * right + c0 * forward;
  m.v = f_px * (down.z() > 0 ? down : Vec3(-down)) + c0 * forward;
  m.width = size;
  m.height = size;
  return m;
}

struct StereoScene {
  CameraModel left;
  CameraModel right;
  std::vector<uint8_t> left_pixels;
  std::vector<uint8_t> right_pixels;
  int32_t size = 0;
  ImageView leftView() const { return ImageView{left_pixels.data(), size, size, size}; }
  ImageView rightView() const { return ImageView{right_pixels.data(), size, size, size}; }
};

// Intersection of a pixel's ray with the ground plane Z = 0; false above the horizon.
inline bool groundPoint(const CameraModel& m, const Vec2& px, Vec3& point) {
  Vec3 o, d;
  if (unproject(m, px, o, d) != Status::kOk || d.z() <= 1e-9) return false;
  point = o + d * (-o.z() / d.z());
  return true;
}

inline void renderGround(const CameraModel& m, int32_t size, uint32_t seed, std::vector<uint8_t>& pixels) {
  pixels.assign(static_cast<size_t>(size) * size, 0);
  for (int32_t y = 0; y < size; ++y) {
    for (int32_t x = 0; x < size; ++x) {
      double sum = 0.0;
      for (int32_t sy = -1; sy <= 1; ++sy) {
        for (int32_t sx = -1; sx <= 1; ++sx) {
          Vec3 p;
          if (groundPoint(m, Vec2(x + sx / 3.0, y + sy / 3.0), p)) sum += groundTexture(p.x(), p.y(), seed);
        }
      }
      pixels[static_cast<size_t>(y) * size + x] = static_cast<uint8_t>(std::lround(std::fmin(255.0, sum / 9.0)));
    }
  }
}

// The pair: mast at 1.5 m (Z = -1.5), baseline 0.2 m, 45 degree field of view.
inline StereoScene makeStereoScene(int32_t size, double azimuth_rad = 0.0, double tilt_rad = 0.7,
                                   uint32_t seed = 7) {
  StereoScene s;
  s.size = size;
  const double f_px = 0.5 * size / std::tan(0.5 * 0.785);
  const Vec3 right_axis(-std::sin(azimuth_rad), std::cos(azimuth_rad), 0.0);
  const Vec3 mast(0.0, 0.0, -1.5);
  s.left = mastCamera(mast - 0.1 * right_axis, azimuth_rad, tilt_rad, f_px, size);
  s.right = mastCamera(mast + 0.1 * right_axis, azimuth_rad, tilt_rad, f_px, size);
  renderGround(s.left, size, seed, s.left_pixels);
  renderGround(s.right, size, seed, s.right_pixels);
  return s;
}

}  // namespace areomap::test
