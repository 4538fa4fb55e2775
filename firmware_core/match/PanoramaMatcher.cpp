#include "firmware_core/match/PanoramaMatcher.hpp"

#include <cmath>

#include "firmware_core/camera/RayIntersection.hpp"
#include "firmware_core/match/EpipolarSearch.hpp"
#include "firmware_core/match/Ncc.hpp"
#include "firmware_core/match/ParallaxVerifier.hpp"

namespace areomap {
namespace {
constexpr double kWarpBasePx = 4.0;  // pixel offset used to measure the local affine map of a patch
constexpr double kOffsetScalePx = 512.0;  // normalises image positions in the offset field
constexpr int32_t kMinAffineOffsets = 6;  // fewer inliers: a constant offset field
constexpr double kTransferRangeFactor = 1.5;  // range interval searched by transferInPair

Vec3 offsetBasis(const Vec2& px) { return Vec3(1.0, px.x() / kOffsetScalePx, px.y() / kOffsetScalePx); }
}  // namespace

void PanoramaMatcher::reset() {
  pair_count_ = 0;
  observations_.reset();
  points_.reset();
}

void PanoramaMatcher::planForPairs(int32_t pairs) {
  planned_pairs_ = pairs > 0 && pairs <= kMaxPairs ? pairs : kMaxPairs;
  const int32_t share = pairs > 0 ? (kMaxTiePoints * 7 / 10) / pairs : kMaxTiesPerPair;
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

TieList PanoramaMatcher::ties() const {
  TieList list;
  list.points = points_.data();
  list.point_count = points_.size();
  list.observations = observations_.data();
  list.observation_count = observations_.size();
  list.pair_count = pair_count_;
  return list;
}

Status PanoramaMatcher::addPair(const ImageView& left, const ImageView* right, const CameraModel& left_model,
                                const CameraModel* right_model, CoarseDem& dem, PairTieReport& report) {
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
  dem.reset(left_model.c);
  bool triangulated[kMaxTiesPerPair];
  Vec3 ground[kMaxTiesPerPair];
  for (int32_t i = 0; i < stereo_result_.tie_count; ++i) {
    double miss_m = 0.0;
    const StereoMatch& m = stereo_result_.ties[i];
    triangulated[i] = ok(triangulateMidpoint(left_model, *right_model, m.left_px, m.right_px, ground[i], miss_m));
    if (triangulated[i]) (void)dem.addPoint(ground[i]);
  }
  dem.finish();
  report.dem_points = dem.pointCount();
  report.dem_cells = dem.measuredCells();

  // 3. Inter-stereo ties from every earlier pair into this one (points created up to the pair's cumulative
  // share, its own selected ties kept free).
  const int32_t planned = planned_pairs_ > j ? planned_pairs_ : j + 1;
  birth_limit_ = static_cast<int32_t>(static_cast<int64_t>(kMaxTiePoints) * (j + 1) / planned) - stereo_result_.tie_count;
  const ImageView* images[2] = {&left, has_right ? right : nullptr};
  interTies(j, images, report);

  // 4. The new points, their intra observations and the stored patches for later pairs.
  for (int32_t i = 0; i < stereo_result_.tie_count; ++i) {
    if (!triangulated[i]) continue;
    const StereoMatch& m = stereo_result_.ties[i];
    StoredTie& st = stored.ties[stored.tie_count];
    if (!fillStoredTie(left, left_model, dem, m, ground[i], st)) continue;
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
    st.point = id;
    ++stored.tie_count;
  }
  if (has_right) {
    storeInterCandidates(left, left_model, *right_model, dem, stored, report);
  } else {
    storeSingleImagePoints(left, left_model, stored);
  }
  ++pair_count_;
  // A single image has done its part when it has stored interest points for the pairs that follow.
  const bool any = stereo_result_.tie_count > 0 || report.inter_observations > 0 || (!has_right && stored.tie_count > 0);
  return any ? Status::kOk : Status::kNoTexture;
}

bool PanoramaMatcher::fillStoredTie(const ImageView& left, const CameraModel& left_model,
                                    const CoarseDem& dem, const StereoMatch& m, const Vec3& ground,
                                    StoredTie& st) const {
  NccTemplate t;
  if (!extractTemplate(left, static_cast<int32_t>(m.left_px.x()), static_cast<int32_t>(m.left_px.y()), t)) return false;
  for (int32_t k = 0; k < kNccPixels; ++k) st.patch[k] = t.pixels[k];
  Vec3 origin, direction, on_dem;
  Vec3 predicted = ground;
  const bool have_ray = ok(unproject(left_model, m.left_px, origin, direction));
  if (have_ray && ok(dem.intersectRay(origin, direction, on_dem))) predicted = on_dem;
  st.predicted_m = predicted.cast<float>();
  // The patch's shape on the surface: where its neighbouring pixels meet the DEM (or, without a DEM there,
  // the plane through the point facing the camera).
  st.has_shape = have_ray;
  for (int32_t axis = 0; axis < 2 && st.has_shape; ++axis) {
    const Vec2 offset_px = m.left_px + (axis == 0 ? Vec2(kWarpBasePx, 0.0) : Vec2(0.0, kWarpBasePx));
    Vec3 o2, d2, p2;
    st.has_shape = ok(unproject(left_model, offset_px, o2, d2));
    if (!st.has_shape) break;
    if (!ok(dem.intersectRay(o2, d2, p2))) {
      const double range = (predicted - o2).dot(direction) / d2.dot(direction);
      p2 = o2 + range * d2;
    }
    (axis == 0 ? st.predicted_dx_m : st.predicted_dy_m) = p2.cast<float>();
  }
  st.source_px[0] = static_cast<int16_t>(m.left_px.x());
  st.source_px[1] = static_cast<int16_t>(m.left_px.y());
  st.right_px[0] = static_cast<float>(m.right_px.x());
  st.right_px[1] = static_cast<float>(m.right_px.y());
  st.intra_score = static_cast<float>(m.score);
  st.has_intra = true;
  st.point = -1;
  return true;
}

void PanoramaMatcher::storeInterCandidates(const ImageView& left, const CameraModel& left_model,
                                           const CameraModel& right_model, const CoarseDem& dem,
                                           StoredPair& stored, PairTieReport& report) {
  if (stored.tie_count >= kMaxStoredTiesPerPair) return;
  const StereoWorkspace& ws = stereo_workspace_;
  const int32_t grid = selectionGridPx(stereo, left.width, left.height);
  const int32_t grid_x = (left.width + grid - 1) / grid;
  // Band cells: half the selection cell, coarse enough for kCandidateGridSide cells along the larger side.
  // Corner cells: the finest (kCandidateGridSide along the larger side) within three band cells of two
  // perpendicular borders -- a diagonal neighbour (the pair beside the one above or below) overlaps only
  // such a corner, a few cells in all, so the corners get the densest candidates and come first.
  const int32_t side = left.width > left.height ? left.width : left.height;
  const int32_t fine = (side + kCandidateGridSide - 1) / kCandidateGridSide;
  const int32_t band = grid / 2 > fine ? grid / 2 : fine;
  const int32_t corner_px = 3 * band;
  int32_t* best = candidate_best_;
  int32_t n = 0;  // entries of the sorted list (candidate_best_ / candidate_border_), corners first
  for (int32_t pass = 0; pass < 2; ++pass) {
    const bool corners = pass == 0;
    const int32_t cell = corners ? fine : band;
    const int32_t cells_x = (left.width + cell - 1) / cell;
    const int32_t cells_y = (left.height + cell - 1) / cell;
    int32_t* cell_best = best + n;  // this pass's cells, after the entries already sorted
    const int32_t cells = cells_x * cells_y;
    if (n + cells > 2 * kCandidateGridSide * kCandidateGridSide) break;
    for (int32_t c = 0; c < cells; ++c) cell_best[c] = -1;
    for (int32_t i = 0; i < ws.match_count; ++i) {
      const StereoMatch& m = ws.matches[i];
      if (!m.verified) continue;
      const int32_t x = static_cast<int32_t>(m.left_px.x());
      const int32_t y = static_cast<int32_t>(m.left_px.y());
      if (ws.cell_best[(y / grid) * grid_x + x / grid] == i) continue;  // selected: already a tie point
      const int32_t dx = x < left.width - 1 - x ? x : left.width - 1 - x;
      const int32_t dy = y < left.height - 1 - y ? y : left.height - 1 - y;
      const bool in_corner = dx < corner_px && dy < corner_px;
      if (corners != in_corner) continue;
      int32_t& b = cell_best[(y / cell) * cells_x + x / cell];
      if (b < 0 || ws.matches[b].score < m.score) b = i;
    }
    // Sorted by the distance to the corner (the larger border distance) or to the border (the smaller),
    // insertion sort in place: slot n + k is free once cell k has been read.
    const int32_t first = n;
    for (int32_t c = 0; c < cells; ++c) {
      const int32_t match = cell_best[c];
      if (match < 0) continue;
      const Vec2& px = ws.matches[match].left_px;
      const double dx = std::fmin(px.x(), left.width - 1 - px.x());
      const double dy = std::fmin(px.y(), left.height - 1 - px.y());
      const int32_t key = static_cast<int32_t>(corners ? std::fmax(dx, dy) : std::fmin(dx, dy));
      int32_t k = n++;
      for (; k > first && candidate_border_[k - 1] > key; --k) {
        candidate_border_[k] = candidate_border_[k - 1];
        best[k] = best[k - 1];
      }
      candidate_border_[k] = key;
      best[k] = match;
    }
  }
  for (int32_t k = 0; k < n && stored.tie_count < kMaxStoredTiesPerPair; ++k) {
    const StereoMatch& m = ws.matches[best[k]];
    Vec3 ground;
    double miss_m = 0.0;
    if (!ok(triangulateMidpoint(left_model, right_model, m.left_px, m.right_px, ground, miss_m))) continue;
    if (!fillStoredTie(left, left_model, dem, m, ground, stored.ties[stored.tie_count])) continue;
    ++stored.tie_count;
    ++report.inter_candidates_stored;
  }
}

void PanoramaMatcher::fitOffsets(int32_t n, double initial_tolerance_px, double tolerance_px, Vec3& fx, Vec3& fy) {
  // Start from the offset that most candidates agree with (within the final tolerance; ties: the higher
  // summed score): unlike the median it holds when strays are the majority (narrow overlaps, where many
  // probes find nothing true).
  int32_t seed = 0;
  int32_t seed_support = -1;
  double seed_score = 0.0;
  for (int32_t a = 0; a < n; ++a) {
    int32_t support = 0;
    double score = 0.0;
    for (int32_t b = 0; b < n; ++b) {
      if (std::fabs(candidates_[a].dx - candidates_[b].dx) > tolerance_px ||
          std::fabs(candidates_[a].dy - candidates_[b].dy) > tolerance_px) {
        continue;
      }
      ++support;
      score += candidates_[b].score;
    }
    if (support > seed_support || (support == seed_support && score > seed_score)) {
      seed = a;
      seed_support = support;
      seed_score = score;
    }
  }
  fx = Vec3(candidates_[seed].dx, 0.0, 0.0);
  fy = Vec3(candidates_[seed].dy, 0.0, 0.0);
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
    if (inliers < kMinAffineOffsets) continue;  // keep the constant (seed) field
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
    st.predicted_m = (origin + range * direction).cast<float>();
    // Shape: the neighbouring pixels' rays at the same range (exact for frames turned about the mast).
    Vec3 o2, d2;
    st.has_shape = ok(unproject(model, Vec2(x + kWarpBasePx, y), o2, d2));
    st.predicted_dx_m = (o2 + range * d2).cast<float>();
    st.has_shape = st.has_shape && ok(unproject(model, Vec2(x, y + kWarpBasePx), o2, d2));
    st.predicted_dy_m = (o2 + range * d2).cast<float>();
    st.source_px[0] = static_cast<int16_t>(x);
    st.source_px[1] = static_cast<int16_t>(y);
    st.has_intra = false;
    st.point = -1;
  }
}

void PanoramaMatcher::interTies(int32_t new_pair, const ImageView* images[2], PairTieReport& report) {
  const StoredPair& target = pairs_[new_pair];
  for (int32_t i = 0; i < new_pair; ++i) {
    StoredPair& source = pairs_[i];
    bool linked = false;
    // The image of the new pair nearest the source's left camera (whose patches are stored) is matched
    // first; the other one then takes each point's observation from the near one through the pair's own
    // stereo geometry. A patch matched directly into a view from far off (a stereo base away) is pulled off
    // its point wherever it straddles an occluding edge (a rock's outline), always the same way: the
    // transfer keeps the inter-stereo observations as unbiased as the intra-stereo ones.
    const bool both = images[0] != nullptr && images[1] != nullptr;
    const int32_t near_side = both && (target.model[1].c - source.model[0].c).norm() <
                                          (target.model[0].c - source.model[0].c).norm()
                                  ? 1
                                  : 0;
    for (int32_t k = 0; k < source.tie_count; ++k) near_ok_[k] = false;
    for (int32_t pass = 0; pass < 2; ++pass) {
      const int32_t side = pass == 0 ? near_side : 1 - near_side;
      const bool transfer = both && pass == 1;
      const ImageView* image = images[side];
      if (image == nullptr) continue;
      const CameraModel& model = target.model[side];
      const int32_t margin = kNccRadius + 1;
      // Predictions inside this image or up to the probe radius outside it (the a-priori pointing errors of
      // the two pairs can move a point that is inside by that much: a narrow overlap may be predicted
      // narrower than it is), with the local shape of each patch.
      const int32_t reach = inter.probe_radius_px - margin;
      int32_t np = 0;
      for (int32_t k = 0; k < source.tie_count; ++k) {
        const StoredTie& st = source.ties[k];
        if (st.point >= 0 && points_[st.point].observation_count >= kMaxObsPerPoint) continue;
        Vec2 predicted;
        if (!ok(project(model, st.predicted_m.cast<double>(), predicted))) continue;
        if (predicted.x() < -reach || predicted.y() < -reach || predicted.x() > image->width - 1 + reach ||
            predicted.y() > image->height - 1 + reach) {
          continue;
        }
        ++report.inter_candidates;
        Mat2 a = Mat2::Identity();
        Vec2 px_dx, px_dy;
        if (st.has_shape && ok(project(model, st.predicted_dx_m.cast<double>(), px_dx)) &&
            ok(project(model, st.predicted_dy_m.cast<double>(), px_dy))) {
          a.col(0) = (px_dx - predicted) / kWarpBasePx;
          a.col(1) = (px_dy - predicted) / kWarpBasePx;
          const double det = a.determinant();
          if (!(det > 0.25 && det < 4.0)) a = Mat2::Identity();  // implausible shape: compare unwarped
        }
        const bool inside = predicted.x() >= margin && predicted.y() >= margin &&
                            predicted.x() <= image->width - 1 - margin && predicted.y() <= image->height - 1 - margin;
        predictions_[np++] = Prediction{k, predicted, a, inside};
      }
      if (np == 0) continue;
      // Probe: a few predictions spread over the list, searched in a wide window, measure the common
      // offset (the difference of the two pairs' a-priori pointing errors). Predictions inside the image
      // come first (those outside it are in the image only if the offset brings them in).
      const int32_t probes = np < kMaxInterOffsetProbes ? np : kMaxInterOffsetProbes;
      int32_t inside = 0;
      for (int32_t c = 0; c < np; ++c) inside += predictions_[c].inside ? 1 : 0;
      const int32_t probes_inside = inside < probes ? inside : probes;
      int32_t probe_of[kMaxInterOffsetProbes];
      for (int32_t pass = 0, q = 0; pass < 2; ++pass) {
        const int32_t pool = pass == 0 ? inside : np - inside;
        const int32_t wanted = pass == 0 ? probes_inside : probes - probes_inside;
        for (int32_t c = 0, seen = 0, taken = 0; c < np && taken < wanted; ++c) {
          if (predictions_[c].inside != (pass == 0)) continue;
          if (seen++ != (taken * pool) / wanted) continue;
          probe_of[q++] = c;
          ++taken;
        }
      }
      int32_t found = 0;
      for (int32_t q = 0; q < probes; ++q) {
        const Prediction& pr = predictions_[probe_of[q]];
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
      fitOffsets(found, 2.0 * inter.search_radius_px, inter.search_radius_px, field_x, field_y);

      // Search every prediction around its corrected position.
      int32_t n = 0;
      for (int32_t c = 0; c < np; ++c) {
        const Prediction& pr = predictions_[c];
        if (transfer && near_ok_[pr.tie]) {
          const Vec3 p = source.ties[pr.tie].predicted_m.cast<double>();
          Vec2 far_px;
          double score = 0.0;
          if (!transferInPair(*images[near_side], *image, target.model[near_side], model, near_px_[pr.tie],
                              (p - target.model[near_side].c).norm(), far_px, score)) {
            continue;
          }
          ++report.inter_matched;
          candidates_[n++] = Candidate{pr.tie, pr.px, score, far_px.x() - pr.px.x(), far_px.y() - pr.px.y()};
          continue;
        }
        NccTemplate t;
        templateFromPixels(source.ties[pr.tie].patch, t);
        if (!t.textured) continue;
        const Vec3 basis = offsetBasis(pr.px);
        const int32_t px = static_cast<int32_t>(std::lround(pr.px.x() + field_x.dot(basis)));
        const int32_t py = static_cast<int32_t>(std::lround(pr.px.y() + field_y.dot(basis)));
        if (px < margin || py < margin || px > image->width - 1 - margin || py > image->height - 1 - margin) continue;
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
          // First match of a stored candidate: the point is born with its observations in the source pair
          // (both intra-stereo ones, or the single image's interest point).
          if (points_.size() >= birth_limit_) {
            ++report.births_deferred;
            continue;
          }
          TiePoint p;
          p.ground_m = st.predicted_m.cast<double>();
          p.pair = i;
          if (!points_.push(p)) {
            ++report.overflow;
            continue;
          }
          st.point = points_.size() - 1;
          const bool born =
              st.has_intra
                  ? addObservation(st.point, 2 * i, st.source_px[0], st.source_px[1], TieKind::kIntra, 1.0f) &&
                        addObservation(st.point, 2 * i + 1, st.right_px[0], st.right_px[1], TieKind::kIntra,
                                       st.intra_score)
                  : addObservation(st.point, 2 * i, st.source_px[0], st.source_px[1], TieKind::kInter, 1.0f);
          if (!born) {
            ++report.overflow;
            continue;
          }
        }
        if (addObservation(st.point, 2 * new_pair + side, predicted.x() + cand.dx, predicted.y() + cand.dy,
                           TieKind::kInter, static_cast<float>(cand.score))) {
          if (pass == 0) {
            near_px_[cand.tie] = Vec2(predicted.x() + cand.dx, predicted.y() + cand.dy);
            near_ok_[cand.tie] = true;
          }
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

bool PanoramaMatcher::transferInPair(const ImageView& near_image, const ImageView& far_image,
                                     const CameraModel& near_model, const CameraModel& far_model,
                                     const Vec2& near_px, double range_m, Vec2& far_px, double& score) {
  NccTemplate near_t, far_t;
  if (!extractTemplateAt(near_image, near_px.x(), near_px.y(), near_t) || !near_t.textured) return false;
  const double lo = std::fmax(stereo.min_range_m, range_m / kTransferRangeFactor);
  const double hi = std::fmin(stereo.max_range_m, range_m * kTransferRangeFactor);
  if (!(lo < hi)) return false;
  EpipolarCurve& curve = stereo_workspace_.curve;
  if (!ok(epipolarCurve(near_model, far_model, near_px, lo, hi, far_image.width, far_image.height, curve))) {
    return false;
  }
  const SearchHit hit = searchAlongCurve(near_t, far_image, curve, stereo.band_px, stereo_workspace_.search);
  if (hit.score < stereo.min_ncc || hit.second > stereo.max_second_ratio * hit.score) return false;
  // Left-right: the far window searched back along its own curve in the near image.
  if (!extractTemplate(far_image, hit.x, hit.y, far_t) || !far_t.textured) return false;
  if (!ok(epipolarCurve(far_model, near_model, Vec2(hit.x, hit.y), lo, hi, near_image.width,
                        near_image.height, curve))) {
    return false;
  }
  const SearchHit back = searchAlongCurve(far_t, near_image, curve, stereo.band_px, stereo_workspace_.search);
  if (back.score < stereo.min_ncc || std::fabs(back.x - near_px.x()) > stereo.lr_tolerance_px + 0.5 ||
      std::fabs(back.y - near_px.y()) > stereo.lr_tolerance_px + 0.5) {
    return false;
  }
  double x = 0.0, y = 0.0;
  refinePeak(near_t, far_image, hit.x, hit.y, hit.score, x, y);
  far_px = Vec2(x, y);
  score = hit.score;
  return true;
}

}  // namespace areomap
