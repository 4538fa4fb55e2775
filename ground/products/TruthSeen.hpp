// What the true cameras see against the products (report.json truth.dem_unseen_empty, dem_seen_filled,
// ortho_agreement; docs/products.md "Seen and unseen cells"), on a synthetic dataset with its true models
// and true DEM. Over the DEM's cells within max_range_m of the gimbal centre that the true DEM covers:
//   a cell is seen in truth when some true camera holds its true ground point in its image (ground/dem
//   imageSees) and the true terrain between them does not hide it: the true DEM sampled at the DEM's cell
//   centres, its horizon from the camera (ground/dem Viewshed), 1 mm of tolerance;
//   dem_unseen_empty: of the cells not seen in truth, the fraction dem.tif leaves empty;
//   dem_seen_filled: of the cells seen in truth, the fraction it fills;
//   ortho_agreement: of the cells seen in truth that both orthos fill, the fraction where ortho.tif's value
//   lies within the values of the truth ortho (the same images through the true models onto the true DEM,
//   ground/ortho with its occlusion rule) at that cell and its eight neighbours, +-2 grey values: a DEM
//   error of up to a cell moves the sample by that much; painting a cell from an image that does not see
//   it (the shadow behind a rock) puts another surface's grey there.
#pragma once

#include <optional>
#include <vector>

#include <opencv2/core.hpp>

#include "firmware_core/base/EigenTypes.hpp"
#include "firmware_core/camera/CameraModel.hpp"
#include "ground/dataset/DemRaster.hpp"

namespace areomap::products {

struct SeenTruth {
  long long cells_unseen = 0, cells_seen = 0, cells_compared = 0;
  long long unseen_measured = 0;  // cells not seen in truth that points fall in (given the DEM's classes)
  std::optional<double> unseen_empty, seen_filled, ortho_agreement;  // absent: no such cell
};

// `images` and `truth_models` in one order (an empty image is skipped; the models sized to their
// images); `ortho` on the DEM's grid (0 = no data), may be null; `classes` (dem_seen.tif's, may be null).
SeenTruth seenAgainstTruth(const DemGrid& dem, const cv::Mat* ortho, const DemGrid& truth_dem,
                           const std::vector<cv::Mat>& images, const std::vector<CameraModel>& truth_models,
                           const Vec3& gimbal_site_m, double max_range_m,
                           const std::vector<uint8_t>* classes = nullptr);

// Per cell of `grid`'s geometry: whether some camera of `models` (with `images`, an empty one skipped)
// holds the point at `surface`'s elevation (nodata: not seen) in its image and `surface` does not hide it
// (to `tolerance_m`). Used above on the true DEM sampled at the cells.
std::vector<uint8_t> cellsSeen(const DemGrid& surface, const std::vector<cv::Mat>& images,
                               const std::vector<CameraModel>& models, double tolerance_m);

}  // namespace areomap::products
