#include "firmware_core/match/CrossSiteMatcher.hpp"

#include <algorithm>
#include <cmath>

#include "firmware_core/base/Angles.hpp"
#include "firmware_core/camera/Binning.hpp"
#include "firmware_core/match/Ncc.hpp"

namespace areomap {
namespace {

// Bilinear sample of a kept image at (x, y) (pixel centres at integers); false outside.
bool keptSample(const KeptImage& k, double x, double y, double& value) {
  if (!(x >= 0.0 && y >= 0.0 && x <= k.width - 1.0 && y <= k.height - 1.0)) return false;
  const int32_t x0 = static_cast<int32_t>(x), y0 = static_cast<int32_t>(y);
  const int32_t x1 = x0 + 1 < k.width ? x0 + 1 : x0, y1 = y0 + 1 < k.height ? y0 + 1 : y0;
  const double fx = x - x0, fy = y - y0;
  const uint8_t* p = k.pixels;
  const double top = (1.0 - fx) * p[y0 * k.width + x0] + fx * p[y0 * k.width + x1];
  const double bottom = (1.0 - fx) * p[y1 * k.width + x0] + fx * p[y1 * k.width + x1];
  value = (1.0 - fy) * top + fy * bottom;
  return true;
}

// The ground plane's upward-pointing normal (Z down: the normal has a negative z) from the DEM's slope at
// (x, y), central differences over one cell; false where the DEM has no value around it.
bool planeNormal(const CoarseDem& dem, const Vec3& p, Vec3& normal) {
  const double h = CoarseDem::cellSize();
  double xp = 0.0, xm = 0.0, yp = 0.0, ym = 0.0;
  if (!dem.elevationAt(p.x() + h, p.y(), xp) || !dem.elevationAt(p.x() - h, p.y(), xm) ||
      !dem.elevationAt(p.x(), p.y() + h, yp) || !dem.elevationAt(p.x(), p.y() - h, ym)) {
    return false;
  }
  normal = Vec3((xp - xm) / (2.0 * h), (yp - ym) / (2.0 * h), -1.0).normalized();
  return true;
}

// sin of the angle between a ray (unit) and the plane (unit normal).
double incidenceSin(const Vec3& ray, const Vec3& normal) {
  return std::fabs(ray.dot(normal));
}

}  // namespace

void CrossSiteRecord::reset() {
  dem_.reset(Vec3::Zero());
  image_count_ = 0;
  candidate_count_ = 0;
  images_not_kept_ = 0;
  for (int32_t k = 0; k < kMaxStoredImages; ++k) {
    for (int32_t c = 0; c < kCandidateGrid * kCandidateGrid; ++c) cell_taken_[k][c] = false;
  }
}

bool CrossSiteRecord::keepImage(const ImageView& image, int32_t index, const CameraModel& apriori_model,
                                const PhotogrammetricCamera& apriori_camera) {
  if (image_count_ >= kMaxStoredImages || !image.valid()) {
    images_not_kept_ += 1;
    return false;
  }
  KeptImage& k = images_[image_count_++];
  const int32_t side = image.width > image.height ? image.width : image.height;
  k.bin = (side + kStoredImageSide - 1) / kStoredImageSide;
  k.width = image.width / k.bin;
  k.height = image.height / k.bin;
  k.image = index;
  k.apriori_model = apriori_model;
  k.apriori_camera = apriori_camera;
  k.model = binnedModel(apriori_model, k.bin);
  const int32_t n = k.bin * k.bin;
  for (int32_t y = 0; y < k.height; ++y) {
    for (int32_t x = 0; x < k.width; ++x) {
      int32_t sum = 0;
      for (int32_t dy = 0; dy < k.bin; ++dy) {
        const uint8_t* row = image.row(y * k.bin + dy) + x * k.bin;
        for (int32_t dx = 0; dx < k.bin; ++dx) sum += row[dx];
      }
      k.pixels[y * k.width + x] = static_cast<uint8_t>((sum + n / 2) / n);
    }
  }
  return true;
}

int32_t CrossSiteRecord::storedOf(int32_t index) const {
  for (int32_t k = 0; k < image_count_; ++k) {
    if (images_[k].image == index) return k;
  }
  return -1;
}

void CrossSiteRecord::setAdjustedModel(int32_t stored, const CameraModel& matcher_frame_model) {
  images_[stored].model = binnedModel(matcher_frame_model, images_[stored].bin);
}

bool CrossSiteRecord::offerCandidate(int32_t stored, const Vec2& stored_px, const CrossSiteCandidate& candidate) {
  if (candidate_count_ >= kMaxSiteCandidates || stored < 0 || stored >= image_count_) return false;
  const KeptImage& k = images_[stored];
  const int32_t cx = static_cast<int32_t>(stored_px.x() * kCandidateGrid / k.width);
  const int32_t cy = static_cast<int32_t>(stored_px.y() * kCandidateGrid / k.height);
  if (cx < 0 || cy < 0 || cx >= kCandidateGrid || cy >= kCandidateGrid) return false;
  bool& taken = cell_taken_[stored][cy * kCandidateGrid + cx];
  if (taken) return false;
  taken = true;
  candidates_[candidate_count_] = candidate;
  candidates_[candidate_count_].stored = stored;
  candidate_count_ += 1;
  return true;
}

void CrossSiteMatcher::match(const CrossSiteRecord& a, const CrossSiteRecord& b, const LevelledPose& a_from_b,
                             const CrossMatchParams& params, RoverCrossTie* ties, int32_t capacity,
                             int32_t& count, CrossMatchCounts& counts) {
  count = 0;
  counts = CrossMatchCounts{};
  const Mat3 r = a_from_b.rotation();
  for (int32_t ci = 0; ci < a.candidateCount(); ++ci) {
    const CrossSiteCandidate& c = a.candidate(ci);
    const Vec3 x_b = r.transpose() * (c.xyz_m - a_from_b.translation_m);
    Vec3 normal_b;
    if (!planeNormal(b.dem(), x_b, normal_b)) {
      counts.outside += 1;
      continue;
    }
    int32_t found = 0;
    for (int32_t k = 0; k < b.imageCount() && found < 2 && count < capacity; ++k) {
      RoverCrossTie tie;
      if (!matchOne(a, c, b.image(k), x_b, normal_b, a_from_b, params, counts, tie)) continue;
      tie.candidate = ci;
      tie.stored = k;
      ties[count++] = tie;
      found += 1;
    }
  }
}

// Long because: one prediction's gates, its warped template and its search in order, sharing the
// prediction's geometry.
bool CrossSiteMatcher::matchOne(const CrossSiteRecord& a, const CrossSiteCandidate& c, const KeptImage& bi,
                                const Vec3& x_b, const Vec3& normal_b, const LevelledPose& a_from_b,
                                const CrossMatchParams& params, CrossMatchCounts& counts, RoverCrossTie& tie) {
  const KeptImage& ai = a.image(c.stored);
  Vec2 u_b;
  if (!ok(project(bi.model, x_b, u_b))) return false;
  const int32_t reach = kCrossTemplateHalf + kCrossSearchRadiusPx + 1;
  const int32_t ub_x = static_cast<int32_t>(std::lround(u_b.x())), ub_y = static_cast<int32_t>(std::lround(u_b.y()));
  if (ub_x < reach || ub_y < reach || ub_x >= bi.width - reach || ub_y >= bi.height - reach) return false;
  // Gates: range and incidence in both views.
  const Vec3 ray_b = x_b - bi.model.c;
  const Vec3 ray_a = c.xyz_m - ai.model.c;
  if (ray_b.norm() > params.max_range_m || ray_a.norm() > params.max_range_m) {
    counts.beyond_range += 1;
    return false;
  }
  const Mat3 r = a_from_b.rotation();
  const Vec3 normal_a = r * normal_b;
  const double min_sin = std::sin(params.min_incidence_deg * kDegToRad);
  if (incidenceSin(ray_b.normalized(), normal_b) < min_sin || incidenceSin(ray_a.normalized(), normal_a) < min_sin) {
    counts.grazing += 1;
    return false;
  }
  counts.predicted += 1;
  // B's pixel px through the ground plane under the point into A's kept image.
  const auto warp = [&](const Vec2& px, Vec2& u_a) {
    Vec3 o, d;
    if (!ok(unproject(bi.model, px, o, d))) return false;
    const double den = normal_b.dot(d);
    if (std::fabs(den) < 1e-9) return false;
    const double t = normal_b.dot(x_b - o) / den;
    if (t <= 0.0) return false;
    return ok(project(ai.model, r * (o + t * d) + a_from_b.translation_m, u_a));
  };
  // The local map of B's pixels into A's at the prediction. Its first column gates the pair of views: a
  // pixel's step across the line of sight is its range times the pixel angle in either view, so this is
  // the ratio of the two footprints' widths (along the line of sight the ground's foreshortening adds to
  // it, which the template's averaging below takes). Its longer column sets that averaging.
  const Vec2 ub(ub_x, ub_y);
  Vec2 u0, ux, uy;
  if (!warp(ub, u0) || !warp(ub + Vec2(1.0, 0.0), ux) || !warp(ub + Vec2(0.0, 1.0), uy)) {
    counts.warp_failed += 1;
    return false;
  }
  Mat2 map;
  map.col(0) = ux - u0;
  map.col(1) = uy - u0;
  const double scale = map.col(0).norm();
  if (!(scale <= params.max_scale_ratio && scale >= 1.0 / params.max_scale_ratio)) {
    counts.scale_gate += 1;
    return false;
  }
  // The template: B's pixels about the prediction, each the mean of A over that pixel's footprint (an
  // s x s grid of bilinear samples, s the map's longer column rounded up): A sampled at B's spacing alone
  // aliases where A sees the ground finer than B does.
  const double stretch = std::max(scale, map.col(1).norm());
  const int32_t sub =
      std::min<int32_t>(kCrossMaxSubsamples, std::max<int32_t>(1, static_cast<int32_t>(std::ceil(stretch))));
  int32_t n = 0;
  for (int32_t dy = -kCrossTemplateHalf; dy <= kCrossTemplateHalf; ++dy) {
    for (int32_t dx = -kCrossTemplateHalf; dx <= kCrossTemplateHalf; ++dx) {
      Vec2 u_a;
      bool inside = warp(ub + Vec2(dx, dy), u_a);
      double sum = 0.0;
      for (int32_t j = 0; j < sub && inside; ++j) {
        for (int32_t i = 0; i < sub && inside; ++i) {
          const Vec2 q = u_a + map * Vec2((i + 0.5) / sub - 0.5, (j + 0.5) / sub - 0.5);
          double v = 0.0;
          inside = keptSample(ai, q.x(), q.y(), v);
          sum += v;
        }
      }
      if (!inside) {
        counts.warp_failed += 1;
        return false;
      }
      template_[n++] = sum / (sub * sub);
    }
  }
  // The search: NCC at every integer shift.
  double best = kNccInvalid;
  int32_t bx = 0, by = 0;
  for (int32_t sy = -kCrossSearchRadiusPx; sy <= kCrossSearchRadiusPx; ++sy) {
    for (int32_t sx = -kCrossSearchRadiusPx; sx <= kCrossSearchRadiusPx; ++sx) {
      int32_t k = 0;
      for (int32_t dy = -kCrossTemplateHalf; dy <= kCrossTemplateHalf; ++dy) {
        const uint8_t* row = bi.pixels + (ub_y + sy + dy) * bi.width + ub_x + sx;
        for (int32_t dx = -kCrossTemplateHalf; dx <= kCrossTemplateHalf; ++dx) window_[k++] = row[dx];
      }
      const double v = nccOfSamples(template_, window_, kCrossTemplatePixels,
                                    kMinNccVariance * kCrossTemplatePixels * kCrossTemplatePixels);
      score_[sy + kCrossSearchRadiusPx][sx + kCrossSearchRadiusPx] = v;
      if (v > best) {
        best = v;
        bx = sx;
        by = sy;
      }
    }
  }
  double second = kNccInvalid;
  for (int32_t sy = -kCrossSearchRadiusPx; sy <= kCrossSearchRadiusPx; ++sy) {
    for (int32_t sx = -kCrossSearchRadiusPx; sx <= kCrossSearchRadiusPx; ++sx) {
      if (std::abs(sx - bx) < 2 && std::abs(sy - by) < 2) continue;
      const double v = score_[sy + kCrossSearchRadiusPx][sx + kCrossSearchRadiusPx];
      if (v > second) second = v;
    }
  }
  if (best < params.min_ncc) {
    counts.low_ncc += 1;
    return false;
  }
  if (second > params.max_second_ratio * best) {
    counts.ambiguous += 1;
    return false;
  }
  if (std::abs(bx) == kCrossSearchRadiusPx || std::abs(by) == kCrossSearchRadiusPx) {
    counts.edge_peak += 1;
    return false;
  }
  const auto at = [this](int32_t sx, int32_t sy) {
    return score_[sy + kCrossSearchRadiusPx][sx + kCrossSearchRadiusPx];
  };
  const double ox = parabolaOffset(at(bx - 1, by), best, at(bx + 1, by));
  const double oy = parabolaOffset(at(bx, by - 1), best, at(bx, by + 1));
  // The template's centre is A's image of the ground at B's integer pixel ub, so the peak places that
  // pixel; the candidate itself lies at the unrounded prediction u_b, the same shift away.
  tie.matcher_px = Vec2(fullResolutionPx(u_b.x() + bx + ox, bi.bin), fullResolutionPx(u_b.y() + by + oy, bi.bin));
  tie.ncc = best;
  counts.matched += 1;
  return true;
}

}  // namespace areomap
