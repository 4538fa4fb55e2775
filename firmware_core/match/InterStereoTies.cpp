// Step 3 of PanoramaMatcher (PanoramaMatcher.hpp): the inter-stereo ties from every earlier pair into a
// new one -- prediction through the stored ground points, the offset probe, the search, the robust offset
// field that verifies the matches, and the transfer into the far image of the new pair.
#include <cmath>

#include "firmware_core/match/EpipolarSearch.hpp"
#include "firmware_core/match/Ncc.hpp"
#include "firmware_core/match/InterStereoTies.hpp"
#include "firmware_core/match/WarpedSearch.hpp"
#include "firmware_core/match/PanoramaMatcher.hpp"

namespace areomap {
namespace {
constexpr double kOffsetScalePx = 512.0;      // normalises image positions in the offset field
constexpr int32_t kMinAffineOffsets = 6;      // fewer inliers: a constant offset field
constexpr double kTransferRangeFactor = 1.5;  // range interval searched by transferInPair

Vec3 offsetBasis(const Vec2& px) {
  return Vec3(1.0, px.x() / kOffsetScalePx, px.y() / kOffsetScalePx);
}
}  // namespace

void fitOffsetField(const OffsetCandidate* candidates, int32_t n, double initial_tolerance_px,
                    double tolerance_px, bool* inlier, Vec3& fx, Vec3& fy) {
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
      if (std::fabs(candidates[a].dx - candidates[b].dx) > tolerance_px ||
          std::fabs(candidates[a].dy - candidates[b].dy) > tolerance_px) {
        continue;
      }
      ++support;
      score += candidates[b].score;
    }
    if (support > seed_support || (support == seed_support && score > seed_score)) {
      seed = a;
      seed_support = support;
      seed_score = score;
    }
  }
  fx = Vec3(candidates[seed].dx, 0.0, 0.0);
  fy = Vec3(candidates[seed].dy, 0.0, 0.0);
  double tolerance = initial_tolerance_px;
  for (int32_t iteration = 0; iteration <= kMaxParallaxFitIterations; ++iteration) {
    int32_t inliers = 0;
    bool changed = false;
    for (int32_t c = 0; c < n; ++c) {
      const Vec3 b = offsetBasis(candidates[c].px);
      const bool in = std::fabs(candidates[c].dx - fx.dot(b)) <= tolerance &&
                      std::fabs(candidates[c].dy - fy.dot(b)) <= tolerance;
      changed = changed || in != inlier[c] || iteration == 0;
      inlier[c] = in;
      inliers += in ? 1 : 0;
    }
    if ((!changed && tolerance == tolerance_px) || iteration == kMaxParallaxFitIterations) break;
    tolerance = tolerance_px;
    if (inliers < kMinAffineOffsets) continue;  // keep the constant (seed) field
    Mat3 normal = Mat3::Zero();
    Vec3 rx = Vec3::Zero(), ry = Vec3::Zero();
    for (int32_t c = 0; c < n; ++c) {
      if (!inlier[c]) continue;
      const Vec3 b = offsetBasis(candidates[c].px);
      normal.noalias() += b * b.transpose();
      rx.noalias() += b * candidates[c].dx;
      ry.noalias() += b * candidates[c].dy;
    }
    const Eigen::LDLT<Mat3> ldlt(normal);
    if (ldlt.info() != Eigen::Success || ldlt.rcond() < 1e-9) continue;
    fx = ldlt.solve(rx);
    fy = ldlt.solve(ry);
  }
}

