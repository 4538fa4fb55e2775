#include "ground/dense/Rectification.hpp"

#include <cmath>
#include <stdexcept>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include "firmware_core/camera/CahvInternal.hpp"

namespace areomap::dense {

namespace {

// The map of one camera: rectified pixel -> ray of the CAHV model -> original (distorted) pixel.
cv::Mat buildMap(const CameraModel& original, const CameraModel& rectified) {
  cv::Mat map(original.height, original.width, CV_32FC2);
  cv::parallel_for_(cv::Range(0, map.rows), [&](const cv::Range& range) {
    for (int y = range.start; y < range.end; ++y) {
      cv::Vec2f* row = map.ptr<cv::Vec2f>(y);
      for (int x = 0; x < map.cols; ++x) {
        row[x] = cv::Vec2f(-1.f, -1.f);
        Vec3 origin, dir;
        if (unproject(rectified, Vec2(x, y), origin, dir) != Status::kOk) continue;
        Vec2 px;
        if (project(original, original.c + dir, px) != Status::kOk) continue;
        if (px.x() < -0.5 || px.y() < -0.5 || px.x() > original.width - 0.5 || px.y() > original.height - 0.5) {
          continue;
        }
        row[x] = cv::Vec2f(static_cast<float>(px.x()), static_cast<float>(px.y()));
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
  const double hs = 0.5 * (il.hs_px + ir.hs_px);
  const double vs = 0.5 * (il.vs_px + ir.vs_px);
  // Principal point: the mean of where the two original optical axes land in the common orientation,
  // shifted so that the image centre stays at the centre on average.
  const double cx = 0.5 * (left.width - 1), cy = 0.5 * (left.height - 1);
  double hc = 0, vc = 0;
  for (const CameraModel* m : {&left, &right}) {
    // The original centre pixel's ray, in the rectified frame without a principal point.
    Vec3 origin, dir;
    if (unproject(*m, Vec2(cx, cy), origin, dir) != Status::kOk) dir = m->a;
    const double z = dir.dot(a);
    hc += cx - hs * dir.dot(h) / z;
    vc += cy - vs * dir.dot(v) / z;
  }
  hc *= 0.5;
  vc *= 0.5;
  CameraModel rect;
  rect.type = CameraType::kCahv;
  rect.a = a;
  rect.h = hs * h + hc * a;
  rect.v = vs * v + vc * a;
  rect.width = left.width;
  rect.height = left.height;
  out.left = rect;
  out.left.c = left.c;
  out.right = rect;
  out.right.c = right.c;
  out.right.width = right.width;
  out.right.height = right.height;
  out.left_map = buildMap(left, out.left);
  out.right_map = buildMap(right, out.right);
  out.max_rotation_rad = std::max(rotationAngle(left.a, a, hl, h), rotationAngle(right.a, a, ir.h_prime, h));
  return out;
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
