// The tie-point network of a panorama, built incrementally as stereo pairs arrive (paper §3.4):
//   1. intra-stereo ties of the new pair (StereoMatcher),
//   2. its coarse DEM from those ties triangulated with the a-priori models (CoarseDem),
//   3. inter-stereo ties: every stored tie of every earlier pair, predicted through that pair's coarse DEM
//      and projected with the a-priori models into the new pair's images, is searched by NCC in a small
//      window there (after a probe of a few strong ties in a wide window has measured the common offset that
//      the a-priori pointing errors cause); the offsets found must agree per image (verification) -- the
//      same tie point keeps its identity, it gains observations. Only the new pair's image nearest the
//      stored patch's camera is matched so; its other image takes each point from that one through the
//      pair's own stereo geometry (transferInPair: epipolar search, left-right check), because a patch
//      matched a stereo base away is pulled off its point, one way, wherever it straddles a rock's outline,
//   4. the new pair's ties are stored for later pairs: the 11 x 11 left-image patch around each tie and its
//      DEM-predicted ground point (the full images are not kept: 256 pairs x 1 MiB would not fit). The
//      selected ties (the tie budget of the pair) rarely fill the kMaxStoredTiesPerPair slots; the rest hold
//      further verified intra-stereo matches nearest the image borders (a finer grid), where the
//      neighbours of a panorama overlap (pan: left/right strips; tiers: top/bottom strips), the corners
//      first and densest (a diagonal neighbour overlaps only a corner). Such a
//      candidate becomes a tie point, with its two intra-stereo observations, only when a later pair
//      matches it, so narrow overlaps get enough inter-stereo ties without spending the point budget.
// Output: the neutral tie list of TieList.hpp (observations: point, image, sample, line, kind, score; points:
// a-priori ground position) that firmware_core/adjust's NetworkBuilder puts into the adjustment Network.
// Image index = 2 * pair + side.
// The coarse DEM is the caller's (the rover publishes it): addPair makes it afresh from the new pair's ties
// and predicts that pair's stored ties through it, so the one thing the matcher needs of firmware_core/dem
// is named in its signature. Zero heap: one PanoramaMatcher (~19 MiB) is allocated statically at start-up.
#pragma once

#include <cstdint>

#include "firmware_core/base/Capacities.hpp"
#include "firmware_core/base/EigenTypes.hpp"
#include "firmware_core/base/FixedVector.hpp"
#include "firmware_core/base/ImageView.hpp"
#include "firmware_core/base/Status.hpp"
#include "firmware_core/camera/CameraModel.hpp"
#include "firmware_core/dem/CoarseDem.hpp"
#include "firmware_core/match/InterStereoTies.hpp"
#include "firmware_core/match/StereoMatcher.hpp"
#include "firmware_core/match/TieList.hpp"
#include "firmware_core/match/WarpedSearch.hpp"

namespace areomap {

// Stored ties per pair for later pairs (step 4): the selected ties (<= kMaxTiesPerPair) and further
// inter-stereo candidates.
constexpr int32_t kMaxStoredTiesPerPair = 352;

struct PairTieReport {
  Status intra_status = Status::kOk;
  StereoCounts intra;
  int32_t dem_points = 0;
  int32_t dem_cells = 0;
  int32_t neighbours = 0;        // earlier pairs with at least one inter-stereo tie to this pair
  int32_t inter_candidates = 0;  // predicted inside this pair's images or within the probe radius of them
  int32_t inter_matched = 0;     // passed NCC
  int32_t inter_rejected = 0;    // failed the offset verification
  int32_t inter_observations = 0;
  int32_t inter_candidates_stored = 0;  // unselected verified matches kept for later pairs (step 4)
  int32_t overflow = 0;          // ties lost to a full list
  int32_t births_deferred = 0;   // inter-stereo matches of stored candidates not made points (pair's share used)
};

class PanoramaMatcher {
 public:
  void reset();
  // Shares kMaxTiePoints among the pairs of a panorama of `pairs` pairs: 70 % for the selected intra-stereo
  // ties (sets stereo.tie_budget), the rest for the points that inter-stereo matches create (stored
  // candidates, single images). Pair j may create points up to its cumulative share
  // kMaxTiePoints * (j + 1) / pairs (its own selected ties kept free), so early pairs cannot starve the
  // later ones, and what a pair leaves unused passes on.
  void planForPairs(int32_t pairs);

  // Adds the next pair (its index is pairCount() before the call). `right` and `right_model` may be null for
  // a single left image. `dem` receives the pair's coarse DEM (steps 2 and 4; empty for a single image).
  // Returns kOk when the pair got any tie, kNoTexture when it got none, kInvalidArgument or
  // kCapacityExceeded for bad input (the pair is then not added).
  [[nodiscard]] Status addPair(const ImageView& left, const ImageView* right, const CameraModel& left_model,
                               const CameraModel* right_model, CoarseDem& dem, PairTieReport& report);