// Long because: per earlier pair and image of the new pair, its five steps (predict,
// probe, search or transfer, verify, add) share the prediction, candidate and inlier arrays and the
// offset field in order; the steps are marked where they start.
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
                            predicted.x() <= image->width - 1 - margin &&
                            predicted.y() <= image->height - 1 - margin;
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
        const SearchHit hit =
            searchWindowWarped(t, *image, static_cast<int32_t>(std::lround(pr.px.x())),
                               static_cast<int32_t>(std::lround(pr.px.y())), inter.probe_radius_px, pr.shape, warp_scratch_);
        // No ambiguity test here: the probes only feed the robust offset field, which drops strays.
        if (hit.score < inter.min_ncc) continue;
        candidates_[found++] =
            OffsetCandidate{pr.tie, pr.px, hit.score, hit.x - pr.px.x(), hit.y - pr.px.y()};
      }
      if (found < inter.min_group) continue;
      Vec3 field_x, field_y;
      fitOffsetField(candidates_, found, 2.0 * inter.search_radius_px, inter.search_radius_px, inlier_,
                     field_x, field_y);

      // Search every prediction around its corrected position.
      int32_t n = 0;
      for (int32_t c = 0; c < np; ++c) {
        const Prediction& pr = predictions_[c];
        if (transfer && near_ok_[pr.tie]) {
          const Vec3 p = source.ties[pr.tie].predicted_m.cast<double>();
          Vec2 far_px;
          double score = 0.0;
          if (!transferInPair(*images[near_side], *image, target.model[near_side], model, near_px_[pr.tie],
                              (p - target.model[near_side].c).norm(), stereo, stereo_workspace_, far_px,
                              score)) {
            continue;
          }
          ++report.inter_matched;
          candidates_[n++] =
              OffsetCandidate{pr.tie, pr.px, score, far_px.x() - pr.px.x(), far_px.y() - pr.px.y()};
          continue;
        }
        NccTemplate t;
        templateFromPixels(source.ties[pr.tie].patch, t);
        if (!t.textured) continue;
        const Vec3 basis = offsetBasis(pr.px);
        const int32_t px = static_cast<int32_t>(std::lround(pr.px.x() + field_x.dot(basis)));
        const int32_t py = static_cast<int32_t>(std::lround(pr.px.y() + field_y.dot(basis)));
        if (px < margin || py < margin || px > image->width - 1 - margin || py > image->height - 1 - margin)
          continue;
        const SearchHit hit = searchWindowWarped(t, *image, px, py, inter.search_radius_px, pr.shape, warp_scratch_);
        if (hit.score < inter.min_ncc || hit.second > stereo.max_second_ratio * hit.score) continue;
        double x = 0.0, y = 0.0;
        refinePeakWarped(t, *image, hit.x, hit.y, hit.score, pr.shape, x, y);
        ++report.inter_matched;
        // The match is kept as its offset from the prediction; the position is rebuilt when accepted.
        candidates_[n++] = OffsetCandidate{pr.tie, pr.px, hit.score, x - pr.px.x(), y - pr.px.y()};
      }
      if (n == 0) continue;
      if (n < inter.min_group) {
        report.inter_rejected += n;
        continue;
      }
      // Verification: the offsets from the prediction (a-priori pointing errors) follow one smooth (affine)
      // field over the image.
      fitOffsetField(candidates_, n, inter.search_radius_px + inter.offset_tolerance_px,
                     inter.offset_tolerance_px, inlier_, field_x, field_y);
      for (int32_t c = 0; c < n; ++c) {
        const OffsetCandidate& cand = candidates_[c];
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
          const bool born = st.has_intra ? addObservation(st.point, 2 * i, st.source_px[0], st.source_px[1],
                                                          TieKind::kIntra, 1.0f) &&
                                               addObservation(st.point, 2 * i + 1, st.right_px[0],
                                                              st.right_px[1], TieKind::kIntra, st.intra_score)
                                         : addObservation(st.point, 2 * i, st.source_px[0], st.source_px[1],
                                                          TieKind::kInter, 1.0f);
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

bool transferInPair(const ImageView& near_image, const ImageView& far_image, const CameraModel& near_model,
                    const CameraModel& far_model, const Vec2& near_px, double range_m,
                    const StereoParams& stereo, StereoWorkspace& workspace, Vec2& far_px, double& score) {
  NccTemplate near_t;
  if (!extractTemplateAt(near_image, near_px.x(), near_px.y(), near_t) || !near_t.textured) return false;
  const double lo = std::fmax(stereo.min_range_m, range_m / kTransferRangeFactor);
  const double hi = std::fmin(stereo.max_range_m, range_m * kTransferRangeFactor);
  if (!(lo < hi)) return false;
  // near_px is sub-pixel, the back match an integer pixel: half a pixel more than the intra-stereo check.
  SearchHit hit;
  Vec2 curve_far_px;
  if (matchAlongCurve(near_t, near_image, far_image, near_model, far_model, near_px, lo, hi, stereo,
                      stereo.lr_tolerance_px + 0.5, workspace, hit,
                      curve_far_px) != CurveMatchStage::kMatched) {
    return false;
  }
  double x = 0.0, y = 0.0;
  refinePeak(near_t, far_image, hit.x, hit.y, hit.score, x, y);
  far_px = Vec2(x, y);
  score = hit.score;
  return true;
}

}  // namespace areomap
