#include "ground/sim/Renderer.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

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

// The most taps a ray's footprint is integrated with along its long axis (see footprintRadiance).
constexpr int kMaxFootprintTaps = 32;

// Radiance integrated over a ray's footprint on the surface, not read at its centre alone. A ray stands
// for a sub-pixel of angular size `ray_rad`; where it meets the surface at incidence cosine |dir . n| its
// footprint is ray_rad * t across and ray_rad * t / |dir . n| along the projection of the ray on the surface
// (~30x longer at 50 m from a 1.5 m mast). Across it the texture is already band-limited (Terrain::albedo
// fades octaves below 1.5 pixel footprints); along it the albedo and the Lambert term are averaged over taps
// spaced at most 0.75 pixel footprints apart (a box filter; a cast shadow is taken at the centre). Without
// this, grazing ground aliases its texture along the range and each view of a stereo pair aliases it
// differently, which biased far disparities (docs/benchmarks-history.md, "Far range").
double footprintRadiance(const Terrain& terrain, const Eigen::Vector3d& hit, const Eigen::Vector3d& dir,
                         const Eigen::Vector3d& normal, bool on_grid, double t, double ray_rad, double pixel_rad,
                         const Eigen::Vector3d& sun, double shadow) {
  auto radiance = [&](double x, double y, const Eigen::Vector3d& n) {
    const double direct = std::max(0.0, n.dot(sun)) * shadow;
    return terrain.albedo(x, y) * (kAmbient + (1.0 - kAmbient) * direct / std::max(0.2, -sun.z()) * 0.8);
  };
  const double cos_incidence = std::max(0.01, std::fabs(dir.dot(normal)));
  const double length_m = ray_rad * t / cos_incidence;
  const double spacing_m = 0.75 * pixel_rad * t;
  const int taps = std::clamp(static_cast<int>(std::ceil(length_m / spacing_m)), 1, kMaxFootprintTaps);
  if (taps == 1) return radiance(hit.x(), hit.y(), normal);
  Eigen::Vector3d along = dir - dir.dot(normal) * normal;
  if (along.squaredNorm() < 1e-18) return radiance(hit.x(), hit.y(), normal);
  along *= length_m / along.norm();
  double sum = 0.0;
  for (int k = 0; k < taps; ++k) {
    const Eigen::Vector3d p = hit + ((k + 0.5) / taps - 0.5) * along;
    sum += radiance(p.x(), p.y(), on_grid ? terrain.normal(p.x(), p.y()) : normal);  // else the far plane
  }
  return sum / taps;
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
  const double pixel_rad = 1.0 / config.focalPx();

  // The pixels before the optical blur and the sensor noise.
  std::vector<double> radiance_dn(image.pixels.size(), 0.0);
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
          double shadow = 1.0;
          if (config.shadows && normal.dot(sun) > 0.0 && on_grid) {
            double ts = 0.0;
            if (terrain.castRay(hit + 1e-3 * normal, sun, ts)) shadow = 0.0;
          }
          sum += kExposureDn * footprintRadiance(terrain, hit, dir, normal, on_grid, t, pixel_rad / s, pixel_rad, sun, shadow);
        }
      }
      radiance_dn[static_cast<std::size_t>(row) * image.width + col] = sum / (s * s);
    }
  });
  if (config.blur_px > 0.0) {
    cv::Mat view(image.height, image.width, CV_64FC1, radiance_dn.data());
    cv::GaussianBlur(view, view, cv::Size(0, 0), config.blur_px, config.blur_px, cv::BORDER_REFLECT);
  }
  parallelFor(image.height, config.threads, [&](int row) {
    for (int col = 0; col < image.width; ++col) {
      double dn = radiance_dn[static_cast<std::size_t>(row) * image.width + col];
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
