#include "firmware_core/match/PanoramaMatcher.hpp"

#include <cmath>

#include "firmware_core/camera/RayIntersection.hpp"
#include "firmware_core/match/Gridding.hpp"
#include "firmware_core/match/Ncc.hpp"
#include "firmware_core/match/ParallaxVerifier.hpp"

namespace areomap {
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
  if (cell < 1) return;
  const Gridding grid(cell, left.width, left.height);
  if (grid.cells() > kMaxTiesPerPair) return;
  int32_t* best = stereo_workspace_.cell_best;
  const InterestPoint* points = stereo_workspace_.points;
  grid.selectBest(
      count,
      [points](int32_t i, int32_t& x, int32_t& y) {
        x = points[i].pixel_x;
        y = points[i].pixel_y;
        return true;
      },
      [points](int32_t i) { return points[i].weight; }, best);
  for (int32_t c = 0; c < grid.cells(); ++c) {
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

}  // namespace areomap
