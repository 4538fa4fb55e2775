#include "ground/dense/Triangulation.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <stdexcept>

#include "firmware_core/base/Solve3.hpp"
#include "ground/dense/LineId.hpp"

namespace areomap::dense {

bool triangulate(const CameraModel& left, const CameraModel& right, const Vec2& left_px, const Vec2& right_px,
                 double sigma_px, CloudPoint& out) {
  const CameraModel* models[2] = {&left, &right};
  const Vec2 pixels[2] = {left_px, right_px};
  PixelIntersection x;
  if (!ok(intersectPixels(models, pixels, 2, x))) return false;
  Mat3 inverse;
  if (!fullPivInverse3(x.normal, inverse)) return false;  // Eigen::FullPivLU's verdict and inverse
  out.site_m = x.point_m;
  out.covariance_m2 = sigma_px * sigma_px * inverse;
  out.residual_px = x.rms_px;
  return true;
}

bool intersectRays(const std::vector<const CameraModel*>& models, const std::vector<Vec2>& pixels, Vec3& point,
                   std::vector<double>& residuals_px) {
  const int n = static_cast<int>(std::min(models.size(), pixels.size()));
  if (n < 2 || n > kMaxIntersectionViews) return false;
  PixelIntersection x;
  if (!ok(intersectPixels(models.data(), pixels.data(), n, x))) return false;
  point = x.point_m;
  residuals_px.assign(x.residual_px, x.residual_px + n);
  return true;
}

namespace {

void checkDisparityInputs(const cv::Mat& disparity, const cv::Mat& grey) {
  if (disparity.type() != CV_32FC1) throw std::invalid_argument("triangulateDisparity: CV_32F disparity expected");
  if (!grey.empty() && (grey.type() != CV_8UC1 || grey.size() != disparity.size())) {
    throw std::invalid_argument("triangulateDisparity: grey image must be CV_8U of the disparity's size");
  }
}

}  // namespace

namespace {

// triangulateDisparity with the pixel sigma of each match from sigmaAt(y, x).
template <typename SigmaAt>
void triangulateEach(const CameraModel& left, const CameraModel& right, const cv::Mat& disparity,
                     const SigmaAt& sigmaAt, int64_t pair_id, const cv::Mat& grey, TriangulationStats& stats,
                     double max_residual_px, const std::function<void(const CloudPoint&)>& sink) {
  checkDisparityInputs(disparity, grey);
  for (int y = 0; y < disparity.rows; ++y) {
    const float* row = disparity.ptr<float>(y);
    for (int x = 0; x < disparity.cols; ++x) {
      const float dsp = row[x];
      if (!std::isfinite(dsp)) continue;
      ++stats.matches;
      CloudPoint p;
      if (!triangulate(left, right, Vec2(x, y), Vec2(x - dsp, y), sigmaAt(y, x), p)) {
        ++stats.rejected_geometry;
        continue;
      }
      if (p.residual_px > max_residual_px) {
        ++stats.rejected_residual;
        continue;
      }
      p.grey = grey.empty() ? 0 : grey.at<uint8_t>(y, x);
      p.line = lineId(pair_id, y);
      sink(p);
      ++stats.triangulated;
    }
  }
}

}  // namespace

void triangulateDisparity(const CameraModel& left, const CameraModel& right, const cv::Mat& disparity,
                          double sigma_px, int64_t pair_id, const cv::Mat& grey, TriangulationStats& stats,
                          double max_residual_px, const std::function<void(const CloudPoint&)>& sink) {
  triangulateEach(
      left, right, disparity, [sigma_px](int, int) { return sigma_px; }, pair_id, grey, stats,
      max_residual_px, sink);
}

void triangulateDisparity(const CameraModel& left, const CameraModel& right, const cv::Mat& disparity,
                          const cv::Mat& sigma_px, int64_t pair_id, const cv::Mat& grey,
                          TriangulationStats& stats, double max_residual_px,
                          const std::function<void(const CloudPoint&)>& sink) {
  if (sigma_px.type() != CV_32FC1 || sigma_px.size() != disparity.size())
    throw std::invalid_argument(
        "triangulateDisparity: the sigma raster must be CV_32F of the disparity's size");
  triangulateEach(
      left, right, disparity,
      [&sigma_px](int y, int x) { return static_cast<double>(sigma_px.at<float>(y, x)); }, pair_id, grey,
      stats, max_residual_px, sink);
}

std::vector<CloudPoint> triangulateDisparity(const CameraModel& left, const CameraModel& right,
                                             const cv::Mat& disparity, double sigma_px, int64_t pair_id,
                                             const cv::Mat& grey, TriangulationStats& stats,
                                             double max_residual_px) {
  checkDisparityInputs(disparity, grey);
  std::vector<CloudPoint> cloud;
  {
    // Reserved for every match (a pair's cloud is ~1e6 points of 120 B: growing would copy it and, at the
    // copy, hold it nearly three times over).
    std::size_t finite = 0;
    for (int y = 0; y < disparity.rows; ++y) {
      const float* row = disparity.ptr<float>(y);
      for (int x = 0; x < disparity.cols; ++x) finite += std::isfinite(row[x]) ? 1 : 0;
    }
    cloud.reserve(finite);
  }
  triangulateDisparity(left, right, disparity, sigma_px, pair_id, grey, stats, max_residual_px,
                       [&cloud](const CloudPoint& p) { cloud.push_back(p); });
  return cloud;
}

void writePly(const std::string& path, const std::vector<CloudPoint>& points, const std::string& comment) {
  writePly(path, points.size(), [&points](std::size_t i) { return points[i]; }, comment);
}

void writePly(const std::string& path, std::size_t count, const std::function<CloudPoint(std::size_t)>& point,
              const std::string& comment) {
  std::ofstream f(path, std::ios::binary);
  if (!f) throw std::runtime_error(path + ": cannot open for writing");
  f << "ply\nformat binary_little_endian 1.0\n";
  f << "comment areomap point cloud, site frame (+X north, +Y east, +Z down), metres\n";
  if (!comment.empty()) f << "comment " << comment << "\n";
  f << "element vertex " << count << "\n"
    << "property double x\nproperty double y\nproperty double z\n"
    << "property float sigma_x\nproperty float sigma_y\nproperty float sigma_z\n"
    << "property uchar grey\nproperty int line\nend_header\n";
  // The points' bytes gathered a block at a time and written in one call each (a call per field costs more
  // than the bytes). PLY binary_little_endian: the bytes in little-endian order on any host.
  const uint16_t probe = 1;
  unsigned char first;
  std::memcpy(&first, &probe, 1);
  std::vector<char> block;
  constexpr std::size_t kBlockBytes = std::size_t{1} << 20;
  block.reserve(kBlockBytes + 64);
  auto put = [&block, first](const void* data, std::size_t n) {
    const char* c = static_cast<const char*>(data);
    if (first == 1) {
      block.insert(block.end(), c, c + n);
    } else {
      for (std::size_t i = n; i > 0; --i) block.push_back(c[i - 1]);
    }
  };
  for (std::size_t i = 0; i < count; ++i) {
    const CloudPoint p = point(i);
    for (int k = 0; k < 3; ++k) {
      const double v = p.site_m(k);
      put(&v, sizeof v);
    }
    for (int k = 0; k < 3; ++k) {
      const float s = static_cast<float>(std::sqrt(std::max(0.0, p.covariance_m2(k, k))));
      put(&s, sizeof s);
    }
    block.push_back(static_cast<char>(p.grey));
    const int32_t line = static_cast<int32_t>(p.line);
    put(&line, sizeof line);
    if (block.size() >= kBlockBytes || i + 1 == count) {
      f.write(block.data(), static_cast<std::streamsize>(block.size()));
      block.clear();
    }
  }
  // Buffered bytes reach the disk at close: a full disk shows there, not at the last write.
  f.close();
  if (!f) throw std::runtime_error(path + ": write failed (disk full?)");
}

std::vector<CloudPoint> readPly(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw std::runtime_error(path + ": cannot open");
  std::string line;
  long long count = -1;
  bool layout = false;
  while (std::getline(f, line)) {
    if (line.rfind("element vertex ", 0) == 0) count = std::atoll(line.c_str() + 15);
    if (line == "property int line") layout = true;
    if (line == "end_header") break;
  }
  if (line != "end_header" || count < 0 || !layout) throw std::runtime_error(path + ": not an areomap PLY");
  auto get = [&f](void* data, std::size_t n) {
    unsigned char* c = static_cast<unsigned char*>(data);
    f.read(reinterpret_cast<char*>(c), static_cast<std::streamsize>(n));
    const uint16_t probe = 1;
    unsigned char first;
    std::memcpy(&first, &probe, 1);
    if (first != 1) std::reverse(c, c + n);  // the file is little-endian
  };
  std::vector<CloudPoint> points(static_cast<std::size_t>(count));
  for (CloudPoint& p : points) {
    for (int k = 0; k < 3; ++k) get(&p.site_m(k), sizeof(double));
    for (int k = 0; k < 3; ++k) {
      float s = 0.f;
      get(&s, sizeof s);
      p.covariance_m2(k, k) = static_cast<double>(s) * s;
    }
    get(&p.grey, 1);
    int32_t id = 0;
    get(&id, sizeof id);
    p.line = id;
  }
  if (!f) throw std::runtime_error(path + ": truncated");
  return points;
}

}  // namespace areomap::dense
