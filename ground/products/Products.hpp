// The ground products of one panorama (DESIGN.md "Products", paper §4), made in one call at the end of a
// panorama by areomap-ground (from the LCM stream or `--dataset DIR`):
//
//   for every stereo pair: rectification with the adjusted models (ground/dense Rectification), dense
//   coarse-to-fine matching (parallax ranges from the pair's tie points), space intersection through the
//   adjusted CAHVOR models -> one cloud `points.ply` (site frame, per-point sigma);
//   DEM: ordinary kriging (fitted variogram, k-d tree) + equi-parallax beyond 20 m blended at the seam ->
//   `dem.tif`, `dem_sigma.tif` (float32 GeoTIFF, nodata, local site CRS, metadata: site and sols) and
//   `dem_seen.tif` (8-bit: 0 unseen, 1 interpolated, 2 measured; unseen cells are empty in dem.tif and
//   ortho.tif: ground/dem/DemSeen.hpp); when
//   dem.tif is coarser than 2 cm (a large cloud), also `dem_near.tif`, `dem_near_sigma.tif`: 2 cm within
//   10 m of the rover (DESIGN.md fixes dem.tif as one grid, so the finer grid is an extra product);
//   orthoimage on the DEM grid (ground/ortho) -> `ortho.tif` (8-bit GeoTIFF, same georeferencing);
//   previews `dem.png` (colour relief + hillshade + scale bar), `ortho.png`, `overlays/<stem>.png`
//   (tie points on each image, unless already written by the caller); `report.html` (self-contained).
//
// NOT written here (the caller writes them with ground/adjust and ground/ties, before or after):
// `models/*.cahvor`, `eo.csv`, `tiepoints.csv`, `report.json`. makeProducts returns its own part of the
// report (ProductsResult: stage timings "rectify", "dense", "triangulate", "dem", "ortho", "previews",
// warnings, dem_rmse_m); the caller merges it into the adjustment's report (mergeIntoReport) before it
// writes report.json. The pipeline: ground/dense (pair -> point cloud), ground/dem (SiteDem: binning,
// kriging, equi-parallax, the near grid), ground/ortho, then the previews and report.html.
//
// Bad input never stops the other products: a missing image, a model inconsistent with its image size, a
// pair without texture or without valid matches is skipped with a warning (report.warnings, stderr); with
// no points at all there is no DEM and no ortho, and the previews / report.html are still made.
#pragma once

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "firmware_core/adjust/Network.hpp"
#include "firmware_core/base/EigenTypes.hpp"
#include "firmware_core/camera/CameraModel.hpp"
#include "ground/adjust/AdjustProducts.hpp"
#include "ground/dataset/DemRaster.hpp"
#include "ground/dense/PairCloud.hpp"
#include "ground/products/DemCoverage.hpp"
#include "ground/products/TruthSeen.hpp"

