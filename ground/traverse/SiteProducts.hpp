// One site of a traverse as the cross-site tie finder sees it: its images (with a small Gaussian pyramid
// for patches seen at another scale), its camera models and its DEM, all in the site's own frame
// (docs/traverse.md "Frames"). Made from the site's pass (ground/pass SitePass), from its ground products
// on disk (areomap-ground --out: models/<stem>.cahvor, dem.tif, dem_sigma.tif) or, for tests and checks,
// from the site's truth (truth/models, truth/dem.tif).
#pragma once

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
// a corner is nodata.
double demElevation(const DemGrid& dem, double x_north_m, double y_east_m);
// Averages a DEM into cells `factor` times larger (a cell is nodata when half of its inputs are).
DemGrid coarsenDem(const DemGrid& dem, int factor);

// Casts a ray (site frame) onto a DEM: the first crossing from above to below the surface within
// `max_range_m`, refined by bisection. False when the ray meets no valid surface.
bool castRayOnDem(const DemGrid& dem, const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                  double max_range_m, double& t_m);

// Least-squares plane of the DEM about a site point (cells within `radius_m`): unit normal (site frame,
// pointing up, i.e. negative z) through the point on the plane above/below it. False with too few cells.
bool demPlane(const DemGrid& dem, const Eigen::Vector3d& point_m, double radius_m, Eigen::Vector3d& normal,
              Eigen::Vector3d& on_plane);

}  // namespace areomap::traverse
