#include "firmware_core/match/PanoramaMatcher.hpp"

#include <cmath>

#include "firmware_core/match/EpipolarSearch.hpp"
#include "firmware_core/match/Ncc.hpp"
#include "firmware_core/match/ParallaxVerifier.hpp"

namespace areomap {
namespace {
constexpr double kWarpBasePx = 4.0;  // pixel offset used to measure the local affine map of a patch
constexpr double kOffsetScalePx = 512.0;  // normalises image positions in the offset field
constexpr int32_t kMinAffineOffsets = 6;  // fewer inliers: a constant offset field

Vec3 offsetBasis(const Vec2& px) { return Vec3(1.0, px.x() / kOffsetScalePx, px.y() / kOffsetScalePx); }
}  // namespace

void PanoramaMatcher::reset() {
  pair_count_ = 0;
  observations_.reset();
  points_.reset();
}

void PanoramaMatcher::planForPairs(int32_t pairs) {
  const int32_t share = pairs > 0 ? (kMaxTiePoints * 4 / 5) / pairs : kMaxTiesPerPair;
  stereo.tie_budget = share < 16 ? 16 : (share > kMaxTiesPerPair ? kMaxTiesPerPair : share);
}

bool PanoramaMatcher::addObservation(int32_t point, int32_t image, double sample_px, double line_px, TieKind kind,
                                     float score) {
  TiePoint& p = points_[point];
  if (p.observation_count >= kMaxObsPerPoint) return false;
  TieObservation o;
  o.point = point;
  o.image = image;
  o.sample_px = sample_px;
  o.line_px = line_px;
  o.kind = kind;
  o.score = score;
  if (!observations_.push(o)) return false;
  ++p.observation_count;
  return true;
}

Status PanoramaMatcher::addPair(const ImageView& left, const ImageView* right, const CameraModel& left_model,
                                const CameraModel* right_model, PairTieReport& report) {
  report = PairTieReport();
  if (!left.valid()) return Status::kInvalidArgument;
  if (left.width > kMaxImageWidth || left.height > kMaxImageHeight) return Status::kCapacityExceeded;
  if (pair_count_ >= kMaxPairs) return Status::kCapacityExceeded;
  const bool has_right = right != nullptr && right_model != nullptr && right->valid();
  const int32_t j = pair_count_;
  StoredPair& stored = pairs_[j];
  stored.model[0] = left_model;
  stored.model[1] = has_right ? *right_model : left_model;
  stored.has_right = has_right;
  stored.tie_count = 0;

  // 1. Intra-stereo ties.
  stereo_result_.tie_count = 0;
  if (has_right) {
    report.intra_status = matchStereoPair(left, *right, left_model, *right_model, stereo, stereo_workspace_,
                                          stereo_result_);
    report.intra = stereo_result_.counts;
    if (report.intra_status == Status::kInvalidArgument || report.intra_status == Status::kCapacityExceeded) {
      return report.intra_status;
    }
  } else {
    report.intra_status = Status::kMissingField;
  }

  // 2. Coarse DEM of the pair from its ties (the ground points are kept in the stereo scratch).
  dem_.reset(left_model.c);
  bool triangulated[kMaxTiesPerPair];
  Vec3 ground[kMaxTiesPerPair];
  for (int32_t i = 0; i < stereo_result_.tie_count; ++i) {
    double miss_m = 0.0;
    const StereoMatch& m = stereo_result_.ties[i];
    triangulated[i] = ok(triangulateMidpoint(left_model, *right_model, m.left_px, m.right_px, ground[i], miss_m));
    if (triangulated[i]) (void)dem_.addPoint(ground[i]);
  }
  dem_.finish();
  report.dem_points = dem_.pointCount();
  report.dem_cells = dem_.measuredCells();

  // 3. Inter-stereo ties from every earlier pair into this one.
  const ImageView* images[2] = {&left, has_right ? right : nullptr};
  interTies(j, images, report);

  // 4. The new points, their intra observations and the stored patches for later pairs.
  for (int32_t i = 0; i < stereo_result_.tie_count; ++i) {
    if (!triangulated[i]) continue;
    const StereoMatch& m = stereo_result_.ties[i];
    NccTemplate t;
    if (!extractTemplate(left, static_cast<int32_t>(m.left_px.x()), static_cast<int32_t>(m.left_px.y()), t)) continue;
    TiePoint p;
    p.ground_m = ground[i];
    p.pair = j;
    if (!points_.push(p)) {
      ++report.overflow;
      continue;
    }
    const int32_t id = points_.size() - 1;
    const bool ok_left = addObservation(id, 2 * j, m.left_px.x(), m.left_px.y(), TieKind::kIntra, 1.0f);
    const bool ok_right =
        ok_left && addObservation(id, 2 * j + 1, m.right_px.x(), m.right_px.y(), TieKind::kIntra, static_cast<float>(m.score));
    if (!ok_right) {
      if (ok_left) observations_.pop();
      points_.pop();
      ++report.overflow;
      continue;
    }
    StoredTie& st = stored.ties[stored.tie_count++];
    for (int32_t k = 0; k < kNccPixels; ++k) st.patch[k] = t.pixels[k];
    Vec3 origin, direction, predicted;
    st.predicted_m = ground[i];
    const bool have_ray = ok(unproject(left_model, m.left_px, origin, direction));
    if (have_ray && ok(dem_.intersectRay(origin, direction, predicted))) st.predicted_m = predicted;
    // The patch's shape on the surface: where its neighbouring pixels meet the DEM (or, without a DEM there,
    // the plane through the point facing the camera).
    st.has_shape = have_ray;
    for (int32_t axis = 0; axis < 2 && st.has_shape; ++axis) {
      const Vec2 offset_px = m.left_px + (axis == 0 ? Vec2(kWarpBasePx, 0.0) : Vec2(0.0, kWarpBasePx));
      Vec3 o2, d2, p2;
      st.has_shape = ok(unproject(left_model, offset_px, o2, d2));
      if (!st.has_shape) break;
      if (!ok(dem_.intersectRay(o2, d2, p2))) {
        const double range = (st.predicted_m - o2).dot(direction) / d2.dot(direction);
        p2 = o2 + range * d2;
      }
      (axis == 0 ? st.predicted_dx_m : st.predicted_dy_m) = p2;
    }
    st.point = id;
    st.source_px = m.left_px;
  }
  if (!has_right) storeSingleImagePoints(left, left_model, stored);
  ++pair_count_;
  // A single image has done its part when it has stored interest points for the pairs that follow.
  const bool any = stereo_result_.tie_count > 0 || report.inter_observations > 0 || (!has_right && stored.tie_count > 0);
  return any ? Status::kOk : Status::kNoTexture;
}

void PanoramaMatcher::fitOffsets(int32_t n, double initial_tolerance_px, double tolerance_px, Vec3& fx, Vec3& fy) {
  for (int32_t c = 0; c < n; ++c) scratch_[c] = candidates_[c].dx;
  const double mdx = medianInPlace(scratch_, n);
  for (int32_t c = 0; c < n; ++c) scratch_[c] = candidates_[c].dy;
  const double mdy = medianInPlace(scratch_, n);
  fx = Vec3(mdx, 0.0, 0.0);
  fy = Vec3(mdy, 0.0, 0.0);
  double tolerance = initial_tolerance_px;
  for (int32_t iteration = 0; iteration <= kMaxParallaxFitIterations; ++iteration) {
    int32_t inliers = 0;
    bool changed = false;
    for (int32_t c = 0; c < n; ++c) {
      const Vec3 b = offsetBasis(candidates_[c].px);
      const bool in = std::fabs(candidates_[c].dx - fx.dot(b)) <= tolerance &&
                      std::fabs(candidates_[c].dy - fy.dot(b)) <= tolerance;
      changed = changed || in != inlier_[c] || iteration == 0;
      inlier_[c] = in;
      inliers += in ? 1 : 0;
    }
    if ((!changed && tolerance == tolerance_px) || iteration == kMaxParallaxFitIterations) break;
    tolerance = tolerance_px;
    if (inliers < kMinAffineOffsets) continue;  // keep the constant (median) field
    Mat3 normal = Mat3::Zero();
    Vec3 rx = Vec3::Zero(), ry = Vec3::Zero();
    for (int32_t c = 0; c < n; ++c) {
      if (!inlier_[c]) continue;
      const Vec3 b = offsetBasis(candidates_[c].px);
      normal.noalias() += b * b.transpose();
      rx.noalias() += b * candidates_[c].dx;
      ry.noalias() += b * candidates_[c].dy;
    }
    const Eigen::LDLT<Mat3> ldlt(normal);
    if (ldlt.info() != Eigen::Success || ldlt.rcond() < 1e-9) continue;
    fx = ldlt.solve(rx);
    fy = ldlt.solve(ry);
  }
}

void PanoramaMatcher::storeSingleImagePoints(const ImageView& left, const CameraModel& model, StoredPair& stored) {
  int32_t count = 0;
  ForstnerParams forstner = stereo.forstner;
  forstner.cell_px = spreadingGridPx(stereo, left.width, left.height);
  if (!ok(detectInterestPoints(left, forstner, stereo_workspace_.forstner, stereo_workspace_.points,
                               kMaxInterestPoints, count))) {
    if (count == 0) return;
  }
  // Gridding as for stereo ties: the strongest point per cell.
  const int32_t cell = selectionGridPx(stereo, left.width, left.height);
  const int32_t cells_x = (left.width + cell - 1) / cell;
  const int32_t cells_y = (left.height + cell - 1) / cell;
  if (cell < 1 || cells_x * cells_y > kMaxTiesPerPair) return;
  int32_t* best = stereo_workspace_.cell_best;
  for (int32_t c = 0; c < cells_x * cells_y; ++c) best[c] = -1;
  for (int32_t i = 0; i < count; ++i) {
    const InterestPoint& p = stereo_workspace_.points[i];
    const int32_t c = (p.pixel_y / cell) * cells_x + p.pixel_x / cell;
    if (best[c] < 0 || stereo_workspace_.points[best[c]].weight < p.weight) best[c] = i;
  }
  for (int32_t c = 0; c < cells_x * cells_y; ++c) {
    if (best[c] < 0) continue;
    const InterestPoint& p = stereo_workspace_.points[best[c]];
    const int32_t x = static_cast<int32_t>(std::lround(p.x_px));
    const int32_t y = static_cast<int32_t>(std::lround(p.y_px));
    NccTemplate t;
    Vec3 origin, direction;
    if (!extractTemplate(left, x, y, t) || !t.textured || !ok(unproject(model, Vec2(x, y), origin, direction))) {
      continue;
    }
    double range = inter.single_max_range_m;
    if (direction.z() > 1e-6) range = (inter.ground_z_m - origin.z()) / direction.z();
    range = std::fmax(inter.single_min_range_m, std::fmin(inter.single_max_range_m, range));
    StoredTie& st = stored.ties[stored.tie_count++];
    for (int32_t k = 0; k < kNccPixels; ++k) st.patch[k] = t.pixels[k];
    st.predicted_m = origin + range * direction;
    // Shape: the neighbouring pixels' rays at the same range (exact for frames turned about the mast).
    Vec3 o2, d2;
    st.has_shape = ok(unproject(model, Vec2(x + kWarpBasePx, y), o2, d2));
    st.predicted_dx_m = o2 + range * d2;
    st.has_shape = st.has_shape && ok(unproject(model, Vec2(x, y + kWarpBasePx), o2, d2));
    st.predicted_dy_m = o2 + range * d2;
    st.source_px = Vec2(x, y);
    st.point = -1;
  }
}

void PanoramaMatcher::interTies(int32_t new_pair, const ImageView* images[2], PairTieReport& report) {
  const StoredPair& target = pairs_[new_pair];
  for (int32_t i = 0; i < new_pair; ++i) {
    StoredPair& source = pairs_[i];
    bool linked = false;
    for (int32_t side = 0; side < 2; ++side) {
      const ImageView* image = images[side];
      if (image == nullptr) continue;
      const CameraModel& model = target.model[side];
      const int32_t margin = kNccRadius + 1;
      // Predictions inside this image, with the local shape of each patch.
      int32_t np = 0;
      for (int32_t k = 0; k < source.tie_count; ++k) {
        const StoredTie& st = source.ties[k];
        if (st.point >= 0 && points_[st.point].observation_count >= kMaxObsPerPoint) continue;
        Vec2 predicted;
        if (!ok(project(model, st.predicted_m, predicted))) continue;
        if (predicted.x() < margin || predicted.y() < margin || predicted.x() > image->width - 1 - margin ||
            predicted.y() > image->height - 1 - margin) {
          continue;
        }
        ++report.inter_candidates;
        Mat2 a = Mat2::Identity();
        Vec2 px_dx, px_dy;
        if (st.has_shape && ok(project(model, st.predicted_dx_m, px_dx)) && ok(project(model, st.predicted_dy_m, px_dy))) {
          a.col(0) = (px_dx - predicted) / kWarpBasePx;
          a.col(1) = (px_dy - predicted) / kWarpBasePx;
          const double det = a.determinant();
          if (!(det > 0.25 && det < 4.0)) a = Mat2::Identity();  // implausible shape: compare unwarped
        }
        predictions_[np++] = Prediction{k, predicted, a};
      }
      if (np == 0) continue;
      // Probe: a few predictions spread over the list, searched in a wide window, measure the common
      // offset (the difference of the two pairs' a-priori pointing errors).
      const int32_t probes = np < kMaxInterOffsetProbes ? np : kMaxInterOffsetProbes;
      int32_t found = 0;
      for (int32_t q = 0; q < probes; ++q) {
        const Prediction& pr = predictions_[(q * np) / probes];
        NccTemplate t;
        templateFromPixels(source.ties[pr.tie].patch, t);
        const SearchHit hit = searchWindowWarped(t, *image, static_cast<int32_t>(std::lround(pr.px.x())),
                                                 static_cast<int32_t>(std::lround(pr.px.y())),
                                                 inter.probe_radius_px, pr.shape);
        // No ambiguity test here: the probes only feed the robust offset field, which drops strays.
        if (hit.score < inter.min_ncc) continue;
        candidates_[found++] = Candidate{pr.tie, pr.px, hit.score, hit.x - pr.px.x(), hit.y - pr.px.y()};
      }
      if (found < inter.min_group) continue;
      Vec3 field_x, field_y;
      fitOffsets(found, inter.probe_radius_px, inter.search_radius_px, field_x, field_y);

      // Search every prediction around its corrected position.
      int32_t n = 0;
      for (int32_t c = 0; c < np; ++c) {
        const Prediction& pr = predictions_[c];
        NccTemplate t;
        templateFromPixels(source.ties[pr.tie].patch, t);
        if (!t.textured) continue;
        const Vec3 basis = offsetBasis(pr.px);
        const int32_t px = static_cast<int32_t>(std::lround(pr.px.x() + field_x.dot(basis)));
        const int32_t py = static_cast<int32_t>(std::lround(pr.px.y() + field_y.dot(basis)));
        const SearchHit hit = searchWindowWarped(t, *image, px, py, inter.search_radius_px, pr.shape);
        if (hit.score < inter.min_ncc || hit.second > stereo.max_second_ratio * hit.score) continue;
        double x = 0.0, y = 0.0;
        refinePeakWarped(t, *image, hit.x, hit.y, hit.score, pr.shape, x, y);
        ++report.inter_matched;
        // The match is kept as its offset from the prediction; the position is rebuilt when accepted.
        candidates_[n++] = Candidate{pr.tie, pr.px, hit.score, x - pr.px.x(), y - pr.px.y()};
      }
      if (n == 0) continue;
      if (n < inter.min_group) {
        report.inter_rejected += n;
        continue;
      }
      // Verification: the offsets from the prediction (a-priori pointing errors) follow one smooth (affine)
      // field over the image.
      fitOffsets(n, inter.search_radius_px + inter.offset_tolerance_px, inter.offset_tolerance_px, field_x, field_y);
      for (int32_t c = 0; c < n; ++c) {
        const Candidate& cand = candidates_[c];
        if (!inlier_[c]) {
          ++report.inter_rejected;
          continue;
        }
        StoredTie& st = source.ties[cand.tie];
        const Vec2 predicted = cand.px;
        if (st.point < 0) {
          // First match of a single image's interest point: the point is born with both observations.
          TiePoint p;
          p.ground_m = st.predicted_m;
          p.pair = i;
          if (!points_.push(p)) {
            ++report.overflow;
            continue;
          }
          st.point = points_.size() - 1;
          if (!addObservation(st.point, 2 * i, st.source_px.x(), st.source_px.y(), TieKind::kInter, 1.0f)) {
            ++report.overflow;
            continue;
          }
        }
        if (addObservation(st.point, 2 * new_pair + side, predicted.x() + cand.dx, predicted.y() + cand.dy,
                           TieKind::kInter, static_cast<float>(cand.score))) {
          ++report.inter_observations;
          linked = true;
        } else {
          ++report.overflow;
        }
      }
    }
    report.neighbours += linked ? 1 : 0;
  }
}

}  // namespace areomap
