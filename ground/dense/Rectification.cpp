#include "ground/dense/Rectification.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include "firmware_core/camera/CahvInternal.hpp"

namespace areomap::dense {

namespace {

// The map of one camera: rectified pixel -> ray of the CAHV model -> original (distorted) pixel. A row's
// rays are projected together (projectPoints: the model's own terms made once, the same pixels).
cv::Mat buildMap(const CameraModel& original, const CameraModel& rectified) {
  cv::Mat map(rectified.height, rectified.width, CV_32FC2);
  cv::parallel_for_(cv::Range(0, map.rows), [&](const cv::Range& range) {
    const std::size_t cols = static_cast<std::size_t>(map.cols);
    std::vector<Vec3> points(cols);
    std::vector<Vec2> pixels(cols);
    std::vector<Status> status(cols);
    std::vector<int> at(cols);  // the columns whose rectified pixel has a ray
    for (int y = range.start; y < range.end; ++y) {
      cv::Vec2f* row = map.ptr<cv::Vec2f>(y);
      int32_t n = 0;
      for (int x = 0; x < map.cols; ++x) {
        row[x] = cv::Vec2f(-1.f, -1.f);
        Vec3 origin, dir;
        if (unproject(rectified, Vec2(x, y), origin, dir) != Status::kOk) continue;
        points[n] = original.c + dir;
        at[n++] = x;
      }
      projectPoints(original, points.data(), n, pixels.data(), status.data());
      for (int32_t k = 0; k < n; ++k) {
        const Vec2& px = pixels[k];
        if (status[k] != Status::kOk) continue;
        if (px.x() < -0.5 || px.y() < -0.5 || px.x() > original.width - 0.5 ||
            px.y() > original.height - 0.5) {
          continue;
        }
        row[at[k]] = cv::Vec2f(static_cast<float>(px.x()), static_cast<float>(px.y()));
      }
    }
  });
  return map;
}

double rotationAngle(const Vec3& a_from, const Vec3& a_to, const Vec3& h_from, const Vec3& h_to) {
  // Angle between the frames (A, H') of the original and the rectified camera, from their axes.
  const double ca = std::clamp(a_from.dot(a_to), -1.0, 1.0);
  const double ch = std::clamp(h_from.dot(h_to), -1.0, 1.0);
  return std::max(std::acos(ca), std::acos(ch));
}

// Where an original image's border lands in the common orientation (a, h, v) at scales hs, vs, without a
// principal point: the box of u = hs (h.d) / (a.d), v = vs (v.d) / (a.d) over the border pixels' rays d.
// Rays within kMinAxisCosine of the image plane (beyond ~84 degrees off the axis) are left out: a linear
// image cannot hold them.
struct Extent {
  double u0 = 1e300, u1 = -1e300, v0 = 1e300, v1 = -1e300;
  bool valid() const { return u1 > u0 && v1 > v0; }
};
constexpr double kMinAxisCosine = 0.1;
// The rectified image holds at most twice the original's pixels (a factor sqrt(2) per axis): enough for the
// linear image of a tile whose principal point is at its corner, or of a wide lens, at the original's
// central scale.
constexpr double kMaxAreaRatio = 2.0;
constexpr int kBorderStepPx = 4;

Extent borderExtent(const CameraModel& m, const Vec3& a, const Vec3& h, const Vec3& v, double hs, double vs) {
  Extent e;
  const auto add = [&](double x, double y) {
    Vec3 origin, d;
    if (unproject(m, Vec2(x, y), origin, d) != Status::kOk) return;
    const double z = d.dot(a);
    if (z < kMinAxisCosine) return;
    const double u = hs * d.dot(h) / z, w = vs * d.dot(v) / z;
    e.u0 = std::min(e.u0, u);
    e.u1 = std::max(e.u1, u);
    e.v0 = std::min(e.v0, w);
    e.v1 = std::max(e.v1, w);
  };
  const double xe = m.width - 1.0, ye = m.height - 1.0;
  for (double x = 0.0; x < xe; x += kBorderStepPx) {
    add(x, 0.0);
    add(x, ye);
  }
  for (double y = 0.0; y < ye; y += kBorderStepPx) {
    add(0.0, y);
    add(xe, y);
  }
  add(xe, ye);
  return e;
}

}  // namespace

RectifiedPair rectifyPair(const CameraModel& left, const CameraModel& right) {
  if (left.width <= 0 || left.height <= 0 || right.width <= 0 || right.height <= 0) {
    throw std::invalid_argument("rectifyPair: the models have no image size");
  }
  const Vec3 base = right.c - left.c;
  const double b = base.norm();
  if (!(b > 1e-6)) throw std::invalid_argument("rectifyPair: zero baseline");
  const CahvInternal il = cahvInternal(left), ir = cahvInternal(right);
  const Vec3& hl = il.h_prime;  // H' unit of the left camera
  Vec3 x = base / b;
  if (x.dot(hl) < 0) x = -x;  // the right camera should lie along +H'; if not, matching sees d < 0
  const Vec3 a_mean = (left.a + right.a).normalized();
  Vec3 v = a_mean.cross(x);
  if (v.norm() < 0.2) throw std::invalid_argument("rectifyPair: baseline along the optical axis");
  v.normalize();
  const Vec3 a = x.cross(v).normalized();
  const Vec3& h = x;

  RectifiedPair out;
  out.baseline_m = b;
  double hs = 0.5 * (il.hs_px + ir.hs_px);
  double vs = 0.5 * (il.vs_px + ir.vs_px);
  // The rectified images cover what both originals show: the columns of either (the right image's content
  // lies left of the left's by the disparity) and the rows they share (epipolar rows seen by one image
  // only have nothing to match), at the originals' mean scale. A pair whose principal point lies at a
  // corner of its images (a sensor tile) or whose lens is wide (CAHVORE fisheye) needs a larger linear
  // image than the original for that; its pixel count is held to kMaxAreaRatio times the original's (a
  // linear image of a fisheye periphery only oversamples it further), beyond which the scale is reduced.
  const Extent el = borderExtent(left, a, h, v, hs, vs), er = borderExtent(right, a, h, v, hs, vs);
  if (!el.valid() || !er.valid())
    throw std::invalid_argument("rectifyPair: the images do not face the common axis");
  double u0 = std::min(el.u0, er.u0), u1 = std::max(el.u1, er.u1);
  double v0 = std::max(el.v0, er.v0), v1 = std::min(el.v1, er.v1);
  if (!(v1 > v0)) throw std::invalid_argument("rectifyPair: the images share no epipolar row");
  // The size below is at most (u1 - u0 + 3) x (v1 - v0 + 3) (whole pixels at both ends); the scale factor f
  // solves (f du + 3)(f dv + 3) = cap when that exceeds the cap.
  const double du = u1 - u0, dv = v1 - v0;
  const double cap = kMaxAreaRatio * static_cast<double>(left.width) * left.height;
  if ((du + 3.0) * (dv + 3.0) > cap) {
    const double p = 3.0 * (du + dv), q = du * dv;
    const double f = (-p + std::sqrt(p * p - 4.0 * q * (9.0 - cap))) / (2.0 * q);
    hs *= f;
    vs *= f;
    u0 *= f;
    u1 *= f;
    v0 *= f;
    v1 *= f;
  }
  const double hc = -std::floor(u0), vc = -std::floor(v0);
  CameraModel rect;
  rect.type = CameraType::kCahv;
  rect.a = a;
  rect.h = hs * h + hc * a;
  rect.v = vs * v + vc * a;
  rect.width = static_cast<int32_t>(std::ceil(u1 + hc)) + 1;
  rect.height = static_cast<int32_t>(std::ceil(v1 + vc)) + 1;
  out.left = rect;
  out.left.c = left.c;
  out.right = rect;
  out.right.c = right.c;
  out.left_map = buildMap(left, out.left);
  out.right_map = buildMap(right, out.right);
  out.max_rotation_rad = std::max(rotationAngle(left.a, a, hl, h), rotationAngle(right.a, a, ir.h_prime, h));
  return out;
}

double disparityAtRange(const RectifiedPair& rectified, double range_m) {
  return cahvInternal(rectified.left).hs_px * rectified.baseline_m / range_m;
}

cv::Mat remapToRectified(const cv::Mat& image, const cv::Mat& map) {
  cv::Mat out;
  cv::remap(image, out, map, cv::noArray(), cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(0));
  return out;
}

bool originalToRectified(const CameraModel& original, const CameraModel& rectified, const Vec2& pixel,
                         Vec2& rectified_px) {
  Vec3 origin, dir;
  if (unproject(original, pixel, origin, dir) != Status::kOk) return false;
  return project(rectified, rectified.c + dir, rectified_px) == Status::kOk;
}

std::vector<TieDisparity> rectifiedTies(const CameraModel& left, const CameraModel& right,
                                        const RectifiedPair& rectified, const std::vector<Vec2>& left_px,
                                        const std::vector<Vec2>& right_px) {
  std::vector<TieDisparity> out;
  const std::size_t n = std::min(left_px.size(), right_px.size());
  for (std::size_t i = 0; i < n; ++i) {
    Vec2 l, r;
    if (!originalToRectified(left, rectified.left, left_px[i], l)) continue;
    if (!originalToRectified(right, rectified.right, right_px[i], r)) continue;
    TieDisparity t;
    t.x_px = l.x();
    t.y_px = l.y();
    t.disparity_px = l.x() - r.x();
    out.push_back(t);
  }
  return out;
}

}  // namespace areomap::dense
