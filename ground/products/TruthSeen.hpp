// What the true cameras see against the products (report.json truth.dem_unseen_empty, dem_seen_filled,
// ortho_agreement; docs/products.md "Seen and unseen cells"), on a synthetic dataset with its true models
// and true DEM. The truth is first brought into the products' frame (DESIGN.md "Datum": the common
// rotation R of the products' models against the true ones, about the gimbal centre, is removed): a
// products' cell is compared with the true ground at the aligned place. Over the DEM's cells within
// max_range_m of the gimbal centre that the true DEM covers:
//   a cell is seen in truth when some true camera sees the true ground at its centre: the point lies
//   inside the camera's image (ground/dem imageSees) and clears the horizon of the true terrain from the
//   camera (ground/dem Viewshed over the true DEM, bilinear between its nodes; 1 mm for the float
//   elevations); unseen when every node of the true surface within the cell's square (the simulator's
//   grid, on which the surface is bilinear, so its nodes are its resolution; the nearest when none is)
//   lies below that horizon by more than one pixel's angle at its distance; marginal otherwise, counted in
//   neither fraction: a cell partly seen (a rock's edge, a shadow's end) is neither, and an image does not resolve
//   a shadow thinner than a pixel (it shows the ground on both sides of it as one surface);
//   dem_unseen_empty: of the cells not seen in truth, the fraction dem.tif leaves empty;
//   dem_seen_filled: of the cells seen in truth, the fraction it fills;
//   ortho_agreement: of the cells seen in truth that both orthos fill, the fraction where ortho.tif's value
//   lies within the values of the truth ortho (the same images through the true models onto the true DEM,
//   both in the products' frame, ground/ortho with its occlusion rule) at that cell and its eight
//   neighbours, +-2 grey values: a DEM error of up to a cell moves the sample by that much; painting a cell
//   from an image that does not see it (the shadow behind a rock) puts another surface's grey there.
#pragma once

#include <optional>
#include <vector>

#include <opencv2/core.hpp>

#include "firmware_core/base/EigenTypes.hpp"
#include "firmware_core/camera/CameraModel.hpp"
#include "ground/dataset/DemRaster.hpp"

namespace areomap::products {

// The products' frame against the truth's: a products' point p is g + R (p - g) in the truth's frame.
struct TruthFrame {
  Mat3 r = Mat3::Identity();
  Vec3 gimbal = Vec3::Zero();
  Vec3 toTruth(const Vec3& p) const { return gimbal + r * (p - gimbal); }
  Vec3 toProducts(const Vec3& q) const { return gimbal + r.transpose() * (q - gimbal); }
};

// The common rotation of `products_models` against `truth_models` (one order; firmware_core/adjust
// Datum.hpp) about `gimbal_site_m`; the identity without models.
TruthFrame truthFrame(const std::vector<CameraModel>& products_models, const std::vector<CameraModel>& truth_models,
                      const Vec3& gimbal_site_m);

inline constexpr uint8_t kTruthUnseen = 0, kTruthMarginal = 1, kTruthSeen = 2;

struct SeenTruth {
  long long cells_unseen = 0, cells_seen = 0, cells_compared = 0, cells_marginal = 0;
  long long unseen_measured = 0;  // cells not seen in truth that points fall in (given the DEM's classes)
  std::optional<double> unseen_empty, seen_filled, ortho_agreement;  // absent: no such cell
  std::vector<uint8_t> seen;  // per cell of the DEM: kTruthUnseen, kTruthMarginal or kTruthSeen (above)
};

// `images` and `truth_models` in one order (an empty image is skipped; the models sized to their
// images); `ortho` on the DEM's grid (0 = no data), may be null; `classes` (dem_seen.tif's, may be null).
SeenTruth seenAgainstTruth(const DemGrid& dem, const cv::Mat* ortho, const DemGrid& truth_dem,
                           const std::vector<cv::Mat>& images, const std::vector<CameraModel>& truth_models,
                           const TruthFrame& frame, double max_range_m,
                           const std::vector<uint8_t>* classes = nullptr);

// Per cell of `grid` (the products' frame): kTruthUnseen, kTruthMarginal or kTruthSeen (above), `truth`
// the true DEM at its own grid.
std::vector<uint8_t> truthCellsSeen(const DemGrid& grid, const DemGrid& truth, const std::vector<cv::Mat>& images,
                                    const std::vector<CameraModel>& models, const TruthFrame& frame);

}  // namespace areomap::products
