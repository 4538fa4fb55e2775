#include "tests/ground/pass/PassChecks.hpp"

#include "firmware_core/camera/Binning.hpp"
#include "ground/dense/Rectification.hpp"
#include "ground/products/DemCoverage.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>

#include <Eigen/Dense>
#include <nlohmann/json.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace areomap::test {
FeatureMatches siftMatches(const cv::Mat& left, const cv::Mat& right) {
  const cv::Ptr<cv::SIFT> sift = cv::SIFT::create(6000);
  std::vector<cv::KeyPoint> kl, kr;
  cv::Mat dl, dr;
  sift->detectAndCompute(left, cv::noArray(), kl, dl);
  sift->detectAndCompute(right, cv::noArray(), kr, dr);
  FeatureMatches out;
  if (dl.empty() || dr.empty()) return out;
  cv::BFMatcher bf(cv::NORM_L2);
  std::vector<std::vector<cv::DMatch>> lr, rl;
  bf.knnMatch(dl, dr, lr, 2);
  bf.knnMatch(dr, dl, rl, 1);
  for (const std::vector<cv::DMatch>& m : lr) {
    if (m.size() < 2 || m[0].distance >= 0.75f * m[1].distance) continue;
    if (rl[m[0].trainIdx].empty() || rl[m[0].trainIdx][0].trainIdx != m[0].queryIdx) continue;
    out.left_px.emplace_back(kl[m[0].queryIdx].pt.x, kl[m[0].queryIdx].pt.y);
    out.right_px.emplace_back(kr[m[0].trainIdx].pt.x, kr[m[0].trainIdx].pt.y);
  }
  return out;
}

double reprojectionResidualPx(const CameraModel& left, const CameraModel& right, const Vec2& left_px,
                              const Vec2& right_px) {
  Vec3 o[2], d[2];
  if (!ok(unproject(left, left_px, o[0], d[0])) || !ok(unproject(right, right_px, o[1], d[1]))) return -1.0;
  // Midpoint of the closest approach, then Gauss-Newton on the reprojection error.
  const Vec3 w = o[0] - o[1];
  const double b = d[0].dot(d[1]), dd = d[0].dot(w), e = d[1].dot(w), den = 1.0 - b * b;
  if (den < 1e-12) return -1.0;
  const double s = (b * e - dd) / den, t = (e - b * dd) / den;
  if (s <= 0.0 || t <= 0.0) return -1.0;
  Vec3 x = 0.5 * (o[0] + s * d[0] + o[1] + t * d[1]);
  const CameraModel* models[2] = {&left, &right};
  const Vec2 measured[2] = {left_px, right_px};
  double sum = 0.0;
  for (int iteration = 0; iteration < 10; ++iteration) {
    Eigen::Matrix<double, 4, 3> j;
    Eigen::Vector4d r;
    for (int k = 0; k < 2; ++k) {
      Vec2 px;
      Mat2x3 jac;
      if (!ok(project(*models[k], x, px, &jac))) return -1.0;
      r.segment<2>(2 * k) = measured[k] - px;
      j.block<2, 3>(2 * k, 0) = jac;
    }
    sum = r.squaredNorm();
    const Vec3 step = (j.transpose() * j).ldlt().solve(j.transpose() * r);
    x += step;
    if (step.norm() < 1e-9) break;
  }
  double final_sum = 0.0;
  for (int k = 0; k < 2; ++k) {
    Vec2 px;
    if (!ok(project(*models[k], x, px))) return -1.0;
    final_sum += (measured[k] - px).squaredNorm();
  }
  (void)sum;
  return std::sqrt(final_sum / 2.0);
}

ModelComparison compareModels(const FeatureMatches& m, const CameraModel& a_left, const CameraModel& a_right,
                              const CameraModel& b_left, const CameraModel& b_right, double gross_px) {
  ModelComparison c;
  double sa = 0.0, sb = 0.0;
  for (std::size_t i = 0; i < m.left_px.size(); ++i) {
    const double ra = reprojectionResidualPx(a_left, a_right, m.left_px[i], m.right_px[i]);
    const double rb = reprojectionResidualPx(b_left, b_right, m.left_px[i], m.right_px[i]);
    if (ra < 0.0 || rb < 0.0 || std::min(ra, rb) > gross_px) continue;
    sa += ra * ra;
    sb += rb * rb;
    ++c.matches;
  }
  if (c.matches > 0) {
    c.rms_a_px = std::sqrt(sa / c.matches);
    c.rms_b_px = std::sqrt(sb / c.matches);
  }
  return c;
}