namespace areomap::products {

struct ProductImage {
  std::string stem;   // image file stem (names overlays/<stem>.png)
  cv::Mat grey;       // CV_8U, full resolution; empty = image missing (skipped with a warning)
  CameraModel model;  // adjusted model (CAHV/CAHVOR/CAHVORE) in the pixel frame of `grey`
};

struct ProductPair {
  int id = 0;
  int sol = 0;
  int left = -1;   // index into ProductInputs::images
  int right = -1;  // -1: a single image (used for the ortho only)
};

struct ProductTie {
  int point = 0;            // tie point id
  int image = 0;            // index into ProductInputs::images
  Vec2 pixel_px = Vec2::Zero();  // measured (distorted) pixel
  bool inter = false;       // inter-stereo tie (drawn red; intra blue)
  double residual_px = -1;  // back-projection residual after adjustment (|v|), < 0: computed by makeProducts
                            // (the point intersected again with the adjusted models)
};

// The adjusted cameras' exterior orientation with its whole covariance, pairs' cross blocks included
// (ground/adjust/FullEoCovariance.hpp): with it the DEM sigma carries the cameras' error, which every point
// of a pair shares and which is correlated between pairs (ground/dem/SharedHeightError.hpp).
struct EoUncertainty {
  std::vector<NetImage> cameras;   // per ProductInputs::images: the adjusted network's io, centre_m, m
  std::vector<int> block_of_pair;  // per ProductInputs::pairs: its 12 x 12 block in `covariance` (-1: none)
  Eigen::MatrixXd covariance;      // [left dC, delta, right dC, delta] per block (Constraints.hpp)
};

struct ProductInputs {
  std::string site;                 // panorama name (raster metadata, report title)
  std::vector<ProductImage> images;
  std::vector<ProductPair> pairs;
  std::vector<ProductTie> ties;     // verified tie observations (parallax ranges, overlays, residual plots)
  Vec3 gimbal_site_m = Vec3::Zero();  // centre of the panorama (ranges, finer grid near the rover)
  // Optional truth (synthetic datasets): the true DEM (truth/dem.tif) -> truth.dem_rmse_m. Or its file,
  // read when the DEM is compared with it (a navcam truth/dem.tif is 0.1 GB: not held through the dense
  // and DEM stages), when truth_dem is absent.
  std::optional<DemGrid> truth_dem;
  std::string truth_dem_path;
  // Optional truth: the true models, per `images` (empty: none) -> truth.dem_unseen_empty, dem_seen_filled,
  // ortho_agreement (TruthSeen.hpp), with truth_dem.
  std::vector<CameraModel> truth_models;
  std::optional<EoUncertainty> eo_uncertainty;  // absent: the DEM sigma leaves the cameras' error out
};

struct ProductOptions {
  double cell_m = -1.0;         // dem.tif cell (-1: automatic: 2 cm up to a 40 m wide cloud, coarser beyond)
  // The finer grid near the rover: when dem.tif's cell is coarser than near_cell_m, the points within
  // near_range_m of the gimbal centre (a square) are kriged again at near_cell_m -> dem_near.tif and
  // dem_near_sigma.tif (same rules as dem.tif). near_cell_m <= 0: not made.
  double near_cell_m = 0.02;
  double near_range_m = 10.0;
  double max_range_m = 60.0;    // points farther from the gimbal centre are not used
  double max_point_sigma_m = 0.5;  // points with a larger height sigma are dropped
  double seam_m = 20.0;         // kriging inside, equi-parallax interpolation outside
  int dense_max_disparity_px = 192;
  std::size_t ply_max_points = 2000000;  // points.ply is thinned evenly to this many points
  bool write_overlays = true;   // overlays/<stem>.png (set false when the ties tool wrote them)
};

struct ProductsResult {
  std::vector<std::string> files;     // products written (paths)
  std::vector<std::string> warnings;  // also appended to the report
  // Products that could not be written (full disk, folder not writable), one message each naming the
  // file (also among the warnings). Every product is written under a temporary name in out_dir and
  // renamed into place when complete: a failed one is absent or still the previous version, never partial.
  std::vector<std::string> write_errors;
  long long points = 0;               // cloud size
  long long dem_points = 0;           // of them, binned into dem.tif's cells (all: the DEM loses none)
  int pairs_matched = 0;
  std::vector<ground::DensePairNoise> dense_pairs;  // each matched pair's matching noise (report.json dense)
  std::optional<DemGrid> dem;                       // the DEM written (absent when no points)
  std::optional<DemGrid> dem_sigma;                 // its sigma (dem_sigma.tif), same grid
  std::vector<uint8_t> dem_seen;  // its cells' classes (dem_seen.tif, ground/dem/DemSeen.hpp), same grid
  std::optional<DemGrid> ortho;  // ortho.tif's grey values (0 = no data) on its grid (absent: none made)
  std::optional<DemGrid> dem_near;   // the finer near-rover DEM (absent when dem.tif is already that fine)
  std::optional<double> dem_rmse_m;  // against truth_dem over cells present in both
  std::optional<SeenTruth> seen_truth;  // with truth_models and truth_dem (TruthSeen.hpp)
  double ortho_seam_px = -1.0;       // median geometric disagreement at ortho seams, px (-1: no seams)
  std::vector<double> residuals_px;  // tie back-projection residuals plotted in report.html
  // Per stereo pair (in ProductInputs::pairs order, both images present): of the cells both cameras see
  // at 2-5 m and at 5-10 m horizontal range, how many the DEM fills (DemCoverage.hpp; report.json
  // dem_coverage).
  std::vector<ground::DemCoverageFigure> coverage;
  std::vector<std::pair<std::string, double>> seconds;  // stage timings (rectify, dense, ..., previews)
};

// One pair's dense matching inputs as the cloud stage hands them to dense::pairCloud: the adjusted models
// with their images' sizes, the measured pixels of the pair's tie points seen in both images (in point
// order, one entry per point) and the pair options from `options`. The pair's images must be present.
struct PairDenseInputs {
  CameraModel left, right;
  std::vector<Vec2> left_ties_px, right_ties_px;
  dense::PairCloudOptions options;
};
PairDenseInputs pairDenseInputs(const ProductInputs& inputs, const ProductOptions& options,
                                const ProductPair& pair);

// Makes every product above in `out_dir` (created if needed). Progress lines on stderr.
// Throws only for an out_dir that cannot be created (cli::InputError naming the path); products that
// cannot be written are listed in `write_errors` (a caller should then exit non-zero).
// `adjustment` (optional) is only read: report.html shows it with the products' part merged in.
ProductsResult makeProducts(const ProductInputs& inputs, const ProductOptions& options,
                            const std::string& out_dir, const ground::AdjustReport* adjustment = nullptr);

// What the products add to report.json: their stage timings after the adjustment's, their warnings,
// dense.pairs (each pair's matching noise) and truth.dem_rmse_m (when the report has a truth section). Call
// before writeReportJson. With seen_truth also truth.dem_unseen_empty, dem_seen_filled, ortho_agreement.
void mergeIntoReport(const ProductsResult& products, ground::AdjustReport& report);

}  // namespace areomap::products
