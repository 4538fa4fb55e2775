#include "ground/ties/FullResolutionTies.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "firmware_core/base/Capacities.hpp"
#include "firmware_core/match/Ncc.hpp"
#include "ground/io/CameraFile.hpp"

namespace areomap {
namespace {

ImageView viewOf(const cv::Mat& m) {
  return ImageView{m.ptr<uint8_t>(0), m.cols, m.rows, static_cast<int32_t>(m.step[0])};
}

struct Peak {
  bool found = false;
  int32_t x = 0;
  int32_t y = 0;
  double score = kNccInvalid;
};

// The best NCC of `t` over the integer positions within `radius` of (cx, cy) in `image`.
Peak bestWithin(const NccTemplate& t, const ImageView& image, int32_t cx, int32_t cy, int32_t radius) {
  Peak p;
  for (int32_t dy = -radius; dy <= radius; ++dy) {
    for (int32_t dx = -radius; dx <= radius; ++dx) {
      const double s = nccAt(t, image, cx + dx, cy + dy);
      if (s > p.score) {
        p = Peak{true, cx + dx, cy + dy, s};
      }
    }
  }
  p.found = p.score > kNccInvalid;
  return p;
}

// One observation matched again at full resolution to the reference template `t` (centred on (rx, ry) of
// `ref`); false when it is left out.
bool refineOne(const NccTemplate& t, const ImageView& ref, int32_t rx, int32_t ry, const ImageView& image,
               const Vec2& predicted_px, int32_t radius, const RefineParams& params, Vec2& refined_px) {
  const int32_t cx = static_cast<int32_t>(std::lround(predicted_px.x()));
  const int32_t cy = static_cast<int32_t>(std::lround(predicted_px.y()));
  const Peak p = bestWithin(t, image, cx, cy, radius);
  if (!p.found || p.score < params.min_ncc) return false;
  if (std::abs(p.x - cx) == radius || std::abs(p.y - cy) == radius) return false;  // not a peak inside
  double x = 0.0, y = 0.0;
  refinePeak(t, image, p.x, p.y, p.score, x, y);
  NccTemplate back;
  if (!extractTemplateAt(image, x, y, back) || !back.textured) return false;
  const Peak b = bestWithin(back, ref, rx, ry, radius);
  if (!b.found || std::abs(b.x - rx) > params.lr_tolerance_px || std::abs(b.y - ry) > params.lr_tolerance_px)
    return false;
  refined_px = Vec2(x, y);
  return true;
}

}  // namespace

int32_t binningFactor(int32_t width, int32_t height) {
  int32_t k = 1;
  while (width / k > kMaxImageWidth || height / k > kMaxImageHeight) ++k;  // ends by k = max(width, height)
  return k;
}

cv::Mat binImage(const cv::Mat& grey, int32_t k) {
  if (k <= 1) return grey;
  const cv::Mat whole = grey(cv::Rect(0, 0, (grey.cols / k) * k, (grey.rows / k) * k));
  cv::Mat binned;
  // INTER_AREA with an integer factor is the k x k box mean.
  cv::resize(whole, binned, cv::Size(grey.cols / k, grey.rows / k), 0.0, 0.0, cv::INTER_AREA);
  return binned;
}

CameraModel binnedModel(const CameraModel& model, int32_t k) {
  if (k <= 1) return model;
  const double offset = 0.5 * (k - 1);
  return io::rescaledModel(model, k, Vec2(offset, offset), model.width / k, model.height / k);
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
  std::vector<NccTemplate> templates(points.size());
  std::vector<Eigen::Vector2i> reference(points.size(), Eigen::Vector2i::Zero());
  std::vector<bool> usable(points.size(), false);
  for (std::size_t p = 0; p < points.size(); ++p) {
    if (first[p] < 0) continue;
    const TieObservation& o = observations[first[p]];
    const cv::Mat* im = imageOf(o.image);
    if (im == nullptr) continue;
    reference[p] = Eigen::Vector2i(static_cast<int32_t>(std::lround(fullResolutionPx(o.sample_px, k))),
                                   static_cast<int32_t>(std::lround(fullResolutionPx(o.line_px, k))));
    usable[p] = extractTemplate(viewOf(*im), reference[p].x(), reference[p].y(), templates[p]) &&
                templates[p].textured;
    if (usable[p]) {
      keep[first[p]] = true;
      refined[first[p]] = reference[p].cast<double>();
    }
  }
  for (std::size_t i = 0; i < n_obs; ++i) {
    const TieObservation& o = observations[i];
    const int32_t p = o.point;
    if (p < 0 || p >= static_cast<int32_t>(points.size()) || first[p] == static_cast<int32_t>(i)) continue;
    const cv::Mat* im = imageOf(o.image);
    const cv::Mat* ref = imageOf(observations[first[p]].image);
    Vec2 px;
    if (usable[p] && im != nullptr && ref != nullptr &&
        refineOne(templates[p], viewOf(*ref), reference[p].x(), reference[p].y(), viewOf(*im),
                  Vec2(fullResolutionPx(o.sample_px, k), fullResolutionPx(o.line_px, k)), radius, params,
                  px)) {
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