namespace {

bool inside(const CameraModel& m, const Vec3& x) {
  Vec2 px;
  return ok(project(m, x, px)) && px.x() >= 0.0 && px.y() >= 0.0 && px.x() <= m.width - 1.0 &&
         px.y() <= m.height - 1.0;
}

}  // namespace

double demCoverage(const DemGrid& dem, const CameraModel& left, const CameraModel& right, double lo_m,
                   double hi_m) {
  // The ground of the band, not a far field that slopes otherwise.
  products::GroundPlane plane;
  if (!products::groundPlane(dem, left.c, 2.0 * hi_m, plane)) return -1.0;
  return products::demCoverage(dem, nullptr, left, right, plane, lo_m, hi_m).fraction();
}

RectificationCover rectificationCover(const CameraModel& left, const CameraModel& right, double range_m) {
  const dense::RectifiedPair rect = dense::rectifyPair(left, right);
  RectificationCover c;
  c.width = rect.left.width;
  c.height = rect.left.height;
  int kept = 0;
  for (int y = 0; y < left.height; y += 4) {
    for (int x = 0; x < left.width; x += 4) {
      Vec3 o, d;
      if (!ok(unproject(left, Vec2(x, y), o, d))) continue;
      if (!inside(right, o + range_m * d)) continue;
      ++c.overlap;
      Vec2 px;
      if (dense::originalToRectified(left, rect.left, Vec2(x, y), px) && px.x() >= 0.0 && px.y() >= 0.0 &&
          px.x() <= c.width - 1.0 && px.y() <= c.height - 1.0)
        ++kept;
    }
  }
  c.inside = c.overlap > 0 ? static_cast<double>(kept) / c.overlap : 0.0;
  return c;
}

namespace {

double lattice(int64_t i, int64_t j, unsigned seed) {
  uint64_t h = static_cast<uint64_t>(i) * 0x9E3779B97F4A7C15ull ^
               static_cast<uint64_t>(j) * 0xC2B2AE3D27D4EB4Full ^ (static_cast<uint64_t>(seed) << 32);
  h ^= h >> 31;
  h *= 0xBF58476D1CE4E5B9ull;
  h ^= h >> 29;
  return static_cast<double>(h & 0xFFFFFF) / 0xFFFFFF;
}

double valueNoise(double x, double y, unsigned seed) {
  const double fx = std::floor(x), fy = std::floor(y);
  const int64_t i = static_cast<int64_t>(fx), j = static_cast<int64_t>(fy);
  double u = x - fx, v = y - fy;
  u = u * u * (3.0 - 2.0 * u);
  v = v * v * (3.0 - 2.0 * v);
  return (1 - v) * ((1 - u) * lattice(i, j, seed) + u * lattice(i + 1, j, seed)) +
         v * ((1 - u) * lattice(i, j + 1, seed) + u * lattice(i + 1, j + 1, seed));
}

// An octave finer than two pixel footprints fades to its mean (0.5): a camera integrates over its pixel,
// and point samples of finer detail would alias differently in each view.
double texture(double x, double y, double footprint_m, unsigned seed) {
  const double cells_m[4] = {0.01, 0.03, 0.1, 0.3};
  const double weight[4] = {0.35, 0.3, 0.2, 0.15};
  double t = 0.0;
  for (int o = 0; o < 4; ++o) {
    const double keep = std::clamp(cells_m[o] / (2.0 * footprint_m) - 1.0, 0.0, 1.0);
    t += weight[o] * (keep * valueNoise(x / cells_m[o], y / cells_m[o], seed + o) + (1.0 - keep) * 0.5);
  }
  return t;
}

}  // namespace

bool planePoint(const CameraModel& model, const Vec2& pixel, double plane_z_m, Vec3& point) {
  Vec3 o, d;
  if (!ok(unproject(model, pixel, o, d)) || d.z() * (plane_z_m - o.z()) <= 0.0) return false;
  const double t = (plane_z_m - o.z()) / d.z();
  if (t > 200.0) return false;  // beyond the scene
  point = o + t * d;
  return true;
}