  int32_t pairCount() const { return pair_count_; }
  const FixedVector<TieObservation, kMaxObservations>& observations() const { return observations_; }
  const FixedVector<TiePoint, kMaxTiePoints>& points() const { return points_; }
  // The tie list so far (a view of the two lists above).
  TieList ties() const;

  StereoParams stereo;
  InterParams inter;

 private:
  static constexpr double kWarpBasePx = 4.0;  // pixel offset used to measure the local affine map of a patch
  // The left-image patch is centred exactly on the tie's left observation, so a match of it anywhere is an
  // observation of the same surface point.
  // Compact (180 bytes): ground points in float (site frame, metres: ~10 um at 100 m, far below a pixel),
  // the integer left pixel in int16, so that kMaxStoredTiesPerPair slots fit where 256 did in double.
  struct StoredTie {
    uint8_t patch[kNccPixels];
    bool has_shape;
    bool has_intra;  // false for a single image's interest point
    Eigen::Vector3f predicted_m;
    // Ground points (through the DEM) of the pixels kWarpBasePx to the right of and below the tie: with
    // predicted_m they give the local affine map of the patch into any other view.
    Eigen::Vector3f predicted_dx_m;
    Eigen::Vector3f predicted_dy_m;
    int16_t source_px[2];  // its observation (integer) in the left image of the pair that stored it
    // -1 for an interest point of a single image (no stereo partner) or an inter-stereo candidate: the
    // point is created by its first inter-stereo match.
    int32_t point;
    // An inter-stereo candidate's intra-stereo right observation (added with the left one when the point
    // is created).
    float right_px[2];
    float intra_score;
  };
  struct StoredPair {
    CameraModel model[2];
    bool has_right = false;
    StoredTie ties[kMaxStoredTiesPerPair];
    int32_t tie_count = 0;
  };
  struct Prediction {
    int32_t tie;
    Vec2 px;
    Mat2 shape;  // local affine map of the stored patch into the target view
    bool inside;  // predicted inside the image (not only within the probe radius of it)
  };

  // Step 3 (InterStereoTies.cpp): the inter-stereo ties of the new pair with every earlier one.
  void interTies(int32_t new_pair, const ImageView* images[2], PairTieReport& report);
  void storeSingleImagePoints(const ImageView& left, const CameraModel& model, StoredPair& stored);
  // Patch, predicted ground point and shape of an intra-stereo match (point -1); false when the patch
  // leaves the image.
  bool fillStoredTie(const ImageView& left, const CameraModel& left_model, const CoarseDem& dem,
                     const StereoMatch& m, const Vec3& ground, StoredTie& st) const;
  // Step 4's inter-stereo candidates (the verified, unselected matches of stereo_workspace_).
  void storeInterCandidates(const ImageView& left, const CameraModel& left_model,
                            const CameraModel& right_model, const CoarseDem& dem, StoredPair& stored,
                            PairTieReport& report);
  bool addObservation(int32_t point, int32_t image, double sample_px, double line_px, TieKind kind, float score);

  StereoWorkspace stereo_workspace_;
  StereoResult stereo_result_;
  WarpedSearchScratch warp_scratch_;
  StoredPair pairs_[kMaxPairs];
  int32_t pair_count_ = 0;
  int32_t planned_pairs_ = kMaxPairs;
  int32_t birth_limit_ = 0;  // points_.size() below which the pair being added may create inter-stereo points
  FixedVector<TieObservation, kMaxObservations> observations_;
  FixedVector<TiePoint, kMaxTiePoints> points_;
  Prediction predictions_[kMaxStoredTiesPerPair];
  OffsetCandidate candidates_[kMaxStoredTiesPerPair];
  bool inlier_[kMaxStoredTiesPerPair];
  // Per stored tie of the source pair in interTies: its observation in the near image, when it has one.
  Vec2 near_px_[kMaxStoredTiesPerPair];
  bool near_ok_[kMaxStoredTiesPerPair];
  // Inter-stereo candidate grids: corner cells (at most kCandidateGridSide^2) then band cells (as many; 32 x 32
  // cells of 32 px on a 1024^2 frame), the best verified unselected match per cell, sorted towards the
  // corner / border.
  static constexpr int32_t kCandidateGridSide = 32;
  int32_t candidate_best_[2 * kCandidateGridSide * kCandidateGridSide];
  int32_t candidate_border_[2 * kCandidateGridSide * kCandidateGridSide];
};

// The matcher's share of the rover's static memory (DESIGN.md: 64 MiB in all): ~19 MiB, leaving the rest to
// the image buffers, the adjustment network and the node.
static_assert(sizeof(PanoramaMatcher) <= 24u * 1024u * 1024u, "PanoramaMatcher exceeds its 24 MiB share");

}  // namespace areomap
