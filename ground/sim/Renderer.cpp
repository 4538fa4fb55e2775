#include "ground/sim/Renderer.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/imgcodecs.hpp>

#include "ground/sim/Noise.hpp"
#include "ground/sim/Parallel.hpp"

namespace areomap::sim {
namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr double kAmbient = 0.18;     // sky light on surfaces in shadow
constexpr double kExposureDn = 520.0; // DN per unit radiance (albedo 0.24, sun 40 degrees -> ~110 DN)
constexpr double kSkyDn = 185.0;      // the bright Martian sky near the horizon

double skyDn(const Eigen::Vector3d& dir) {
  const double elevation = std::asin(std::clamp(-dir.z(), -1.0, 1.0));
  return kSkyDn - 60.0 * std::clamp(elevation / (30.0 * kDeg), 0.0, 1.0);
}

}  // namespace

RenderedImage renderImage(const Terrain& terrain, const SimConfig& config, const CameraModel& model, int image_index) {
  RenderedImage image;
  image.width = model.width;
  image.height = model.height;
  image.pixels.assign(static_cast<std::size_t>(image.width) * image.height, 0);
  const Eigen::Vector3d sun(std::cos(config.sun_elevation_deg * kDeg) * std::cos(config.sun_azimuth_deg * kDeg),
                            std::cos(config.sun_elevation_deg * kDeg) * std::sin(config.sun_azimuth_deg * kDeg),
                            -std::sin(config.sun_elevation_deg * kDeg));
  const int s = config.supersample;
  const uint64_t noise_seed = hash3(config.seed, 0x1a6e, image_index);
  const double far_elevation = terrain.farElevation();

  parallelFor(image.height, config.threads, [&](int row) {
    for (int col = 0; col < image.width; ++col) {
      double sum = 0.0;
      for (int a = 0; a < s; ++a) {
        for (int b = 0; b < s; ++b) {
          const Vec2 pixel(col - 0.5 + (b + 0.5) / s, row - 0.5 + (a + 0.5) / s);
          Vec3 origin, dir;
          if (unproject(model, pixel, origin, dir) != Status::kOk) {
            sum += kSkyDn;
            continue;
          }
          double t = 0.0;
          Eigen::Vector3d hit;
          Eigen::Vector3d normal(0.0, 0.0, -1.0);
          bool on_grid = terrain.castRay(origin, dir, t);
          if (on_grid) {
            hit = origin + t * dir;
            normal = terrain.normal(hit.x(), hit.y());
          } else if (dir.z() > 1e-9 && -origin.z() > far_elevation) {
            // Beyond the grid: a flat far plane at the mean edge elevation.
            t = (-far_elevation - origin.z()) / dir.z();
            hit = origin + t * dir;
            if (terrain.inside(hit.x(), hit.y())) {
              sum += skyDn(dir);  // under the grid's relief range but not hit: treat as sky (rare)
              continue;
            }
          } else {
            sum += skyDn(dir);
            continue;
          }
          double direct = std::max(0.0, normal.dot(sun));
          if (config.shadows && direct > 0.0 && on_grid) {
            double ts = 0.0;
            if (terrain.castRay(hit + 1e-3 * normal, sun, ts)) direct = 0.0;
          }
          const double radiance = terrain.albedo(hit.x(), hit.y()) * (kAmbient + (1.0 - kAmbient) * direct / std::max(0.2, -sun.z()) * 0.8);
          sum += kExposureDn * radiance;
        }
      }
      double dn = sum / (s * s);
      if (config.noise_dn > 0.0) {
        const uint64_t h = hash3(noise_seed, row, col);
        dn += config.noise_dn * gaussian(mix64(h), mix64(h + 1));
      }
      image.pixels[static_cast<std::size_t>(row) * image.width + col] =
          static_cast<uint8_t>(std::clamp(std::lround(dn), 0L, 255L));
    }
  });

  if (config.jpeg_quality > 0) {
    const cv::Mat view(image.height, image.width, CV_8UC1, image.pixels.data());
    std::vector<uchar> bytes;
    cv::imencode(".jpg", view, bytes, {cv::IMWRITE_JPEG_QUALITY, config.jpeg_quality});
    const cv::Mat decoded = cv::imdecode(bytes, cv::IMREAD_GRAYSCALE);
    std::copy(decoded.data, decoded.data + image.pixels.size(), image.pixels.begin());
  }
  return image;
}

}  // namespace areomap::sim