CameraModel navcam(bool right) {
  CameraModel m;
  m.type = CameraType::kCahvore;
  m.cahvore_kind = CahvoreKind::kFisheye;
  m.linearity = 0.0;
  m.width = 1280;
  m.height = 960;
  if (!right) {
    m.c = Vec3(0.947337, 0.346457, -1.90383);
    m.a = Vec3(0.861174, 0.0103048, 0.508221);
    m.h = Vec3(550.797, 746.26, 327.139);
    m.v = Vec3(42.1059, 3.07463, 883.465);
    m.o = Vec3(0.861107, 0.0117207, 0.508305);
    m.r = Vec3(1.736e-06, 0.0501396, -0.0171254);
    m.e = Vec3(-8e-09, 1e-08, -2.9e-08);
  } else {
    m.c = Vec3(0.942658, 0.770793, -1.90443);
    m.a = Vec3(0.86198, 0.0100552, 0.506857);
    m.h = Vec3(547.566, 744.218, 325.295);
    m.v = Vec3(45.7281, 1.96331, 882.562);
    m.o = Vec3(0.862372, 0.00968278, 0.506198);
    m.r = Vec3(4.24e-07, 0.0517186, -0.0187155);
    m.e = Vec3(1.2e-08, 3e-08, -3e-09);
  }
  return m;
}

CameraModel detector(bool right) {
  return rescaledModel(navcam(right), 0.25, Vec2(-0.375, -0.375), 5120, 3840);
}

CameraModel tile(bool right, double x0, double y0) {
  return rescaledModel(detector(right), 2.0, Vec2(x0 + 0.5, y0 + 0.5), 1288, 968);
}

cv::Mat renderPlane(const CameraModel& model, double plane_z_m, unsigned seed) {
  constexpr int kStep = 4;
  const int gw = model.width / kStep + 2, gh = model.height / kStep + 2;
  cv::Mat grid(gh, gw, CV_64FC2, cv::Scalar(NAN, NAN));
  cv::parallel_for_(cv::Range(0, gh), [&](const cv::Range& r) {
    for (int gy = r.start; gy < r.end; ++gy) {
      for (int gx = 0; gx < gw; ++gx) {
        Vec3 p;
        if (planePoint(model, Vec2(gx * kStep, gy * kStep), plane_z_m, p))
          grid.at<cv::Vec2d>(gy, gx) = cv::Vec2d(p.x(), p.y());
      }
    }
  });
  cv::Mat image(model.height, model.width, CV_8U);
  cv::parallel_for_(cv::Range(0, model.height), [&](const cv::Range& r) {
    for (int y = r.start; y < r.end; ++y) {
      for (int x = 0; x < model.width; ++x) {
        const int gx = x / kStep, gy = y / kStep;
        const double u = static_cast<double>(x - gx * kStep) / kStep,
                     v = static_cast<double>(y - gy * kStep) / kStep;
        const cv::Vec2d a = grid.at<cv::Vec2d>(gy, gx), b = grid.at<cv::Vec2d>(gy, gx + 1);
        const cv::Vec2d c = grid.at<cv::Vec2d>(gy + 1, gx), d = grid.at<cv::Vec2d>(gy + 1, gx + 1);
        double px = 0.0, py = 0.0;
        // The ground size of a pixel, from the grid cell's sides (2 cm where the cell leaves the plane).
        const double footprint =
            std::isnan(a[0]) || std::isnan(b[0]) || std::isnan(c[0])
                ? 0.02
                : std::max(std::hypot(b[0] - a[0], b[1] - a[1]), std::hypot(c[0] - a[0], c[1] - a[1])) /
                      kStep;
        if (std::isnan(a[0]) || std::isnan(b[0]) || std::isnan(c[0]) || std::isnan(d[0])) {
          Vec3 p;
          if (!planePoint(model, Vec2(x, y), plane_z_m, p)) {
            image.at<uint8_t>(y, x) = 200;  // sky
            continue;
          }
          px = p.x();
          py = p.y();
        } else {
          px = (1 - v) * ((1 - u) * a[0] + u * b[0]) + v * ((1 - u) * c[0] + u * d[0]);
          py = (1 - v) * ((1 - u) * a[1] + u * b[1]) + v * ((1 - u) * c[1] + u * d[1]);
        }
        image.at<uint8_t>(y, x) = cv::saturate_cast<uint8_t>(30.0 + 180.0 * texture(px, py, footprint, seed));
      }
    }
  });
  return image;
}

}  // namespace areomap::test
