#include "firmware_core/match/StereoMatcher.hpp"

#include <cmath>

#include "firmware_core/match/Gridding.hpp"
#include "firmware_core/match/Ncc.hpp"

namespace areomap {

int32_t selectionGridPx(const StereoParams& params, int32_t width, int32_t height) {
  if (params.grid_cell_px > 0) return params.grid_cell_px;
  const int32_t side = width > height ? width : height;
  int32_t per_side = 1;
  while ((per_side + 1) * (per_side + 1) <= params.tie_budget && per_side < 16) ++per_side;
  const int32_t cell = (side + per_side - 1) / per_side;
  return cell < 16 ? 16 : cell;
}

int32_t spreadingGridPx(const StereoParams& params, int32_t width, int32_t height) {
  if (params.forstner.cell_px > 0) return params.forstner.cell_px;
  const int32_t side = width > height ? width : height;
  const int32_t cell = (side + 31) / 32;
  return cell < kMinSpreadingCellPx ? kMinSpreadingCellPx : cell;
}

CurveMatchStage matchAlongCurve(const NccTemplate& t, const ImageView& from, const ImageView& to,
                                const CameraModel& from_model, const CameraModel& to_model,
                                const Vec2& from_px, double lo_m, double hi_m, const StereoParams& params,
                                double back_tolerance_px, StereoWorkspace& workspace, SearchHit& hit,
                                Vec2& far_px) {
  if (!ok(epipolarCurve(from_model, to_model, from_px, lo_m, hi_m, to.width, to.height, workspace.curve))) {
    return CurveMatchStage::kNoCurve;
  }
  far_px = workspace.curve.far_px;
  hit = searchAlongCurve(t, to, workspace.curve, params.band_px, workspace.search);
  if (hit.score < params.min_ncc || hit.second > params.max_second_ratio * hit.score) {
    return CurveMatchStage::kNoMatch;
  }
  // Left-right: the window at the hit searched back along its own curve in `from`.
  NccTemplate back_template;
  if (!extractTemplate(to, hit.x, hit.y, back_template) || !back_template.textured ||
      !ok(epipolarCurve(to_model, from_model, Vec2(hit.x, hit.y), lo_m, hi_m, from.width, from.height,
                        workspace.curve))) {
    return CurveMatchStage::kNoBackMatch;
  }
  const SearchHit back =
      searchAlongCurve(back_template, from, workspace.curve, params.band_px, workspace.search);
  if (back.score < params.min_ncc || std::fabs(back.x - from_px.x()) > back_tolerance_px ||
      std::fabs(back.y - from_px.y()) > back_tolerance_px) {
    return CurveMatchStage::kNoBackMatch;
  }
  return CurveMatchStage::kMatched;
}

Status matchStereoPair(const ImageView& left, const ImageView& right, const CameraModel& left_model,
                       const CameraModel& right_model, const StereoParams& params, StereoWorkspace& workspace,
                       StereoResult& result) {
  result.tie_count = 0;
  result.counts = StereoCounts();
  result.curve = ParallaxCurve();
  workspace.match_count = 0;
  if (!left.valid() || !right.valid() || params.grid_cell_px < 0) return Status::kInvalidArgument;
  if (right.width > kMaxImageWidth || right.height > kMaxImageHeight) return Status::kCapacityExceeded;
  const Gridding grid(selectionGridPx(params, left.width, left.height), left.width, left.height);
  if (grid.cells() > kMaxTiesPerPair) return Status::kCapacityExceeded;

  int32_t point_count = 0;
  ForstnerParams forstner = params.forstner;
  forstner.cell_px = spreadingGridPx(params, left.width, left.height);
  const Status detected = detectInterestPoints(left, forstner, workspace.forstner, workspace.points,
                                               kMaxInterestPoints, point_count);
  result.counts.interest_points = point_count;
  if (!ok(detected)) return detected;

  // Match every interest point along its epipolar curve, then check left-right consistency.
  int32_t match_count = 0;
  NccTemplate left_template;
  for (int32_t i = 0; i < point_count; ++i) {
    const int32_t lx = static_cast<int32_t>(std::lround(workspace.points[i].x_px));
    const int32_t ly = static_cast<int32_t>(std::lround(workspace.points[i].y_px));
    if (!extractTemplate(left, lx, ly, left_template) || !left_template.textured) continue;
    const Vec2 left_px(lx, ly);
    SearchHit hit;
    Vec2 far_px;
    const CurveMatchStage stage =
        matchAlongCurve(left_template, left, right, left_model, right_model, left_px, params.min_range_m,
                        params.max_range_m, params, params.lr_tolerance_px, workspace, hit, far_px);
    if (stage == CurveMatchStage::kNoCurve) continue;
    ++result.counts.searched;
    if (stage == CurveMatchStage::kNoMatch) continue;
    ++result.counts.ncc_passed;
    if (stage != CurveMatchStage::kMatched) continue;
    ++result.counts.lr_passed;
    StereoMatch& m = workspace.matches[match_count];
    m.left_px = left_px;
    double rx = 0.0, ry = 0.0;
    refinePeak(left_template, right, hit.x, hit.y, hit.score, rx, ry);
    m.right_px = Vec2(rx, ry);
    m.score = hit.score;
    m.parallax_px = (m.right_px - far_px).norm();
    m.verified = false;
    workspace.rows[match_count] = static_cast<float>(ly);
    workspace.parallax[match_count] = static_cast<float>(m.parallax_px);
    ++match_count;
  }

  workspace.match_count = match_count;
  // Parallax consistency.
  const Status fitted = fitParallaxCurve(workspace.rows, workspace.parallax, match_count, params.parallax,
                                         0.5 * (left.height - 1), 0.5 * left.height, workspace.inlier,
                                         workspace.scratch, result.curve);
  if (!ok(fitted)) return fitted;
  for (int32_t i = 0; i < match_count; ++i) {
    workspace.matches[i].verified = workspace.inlier[i];
    result.counts.parallax_passed += workspace.inlier[i] ? 1 : 0;
  }

  // Gridding: the best verified match per cell.
  const StereoMatch* matches = workspace.matches;
  grid.selectBest(
      match_count,
      [matches](int32_t i, int32_t& x, int32_t& y) {
        x = static_cast<int32_t>(matches[i].left_px.x());
        y = static_cast<int32_t>(matches[i].left_px.y());
        return matches[i].verified;
      },
      [matches](int32_t i) { return matches[i].score; }, workspace.cell_best);
  for (int32_t c = 0; c < grid.cells(); ++c) {
    if (workspace.cell_best[c] >= 0) result.ties[result.tie_count++] = workspace.matches[workspace.cell_best[c]];
  }
  result.counts.selected = result.tie_count;
  return result.tie_count >= params.min_ties ? Status::kOk : Status::kNoTexture;
}

}  // namespace areomap
