// Cross-site tie points on board (the rover's port of the ground's matcher, ground/traverse/CrossTieMatching
// and WarpedPatchMatcher, with fewer points and no image pyramid): between site A, mapped before, and site
// B, just mapped, once B's DEM has been registered onto A's (CoarseDemRegistration.hpp).
//
// What a site keeps (CrossSiteRecord, filled while and after its panorama is mapped): its coarse DEM (from
// its adjusted tie points), the left image of each pair binned to at most kStoredImageSide a side with its
// adjusted model in that binned frame, and candidates: adjusted tie points spread over those images
// (kCandidateGrid^2 cells per image), each with its observations in ideal pixels.
//
// Matching: every candidate of A is moved into B by the registered pose and projected into each stored image
// of B that sees it (in range, in the image, not grazing the ground plane under it, a footprint of like scale
// in both views). The template is B's (2 kCrossTemplateHalf + 1)^2 pixel grid about the prediction, each
// pixel's ray cut with the ground plane under the point (normal from B's DEM), moved into A and A's stored
// image averaged over that pixel's footprint there (bilinear samples on a grid as fine as the footprint is
// long, at most kCrossMaxSubsamples a side): A's patch warped into B's view. It is correlated (nccOfSamples)
// with B's stored image at every integer shift within +-kCrossSearchRadiusPx; the best NCC must reach
// min_ncc, a second peak (two pixels or more away) must stay below max_second_ratio of it, the peak must not
// lie on the search's edge; the sub-pixel position is a parabola in x and in y. A tie is the candidate and
// B's pixel in the matcher's frame of that image (the one the site's network works in): the unrounded
// prediction moved by the peak's shift.
//
// Memory: fixed (a record ~1.6 MiB); no heap; every loop bounded.
#pragma once

#include <cstdint>

#include "firmware_core/base/Capacities.hpp"
#include "firmware_core/base/EigenTypes.hpp"
#include "firmware_core/base/ImageView.hpp"
#include "firmware_core/base/Status.hpp"
#include "firmware_core/camera/CameraConversion.hpp"
#include "firmware_core/camera/CameraModel.hpp"
#include "firmware_core/dem/CoarseDem.hpp"
#include "firmware_core/dem/CoarseDemRegistration.hpp"

namespace areomap {

// Images a site keeps: the left image of each pair, a two-tier Navcam ring of 10-20 pairs; later pairs are
// counted and not kept.
constexpr int32_t kMaxStoredImages = 24;
// A kept image's largest side (binned by the smallest integer factor that fits: Navcam's 1024 by 4, the
// tiny camera's 256 x 192 not at all): the far field of the other site, where ties come from, is seen at
// a few centimetres a pixel at 10-30 m, which 4x binning of Navcam still resolves.
constexpr int32_t kStoredImageSide = 256;
constexpr int32_t kStoredImagePixels = kStoredImageSide * kStoredImageSide;
// Candidates per image: one per cell of an 8 x 8 grid; per site at most 1024. A candidate ties a leg only
// where both sites see it at a like scale, which the next leg's length decides, unknown when the site is
// kept: a site keeps candidates over all the ranges its images show, and most of them (its near field from
// a leg's length away) fail the scale gate.
constexpr int32_t kCandidateGrid = 8;
constexpr int32_t kMaxSiteCandidates = 1024;
constexpr int32_t kMaxCandidateObservations = 4;  // the stereo pair's two rays, and two of a neighbour pair
// The template: 11 x 11 pixels on B's grid; the search: +-8 pixels of the kept images (the registration of
// the rover's coarse DEMs leaves about 0.1 m and a few tenths of a degree: 3-5 pixels of the tiny camera at
// 8 m, 1-2 of Navcam binned by 4).
constexpr int32_t kCrossTemplateHalf = 5;
constexpr int32_t kCrossTemplateSide = 2 * kCrossTemplateHalf + 1;
constexpr int32_t kCrossTemplatePixels = kCrossTemplateSide * kCrossTemplateSide;
constexpr int32_t kCrossSearchRadiusPx = 8;
// A template pixel averages at most 4 x 4 samples of A (the scale gate keeps the stretch within 2.5 but for
// a footprint much longer than wide).
constexpr int32_t kCrossMaxSubsamples = 4;
// Ties of one pair of sites: each candidate in at most two of B's images.
constexpr int32_t kMaxCrossSiteTiesPerLeg = 2 * kMaxSiteCandidates;

struct KeptImage {
  int32_t image = -1;  // the caller's index of the image (its network image)
  int32_t bin = 1;     // kept pixel = mean of bin x bin matcher pixels
  int32_t width = 0, height = 0;
  CameraModel model;                   // adjusted, site frame, in the kept (binned) pixel frame
  CameraModel apriori_model;           // the matcher's frame: to map a matched pixel to ideal pixels
  PhotogrammetricCamera apriori_camera;
  uint8_t pixels[kStoredImagePixels];
};

struct CrossSiteCandidate {
  Vec3 xyz_m = Vec3::Zero();  // adjusted, site frame
  int32_t stored = -1;        // the kept image its template comes from
  int32_t observation_count = 0;
  int32_t image[kMaxCandidateObservations] = {};  // the caller's image indices
  Vec2 ideal_px[kMaxCandidateObservations];
};

class CrossSiteRecord {
 public:
  void reset();
  // Keeps an image (binned to fit), unless kMaxStoredImages are kept (counted: imagesNotKept()).
  bool keepImage(const ImageView& image, int32_t index, const CameraModel& apriori_model,
                 const PhotogrammetricCamera& apriori_camera);
  // The kept image of the caller's image `index`, or -1.
  int32_t storedOf(int32_t index) const;
  // After the site's adjustment: a kept image's adjusted model (in the matcher's frame: binned here).
  void setAdjustedModel(int32_t stored, const CameraModel& matcher_frame_model);
  // A candidate seen in kept image `stored` at kept pixel `px`: taken when its grid cell is still empty.
  bool offerCandidate(int32_t stored, const Vec2& stored_px, const CrossSiteCandidate& candidate);

