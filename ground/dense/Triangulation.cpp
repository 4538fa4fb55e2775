#include "ground/dense/Triangulation.hpp"

#include <cmath>
#include <cstring>
#include <fstream>
#include <stdexcept>

#include <Eigen/Dense>

namespace areomap::dense {

namespace {

constexpr int kMaxGaussNewtonIterations = 10;
constexpr double kStepToleranceM = 1e-9;
constexpr double kMinRayAngleRad = 1e-5;   // rays closer to parallel than this do not intersect
constexpr double kJacobianStepM = 1e-6;     // central-difference step (relative to the range)

bool projectBoth(const CameraModel& l, const CameraModel& r, const Vec3& p, Eigen::Vector4d& uv) {
  Vec2 a, b;
  if (project(l, p, a) != Status::kOk || project(r, p, b) != Status::kOk) return false;
  uv << a.x(), a.y(), b.x(), b.y();
  return true;
}

}  // namespace

bool triangulate(const CameraModel& left, const CameraModel& right, const Vec2& left_px, const Vec2& right_px,
                 double sigma_px, CloudPoint& out) {
  Vec3 o1, d1, o2, d2;
  if (unproject(left, left_px, o1, d1) != Status::kOk || unproject(right, right_px, o2, d2) != Status::kOk) {
    return false;
  }
  // Closest approach of the two rays.
  const Vec3 w = o1 - o2;
  const double b = d1.dot(d2), d = d1.dot(w), e = d2.dot(w);
  const double denom = 1.0 - b * b;  // unit directions
  if (denom < kMinRayAngleRad * kMinRayAngleRad) return false;
  const double s = (b * e - d) / denom;
  const double t = (e - b * d) / denom;
  if (!(s > 0.0) || !(t > 0.0)) return false;
  Vec3 p = 0.5 * ((o1 + s * d1) + (o2 + t * d2));
  Eigen::Vector4d obs;
  obs << left_px.x(), left_px.y(), right_px.x(), right_px.y();
  Eigen::Matrix<double, 4, 3> j;
  Eigen::Vector4d uv;
  for (int it = 0; it < kMaxGaussNewtonIterations; ++it) {
    if (!projectBoth(left, right, p, uv)) return false;
    const double h = kJacobianStepM * std::max(1.0, (p - o1).norm());
    for (int k = 0; k < 3; ++k) {
      Vec3 pp = p, pm = p;
      pp(k) += h;
      pm(k) -= h;
      Eigen::Vector4d up, um;
      if (!projectBoth(left, right, pp, up) || !projectBoth(left, right, pm, um)) return false;
      j.col(k) = (up - um) / (2.0 * h);
    }
    const Vec3 step = (j.transpose() * j).ldlt().solve(j.transpose() * (obs - uv));
    if (!step.allFinite()) return false;
    p += step;
    if (step.norm() < kStepToleranceM) break;
  }
  if (!projectBoth(left, right, p, uv)) return false;
  const Mat3 normal = j.transpose() * j;
  const Eigen::FullPivLU<Mat3> lu(normal);
  if (!lu.isInvertible()) return false;
  out.site_m = p;
  out.covariance_m2 = sigma_px * sigma_px * lu.inverse();
  out.residual_px = std::sqrt((obs - uv).squaredNorm() / 4.0);
  return true;
}

std::vector<CloudPoint> triangulateDisparity(const CameraModel& left, const CameraModel& right,
                                             const cv::Mat& disparity, double sigma_px, int64_t pair_id,
                                             const cv::Mat& grey, TriangulationStats& stats,
                                             double max_residual_px) {
  if (disparity.type() != CV_32FC1) throw std::invalid_argument("triangulateDisparity: CV_32F disparity expected");
  if (!grey.empty() && (grey.type() != CV_8UC1 || grey.size() != disparity.size())) {
    throw std::invalid_argument("triangulateDisparity: grey image must be CV_8U of the disparity's size");
  }
  std::vector<CloudPoint> cloud;
  for (int y = 0; y < disparity.rows; ++y) {
    for (int x = 0; x < disparity.cols; ++x) {
      const float dsp = disparity.at<float>(y, x);
      if (!std::isfinite(dsp)) continue;
      ++stats.matches;
      CloudPoint p;
      if (!triangulate(left, right, Vec2(x, y), Vec2(x - dsp, y), sigma_px, p)) {
        ++stats.rejected_geometry;
        continue;
      }
      if (p.residual_px > max_residual_px) {
        ++stats.rejected_residual;
        continue;
      }
      p.grey = grey.empty() ? 0 : grey.at<uint8_t>(y, x);
      p.line = pair_id * 65536 + y;
      cloud.push_back(p);
      ++stats.triangulated;
    }
  }
  return cloud;
}

void writePly(const std::string& path, const std::vector<CloudPoint>& points, const std::string& comment) {
  std::ofstream f(path, std::ios::binary);
  if (!f) throw std::runtime_error(path + ": cannot open for writing");
  f << "ply\nformat binary_little_endian 1.0\n";
  f << "comment areomap point cloud, site frame (+X north, +Y east, +Z down), metres\n";
  if (!comment.empty()) f << "comment " << comment << "\n";
  f << "element vertex " << points.size() << "\n"
    << "property double x\nproperty double y\nproperty double z\n"
    << "property float sigma_x\nproperty float sigma_y\nproperty float sigma_z\n"
    << "property uchar grey\nproperty int line\nend_header\n";
  auto put = [&f](const void* data, std::size_t n) {
    // PLY binary_little_endian: write bytes in little-endian order on any host.
    const unsigned char* c = static_cast<const unsigned char*>(data);
    const uint16_t probe = 1;
    unsigned char first;
    std::memcpy(&first, &probe, 1);
    if (first == 1) {
      f.write(reinterpret_cast<const char*>(c), static_cast<std::streamsize>(n));
    } else {
      for (std::size_t i = n; i > 0; --i) f.put(static_cast<char>(c[i - 1]));
    }
  };
  for (const CloudPoint& p : points) {
    for (int k = 0; k < 3; ++k) {
      const double v = p.site_m(k);
      put(&v, sizeof v);
    }
    for (int k = 0; k < 3; ++k) {
      const float s = static_cast<float>(std::sqrt(std::max(0.0, p.covariance_m2(k, k))));
      put(&s, sizeof s);
    }
    f.put(static_cast<char>(p.grey));
    const int32_t line = static_cast<int32_t>(p.line);
    put(&line, sizeof line);
  }
  if (!f) throw std::runtime_error(path + ": write failed");
}

}  // namespace areomap::dense
