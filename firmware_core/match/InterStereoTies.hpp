// Step 3 of PanoramaMatcher (paper §3.4, PanoramaMatcher.hpp): the inter-stereo ties of a new pair with
// every earlier one. Here its parameters and the two pieces it is made of that need none of the matcher's
// stored pairs: the robust offset field that verifies the matches found in one image, and the transfer of
// a point from the near image of the new pair into its far one. PanoramaMatcher::interTies
// (InterStereoTies.cpp) runs the steps -- predict, probe, search or transfer, verify, add -- over the
// stored pairs. No heap; every loop bounded.
#pragma once

#include <cstdint>

#include "firmware_core/base/Capacities.hpp"
#include "firmware_core/base/EigenTypes.hpp"
#include "firmware_core/base/ImageView.hpp"
#include "firmware_core/camera/CameraModel.hpp"
#include "firmware_core/match/StereoMatcher.hpp"

namespace areomap {

struct InterParams {
  // A single image has no DEM: its interest points are predicted on the plane Z = ground_z_m (site frame,
  // Z down) at a range clamped to [min, max], which is close enough for frames turned about one mast.
  double ground_z_m = 0.0;
  double single_min_range_m = 2.0;
  double single_max_range_m = 50.0;
  int32_t probe_radius_px = kInterOffsetSearchRadiusPx;  // offset probe (a-priori pointing differences)
  int32_t search_radius_px =
      4;  // around the prediction corrected by the probed offset, <= kInterSearchRadiusPx
  double min_ncc = 0.8;
  double offset_tolerance_px =
      1.5;                // departure from the offset field (affine in the image) of the image pair
  int32_t min_group = 3;  // fewer candidates in an image than this: not verifiable, rejected
};

// A match of a stored tie in one image: the tie, its predicted pixel and the offset found from there.
struct OffsetCandidate {
  int32_t tie;
  Vec2 px;  // prediction
  double score;
  double dx;
  double dy;
};

// Robust affine field of the offsets (found - predicted) over the image, seeded by the offset most
// candidates agree with (within tolerance_px; ties: the higher summed score), its inliers first taken within
// initial_tolerance_px, then within tolerance_px: fx, fy (offset = f . (1, x / 512, y / 512)) and inlier[c]
// per candidate.
void fitOffsetField(const OffsetCandidate* candidates, int32_t n, double initial_tolerance_px,
                    double tolerance_px, bool* inlier, Vec3& fx, Vec3& fy);

// The far image's observation of a point observed at near_px in the near image of the same pair: the
// near image's patch there searched along the pair's epipolar curve (ranges within a factor of
// kTransferRangeFactor of range_m, InterStereoTies.cpp, and within the stereo ranges), left-right checked.
// False when it fails.
bool transferInPair(const ImageView& near_image, const ImageView& far_image, const CameraModel& near_model,
                    const CameraModel& far_model, const Vec2& near_px, double range_m,
                    const StereoParams& stereo, StereoWorkspace& workspace, Vec2& far_px, double& score);

}  // namespace areomap
