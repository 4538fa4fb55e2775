#include "ground/ties/FullResolutionTies.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>

#include "firmware_core/base/Capacities.hpp"
#include "firmware_core/match/Ncc.hpp"

namespace areomap {
namespace {

struct Peak {
  bool found = false;
  int32_t x = 0;  // integer peak, image pixels
  int32_t y = 0;
  double sub_x = 0.0, sub_y = 0.0;  // sub-pixel peak (parabolas through the neighbours)
  double score = -2.0;
};

// The best normalised correlation of `templ` (square, odd side) centred within `radius` of (cx, cy) in
// `image`; not found when the search window leaves the image or the image is flat there.
Peak bestWithin(const cv::Mat& templ, const cv::Mat& image, int32_t cx, int32_t cy, int32_t radius) {
  Peak p;
  const int32_t half = templ.cols / 2;
  const cv::Rect window(cx - radius - half, cy - radius - half, 2 * (radius + half) + 1,
                        2 * (radius + half) + 1);
  if (window.x < 0 || window.y < 0 || window.x + window.width > image.cols ||
      window.y + window.height > image.rows)
    return p;
  cv::Mat scores;
  cv::matchTemplate(image(window), templ, scores, cv::TM_CCOEFF_NORMED);
  double best = 0.0;
  cv::Point at;
  cv::minMaxLoc(scores, nullptr, &best, nullptr, &at);
  if (!std::isfinite(best)) return p;
  p.found = true;
  p.score = best;
  p.x = cx - radius + at.x;
  p.y = cy - radius + at.y;
  const auto s = [&](int32_t x, int32_t y) { return static_cast<double>(scores.at<float>(y, x)); };
  p.sub_x =
      p.x +
      (at.x > 0 && at.x + 1 < scores.cols ? parabolaOffset(s(at.x - 1, at.y), best, s(at.x + 1, at.y)) : 0.0);
  p.sub_y =
      p.y +
      (at.y > 0 && at.y + 1 < scores.rows ? parabolaOffset(s(at.x, at.y - 1), best, s(at.x, at.y + 1)) : 0.0);
  return p;
}

double sample(const cv::Mat& image, double x, double y) {
  const int32_t ix = static_cast<int32_t>(std::floor(x)), iy = static_cast<int32_t>(std::floor(y));
  const double fx = x - ix, fy = y - iy;
  const uint8_t* r0 = image.ptr<uint8_t>(iy);
  const uint8_t* r1 = image.ptr<uint8_t>(iy + 1);
  return (1 - fy) * ((1 - fx) * r0[ix] + fx * r0[ix + 1]) + fy * ((1 - fx) * r1[ix] + fx * r1[ix + 1]);
}

// Least-squares matching (Gruen's adaptive least-squares correlation): the template t about its centre
// against `image` resampled (bilinear) through an affine map of the template offsets (u, v),
//   t(u, v) = g0 + g1 image(x + a11 u + a12 v, y + a21 u + a22 v),
// Gauss-Newton from (x, y), the identity and g0 = 0, g1 = 1. The affine terms take the foreshortening
// between the two views over the template (a slanted surface at near range), which biases a plain
// correlation peak. False when it does not converge, moves more than kMaxLsmShiftPx from the start, or its
// affine map degenerates (scale outside 1/2..2: not the same surface).
constexpr int32_t kMaxLsmIterations = 20;
constexpr double kLsmConvergedPx = 0.01;
constexpr double kMaxLsmShiftPx = 1.5;
bool leastSquaresMatch(const cv::Mat& t, const cv::Mat& image, Vec2& xy) {
  const int32_t half = t.cols / 2;
  Eigen::Matrix<double, 8, 1> q;
  q << xy.x(), xy.y(), 1.0, 0.0, 0.0, 1.0, 0.0, 1.0;  // x, y, a11, a12, a21, a22, g0, g1
  const Vec2 start = xy;
  for (int32_t it = 0; it < kMaxLsmIterations; ++it) {
    Eigen::Matrix<double, 8, 8> n = Eigen::Matrix<double, 8, 8>::Zero();
    Eigen::Matrix<double, 8, 1> g = Eigen::Matrix<double, 8, 1>::Zero();
    for (int32_t v = -half; v <= half; ++v) {
      for (int32_t u = -half; u <= half; ++u) {
        const double x = q(0) + q(2) * u + q(3) * v, y = q(1) + q(4) * u + q(5) * v;
        if (x < 1.0 || y < 1.0 || x > image.cols - 3.0 || y > image.rows - 3.0) return false;
        const double i0 = sample(image, x, y);
        const double ix = 0.5 * (sample(image, x + 1.0, y) - sample(image, x - 1.0, y));
        const double iy = 0.5 * (sample(image, x, y + 1.0) - sample(image, x, y - 1.0));
        Eigen::Matrix<double, 8, 1> j;
        j << q(7) * ix, q(7) * iy, q(7) * ix * u, q(7) * ix * v, q(7) * iy * u, q(7) * iy * v, 1.0, i0;
        const double r = t.at<uint8_t>(v + half, u + half) - (q(6) + q(7) * i0);
        n.noalias() += j * j.transpose();
        g.noalias() += j * r;
      }
    }
    const Eigen::Matrix<double, 8, 1> d = n.ldlt().solve(g);
    if (!d.allFinite()) return false;
    q += d;
    const double det = q(2) * q(5) - q(3) * q(4);
    if (!(det > 0.25 && det < 4.0) || (Vec2(q(0), q(1)) - start).norm() > kMaxLsmShiftPx) return false;
    if (std::hypot(d(0), d(1)) < kLsmConvergedPx) {
      xy = Vec2(q(0), q(1));
      return true;
    }
  }
  return false;
}

// One observation matched again at full resolution to the reference template `t` (centred on (rx, ry) of
// `ref`); false when it is left out, with the reason counted in `counts`.
bool refineOne(const cv::Mat& t, const cv::Mat& ref, int32_t rx, int32_t ry, const cv::Mat& image,
               const Vec2& predicted_px, int32_t radius, const RefineParams& params, Vec2& refined_px,
               RefineCounts& counts) {
  const int32_t cx = static_cast<int32_t>(std::lround(predicted_px.x()));
  const int32_t cy = static_cast<int32_t>(std::lround(predicted_px.y()));
  const Peak p = bestWithin(t, image, cx, cy, radius);
  if (!p.found || p.score < params.min_ncc) {
    ++counts.low_score;
    return false;
  }
  if (std::abs(p.x - cx) == radius || std::abs(p.y - cy) == radius) {  // not a peak inside
    ++counts.border;
    return false;
  }
  cv::Mat back;
  cv::getRectSubPix(image, t.size(), cv::Point2f(static_cast<float>(p.sub_x), static_cast<float>(p.sub_y)),
                    back);
  const Peak b = bestWithin(back, ref, rx, ry, radius);
  if (!b.found || std::abs(b.x - rx) > params.lr_tolerance_px ||
      std::abs(b.y - ry) > params.lr_tolerance_px) {
    ++counts.back_match;
    return false;
  }
  refined_px = Vec2(p.sub_x, p.sub_y);
  if (!leastSquaresMatch(t, image, refined_px)) {
    ++counts.least_squares;
    return false;
  }
  return true;
}

// The reference template of a point: the square of k times the matcher's template side about (x, y) (the
// surface the binned match compared), or empty when it leaves the image or is flat.
cv::Mat referenceTemplate(const cv::Mat& image, int32_t x, int32_t y, int32_t half) {
  const cv::Rect r(x - half, y - half, 2 * half + 1, 2 * half + 1);
  if (r.x < 0 || r.y < 0 || r.x + r.width > image.cols || r.y + r.height > image.rows) return cv::Mat();
  cv::Scalar mean, sd;
  cv::meanStdDev(image(r), mean, sd);
  if (sd[0] * sd[0] < kMinNccVariance) return cv::Mat();
  return image(r).clone();
}

}  // namespace

cv::Mat binImage(const cv::Mat& grey, int32_t k) {
  if (k <= 1) return grey;
  const cv::Mat whole = grey(cv::Rect(0, 0, (grey.cols / k) * k, (grey.rows / k) * k));
  cv::Mat binned;
  // INTER_AREA with an integer factor is the k x k box mean.
  cv::resize(whole, binned, cv::Size(grey.cols / k, grey.rows / k), 0.0, 0.0, cv::INTER_AREA);
  return binned;
}

RefineCounts refineAtFullResolution(const std::vector<cv::Mat>& images, int32_t k, const RefineParams& params,
                                    std::vector<TieObservation>& observations, std::vector<TiePoint>& points,
                                    std::vector<int32_t>& kept_prefix, std::vector<int32_t>& kept_points) {
  RefineCounts counts;
  const int32_t radius = k + 1;
  const std::size_t n_obs = observations.size();
  std::vector<Vec2> refined(n_obs, Vec2::Zero());
  std::vector<bool> keep(n_obs, false);
  std::vector<int32_t> first(points.size(), -1);
  for (std::size_t i = 0; i < n_obs; ++i) {
    const int32_t p = observations[i].point;
    if (p >= 0 && p < static_cast<int32_t>(points.size()) && first[p] < 0) first[p] = static_cast<int32_t>(i);
  }
  const auto imageOf = [&](int32_t index) -> const cv::Mat* {
    if (index < 0 || index >= static_cast<int32_t>(images.size()) || images[index].empty()) return nullptr;
    return &images[index];
  };
  // Each point's reference: its first observation at the nearest full-resolution pixel.
  std::vector<cv::Mat> templates(points.size());
  const int32_t half = k * kNccRadius;
  std::vector<Eigen::Vector2i> reference(points.size(), Eigen::Vector2i::Zero());
  std::vector<bool> usable(points.size(), false);
  for (std::size_t p = 0; p < points.size(); ++p) {
    if (first[p] < 0) continue;
    const TieObservation& o = observations[first[p]];
    const cv::Mat* im = imageOf(o.image);
    if (im == nullptr) continue;
    reference[p] = Eigen::Vector2i(static_cast<int32_t>(std::lround(fullResolutionPx(o.sample_px, k))),
                                   static_cast<int32_t>(std::lround(fullResolutionPx(o.line_px, k))));
    templates[p] = referenceTemplate(*im, reference[p].x(), reference[p].y(), half);
    usable[p] = !templates[p].empty();
    if (usable[p]) {
      keep[first[p]] = true;
      refined[first[p]] = reference[p].cast<double>();
    }
  }
  // The correlation floor at full resolution. Every match here was verified at the binned scale (the
  // matcher's min_ncc, left-right and parallax checks); full resolution adds detail and sensor noise, which
  // lower the same surface's score by an amount the data show: the floor is the lower of min_ncc and the
  // peak scores' median less 4 robust standard deviations (1.4826 MAD), so that only the scores that stand
  // out below the rest are left out.
  std::vector<double> scores;
  for (std::size_t i = 0; i < n_obs; ++i) {
    const TieObservation& o = observations[i];
    const int32_t p = o.point;
    if (p < 0 || p >= static_cast<int32_t>(points.size()) || first[p] == static_cast<int32_t>(i) ||
        !usable[p])
      continue;
    const cv::Mat* im = imageOf(o.image);
    if (im == nullptr) continue;
    const Peak peak =
        bestWithin(templates[p], *im, static_cast<int32_t>(std::lround(fullResolutionPx(o.sample_px, k))),
                   static_cast<int32_t>(std::lround(fullResolutionPx(o.line_px, k))), radius);
    if (peak.found) scores.push_back(peak.score);
  }
  RefineParams used = params;
  if (!scores.empty()) {
    std::vector<double> dev(scores.size());
    std::nth_element(scores.begin(), scores.begin() + scores.size() / 2, scores.end());
    const double median = scores[scores.size() / 2];
    for (std::size_t i = 0; i < scores.size(); ++i) dev[i] = std::fabs(scores[i] - median);
    std::nth_element(dev.begin(), dev.begin() + dev.size() / 2, dev.end());
    used.min_ncc = std::max(0.0, std::min(params.min_ncc, median - 4.0 * 1.4826 * dev[dev.size() / 2]));
  }
  counts.score_floor = used.min_ncc;
  for (std::size_t i = 0; i < n_obs; ++i) {
    const TieObservation& o = observations[i];
    const int32_t p = o.point;
    if (p < 0 || p >= static_cast<int32_t>(points.size()) || first[p] == static_cast<int32_t>(i)) continue;
    const cv::Mat* im = imageOf(o.image);
    const cv::Mat* ref = imageOf(observations[first[p]].image);
    Vec2 px;
    if (usable[p] && im != nullptr && ref != nullptr &&
        refineOne(templates[p], *ref, reference[p].x(), reference[p].y(), *im,
                  Vec2(fullResolutionPx(o.sample_px, k), fullResolutionPx(o.line_px, k)), radius, used, px,
                  counts)) {
      keep[i] = true;
      refined[i] = px;
      ++counts.refined;
    } else {
      ++counts.dropped;
    }
  }
  // A point needs two observations.
  std::vector<int32_t> kept_count(points.size(), 0);
  for (std::size_t i = 0; i < n_obs; ++i)
    if (keep[i]) ++kept_count[observations[i].point];
  std::vector<int32_t> new_index(points.size(), -1);
  std::vector<TiePoint> out_points;
  kept_points.assign(points.size() + 1, 0);
  for (std::size_t p = 0; p < points.size(); ++p) {
    if (kept_count[p] >= 2) {
      new_index[p] = static_cast<int32_t>(out_points.size());
      out_points.push_back(points[p]);
      out_points.back().observation_count = kept_count[p];
    } else if (first[p] >= 0) {
      ++counts.points_dropped;
    }
    kept_points[p + 1] = static_cast<int32_t>(out_points.size());
  }
  std::vector<TieObservation> out_obs;
  kept_prefix.assign(n_obs + 1, 0);
  for (std::size_t i = 0; i < n_obs; ++i) {
    const TieObservation& o = observations[i];
    if (keep[i] && o.point >= 0 && new_index[o.point] >= 0) {
      TieObservation r = o;
      r.point = new_index[o.point];
      r.sample_px = refined[i].x();
      r.line_px = refined[i].y();
      out_obs.push_back(r);
    } else if (keep[i]) {
      ++counts.dropped;  // its partner was left out
    }
    kept_prefix[i + 1] = static_cast<int32_t>(out_obs.size());
  }
  observations.swap(out_obs);
  points.swap(out_points);
  return counts;
}

}  // namespace areomap
