// One site of a traverse as the cross-site tie finder sees it: its images (with a small Gaussian pyramid
// for patches seen at another scale), its camera models and its DEM, all in the site's own frame
// (docs/traverse.md "Frames"). Made from the site's pass (ground/pass SitePass), from its ground products
// on disk (areomap-ground --out: models/<stem>.cahvor, dem.tif, dem_sigma.tif) or, for tests and checks,
// from the site's truth (truth/models, truth/dem.tif).
#pragma once

#include <cmath>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "firmware_core/camera/CameraModel.hpp"
#include "ground/dataset/Dataset.hpp"
#include "ground/dataset/DemRaster.hpp"
#include "ground/dataset/Traverse.hpp"
#include "ground/pass/GroundPass.hpp"

namespace areomap::traverse {

// Pyramid levels kept per image: level l is the image low-passed and subsampled by 2^l (cv::pyrDown), so
// that a patch seen up to 8x smaller in another image is compared at a matching scale.
constexpr int kPyramidLevels = 4;

struct SiteImage {
  std::string stem;
  int pair_index = 0;
  bool right = false;
  CameraModel model;             // in the site frame
  std::vector<cv::Mat> pyramid;  // CV_32F, level 0 = the image
};

struct SiteProducts {
  std::string id;
  std::vector<SiteImage> images;
  DemGrid dem;                       // elevation up (-Z), site frame
  std::optional<DemGrid> dem_sigma;  // same grid, metres
  std::optional<DemGrid> ortho;      // same grid, grey values (0 or nodata: none); the products' ortho.tif
  // Index of an image stem in `images`, or -1.
  int indexOf(const std::string& stem) const;
};

// Reads site `site` of a traverse with its products in `products_dir` (models/<stem>.cahvor, dem.tif,
// dem_sigma.tif when present). Throws cli::InputError / DatasetError naming the file and field.
SiteProducts loadSiteProducts(const TraverseSite& site, const std::string& products_dir);
// The same from the site's pass as data (its images, adjusted models, DEM and sigma).
SiteProducts siteProducts(const TraverseSite& site, const ground::SitePass& pass);
// The site's truth as products: truth/models and truth/dem.tif, averaged to `cell_m` cells (0: as is).
SiteProducts loadSiteTruth(const TraverseSite& site, double cell_m);

// Bilinear elevation of a DEM at a site point (cell centres per the raster contract); NaN outside or where
// a corner is nodata. Inline: the rays cast onto the DEMs call it at every step.
inline double demElevation(const DemGrid& dem, double x_north_m, double y_east_m) {
  const double u = (y_east_m - dem.east0_m) / dem.cell_m - 0.5;
  const double v = (dem.north0_m - x_north_m) / dem.cell_m - 0.5;
  if (!(u >= 0.0 && v >= 0.0)) return NAN;
  const int c = static_cast<int>(u), r = static_cast<int>(v);
  if (c + 1 >= dem.cols || r + 1 >= dem.rows) return NAN;
  const float a = dem.at(c, r), b = dem.at(c + 1, r), d = dem.at(c, r + 1), e = dem.at(c + 1, r + 1);
  if (a == dem.nodata || b == dem.nodata || d == dem.nodata || e == dem.nodata) return NAN;
  if (!std::isfinite(a) || !std::isfinite(b) || !std::isfinite(d) || !std::isfinite(e)) return NAN;
  const double fu = u - c, fv = v - r;
  return a * (1 - fu) * (1 - fv) + b * fu * (1 - fv) + d * (1 - fu) * fv + e * fu * fv;
}

// Averages a DEM into cells `factor` times larger (a cell is nodata when half of its inputs are).
DemGrid coarsenDem(const DemGrid& dem, int factor);

// Casts a ray (site frame) onto a DEM: the first crossing from above to below the surface within
// `max_range_m`, refined by bisection. False when the ray meets no valid surface.
bool castRayOnDem(const DemGrid& dem, const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                  double max_range_m, double& t_m);

// The highest valid elevation of a DEM over square blocks of cells, each block's taken over the cells its
// samples' bilinear corners may reach (one cell beyond it on every side): a stretch of a ray above a
// block's ceiling is above the surface, or off it, at every step it makes there.
struct DemCeiling {
  int block = 8;           // cells per block side
  int cols = 0, rows = 0;  // blocks
  std::vector<float> top;  // row-major; -inf where the block has no valid cell
};
DemCeiling demCeiling(const DemGrid& dem, int block = 8);

// castRayOnDem on `dem` whose ceiling is `ceiling`: the steps above a block's ceiling are passed over, the
// others made as there, so that the crossing is the same bits.
bool castRayOnDem(const DemGrid& dem, const DemCeiling& ceiling, const Eigen::Vector3d& origin,
                  const Eigen::Vector3d& direction, double max_range_m, double& t_m);

// Least-squares plane of the DEM about a site point (cells within `radius_m`): unit normal (site frame,
// pointing up, i.e. negative z) through the point on the plane above/below it. False with too few cells.
bool demPlane(const DemGrid& dem, const Eigen::Vector3d& point_m, double radius_m, Eigen::Vector3d& normal,
              Eigen::Vector3d& on_plane);

}  // namespace areomap::traverse
