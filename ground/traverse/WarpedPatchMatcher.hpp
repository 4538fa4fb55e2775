// NCC of DEM-warped patches between two images that see the same ground at different scales and from
// different directions (cross-site ties). A local affine map A = d(pixel in J)/d(pixel in I),
// from the ground plane under the point, relates the two views. The comparison runs on the grid of the
// coarser view: the finer image is sampled through the map from its Gaussian pyramid level of that scale
// (so that it is low-passed like the coarser one), the other image at full resolution. A (2h+1)^2
// template around the point in I is searched over +-radius grid steps about the predicted point in J:
// integer NCC maximum, second peak (>= 2 steps away) for the ambiguity test, then a least-squares
// (Lucas-Kanade) translation with gain and offset from the integer peak for the sub-pixel position.
#pragma once

#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace areomap::traverse {

struct PatchParams {
  int half = 7;                    // template (2 half + 1)^2 grid steps
  double radius_px = 6.0;          // search radius in J pixels about the prediction
  double min_ncc = 0.75;           // best NCC below it: rejected
  double max_second_ratio = 0.92;  // second peak / best above it: ambiguous
  int lsm_iterations = 8;          // least-squares refinement steps
  bool lsm_affine = true;          // the refinement also corrects the warp's linear part
  bool anisotropic = true;         // the finer image low-passed to the footprint's shape (else its scale)
  bool clip_at_edge = true;        // search only the shifts whose window is inside J (else refuse the point)
  // Through a surface: the casts interpolated from a lattice where that is within this many grid steps of
  // J (PatchWarp.hpp); 0: every sample cast.
  double warp_tolerance_steps = 0.05;
};

enum class PatchResult { kOk, kOutside, kFlat, kLowNcc, kAmbiguous, kEdgePeak, kLsmDiverged };

struct PatchMatch {
  PatchResult result = PatchResult::kOutside;
  Eigen::Vector2d j_px = Eigen::Vector2d::Zero();  // matched point in J (full-resolution pixels)
  double ncc = 0.0;                                // at the integer peak
  double second = 0.0;                             // the second peak
  double ncc_final = 0.0;                          // NCC of the refined position
  // The least-squares translation's covariance (J pixels; the residuals' variance over the redundancy
  // times the inverse normal matrix of its last step).
  Eigen::Matrix2d cov_px = Eigen::Matrix2d::Zero();
};

// The surface between the two views: maps a pixel of image I to image J through the ground (e.g. the ray
// cast onto a DEM and projected), false where it cannot. With one, each template sample has its own place in
// J (the relief within the patch, which a plane misses at grazing views, is followed); without, or where it
// fails, the local affine map is used.
class PatchSurface {
 public:
  virtual ~PatchSurface() = default;
  virtual bool map(const Eigen::Vector2d& i_px, Eigen::Vector2d& j_px) const = 0;
};

// Bilinear sample of pyramid level `level` at full-resolution pixel coordinates (NaN outside).
double samplePyramid(const std::vector<cv::Mat>& pyramid, int level, double x_px, double y_px);

// Matches the patch around `i_px` in image I into image J about `j_predicted_px`; `a` maps I pixel offsets
// to J pixel offsets near the point.
PatchMatch matchWarpedPatch(const std::vector<cv::Mat>& image_i, const Eigen::Vector2d& i_px,
                            const std::vector<cv::Mat>& image_j, const Eigen::Vector2d& j_predicted_px,
                            const Eigen::Matrix2d& a, const PatchParams& params,
                            const PatchSurface* surface = nullptr);

}  // namespace areomap::traverse