  CoarseDem& dem() { return dem_; }
  const CoarseDem& dem() const { return dem_; }
  int32_t imageCount() const { return image_count_; }
  const KeptImage& image(int32_t k) const { return images_[k]; }
  int32_t candidateCount() const { return candidate_count_; }
  const CrossSiteCandidate& candidate(int32_t k) const { return candidates_[k]; }
  int32_t imagesNotKept() const { return images_not_kept_; }

 private:
  CoarseDem dem_;
  KeptImage images_[kMaxStoredImages];
  CrossSiteCandidate candidates_[kMaxSiteCandidates];
  bool cell_taken_[kMaxStoredImages][kCandidateGrid * kCandidateGrid] = {};
  int32_t image_count_ = 0;
  int32_t candidate_count_ = 0;
  int32_t images_not_kept_ = 0;
};

struct RoverCrossTie {
  int32_t candidate = -1;  // of A
  int32_t stored = -1;     // B's kept image
  Vec2 matcher_px = Vec2::Zero();  // in the matcher's frame of that image
  double ncc = 0.0;
};

struct CrossMatchParams {
  double max_range_m = 30.0;        // from each camera
  double min_incidence_deg = 4.0;   // of each view's ray on the ground plane
  double max_scale_ratio = 2.5;     // between the two views' footprints
  double min_ncc = 0.8;
  double max_second_ratio = 0.92;
};

struct CrossMatchCounts {
  int32_t predicted = 0;  // (candidate, image) pairs searched
  int32_t outside = 0, beyond_range = 0, grazing = 0, scale_gate = 0, warp_failed = 0;
  int32_t low_ncc = 0, ambiguous = 0, edge_peak = 0;
  int32_t matched = 0;
};

class CrossSiteMatcher {
 public:
  // Ties of A's candidates in B's kept images under `a_from_b`; at most `capacity` into `ties`.
  void match(const CrossSiteRecord& a, const CrossSiteRecord& b, const LevelledPose& a_from_b,
             const CrossMatchParams& params, RoverCrossTie* ties, int32_t capacity, int32_t& count,
             CrossMatchCounts& counts);

 private:
  // One (candidate, B image): the template warped from A, then the search. True and `tie` on a match.
  bool matchOne(const CrossSiteRecord& a, const CrossSiteCandidate& c, const KeptImage& bi, const Vec3& x_b,
                const Vec3& normal_b, const LevelledPose& a_from_b, const CrossMatchParams& params,
                CrossMatchCounts& counts, RoverCrossTie& tie);

  double template_[kCrossTemplatePixels] = {};
  double window_[kCrossTemplatePixels] = {};
  double score_[2 * kCrossSearchRadiusPx + 1][2 * kCrossSearchRadiusPx + 1] = {};
};

}  // namespace areomap
