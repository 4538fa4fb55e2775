// Orthoimage (paper §4.2): every cell of a DEM grid (ground/dataset DemGrid: columns east = site +Y, rows
// south, elevation up = -Z) is back-projected into the images with the adjusted camera models; the grey
// value comes from the image whose projection lies nearest its image centre (bilinear resampling).
//
// Seams: where the chosen image changes between neighbouring cells, the cell is a seam cell. At seam cells
// both candidate images are compared: the grey difference, and the geometric disagreement, measured in
// ortho space: each image is resampled through the DEM (bilinear) onto a local ground grid around the seam
// cell spaced one pixel of the chosen image; the best shift between the two patches (NCC search
// +-seam_search samples, parabolic) is the disagreement in pixels of the chosen image. With right models
// and a right DEM the two agree; a DEM or EO error shows.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "firmware_core/camera/CameraModel.hpp"
#include "ground/dataset/DemRaster.hpp"

namespace areomap::ortho {

struct OrthoSource {
  cv::Mat grey;       // CV_8U; empty images are skipped
  CameraModel model;  // model in the pixel frame of `grey`
};

struct OrthoOptions {
  int supersample = 1;          // ortho cells per DEM cell along each axis (ortho grid = DEM grid / this)
  double border_px = 2.0;       // projections closer than this to the image edge are not used
  int seam_search_px = 3;       // NCC search radius for the seam check, pixels
  int seam_patch_half_px = 5;   // half size of the NCC patch, pixels
  int max_seam_samples = 4000;  // seam cells checked (evenly subsampled)
  // An image paints a cell only when the DEM's own terrain does not hide the cell from the camera
  // (ground/dem Viewshed: a DEM cell hides when it rises above the line of sight by more than twice its
  // sigma, `dem_sigma` on the DEM's grid; none: by any amount).
  bool occlusion = true;
  const DemGrid* dem_sigma = nullptr;
  // Per DEM cell (row-major, the DEM's size): 0 where the caller reads none of its ortho cells (left empty,
  // not painted); none: every cell. A cell's ortho value does not depend on which others are painted.
  const std::vector<uint8_t>* cells = nullptr;
  bool check_seams = true;  // the seam statistics (OrthoResult::seams); false: seam_cells only
};

struct SeamStats {
  long long seam_cells = 0;
  long long checked = 0;             // seam cells with a valid NCC match
  double grey_rms = 0.0;             // RMS grey difference of the two candidates at seam cells
  double geometric_rms_px = 0.0;     // RMS offset (see above)
  double geometric_p95_px = 0.0;
  double geometric_median_px = 0.0;  // robust figure (occlusions at rocks make the RMS heavy-tailed)
};

struct OrthoResult {
  DemGrid grid;       // geometry of the ortho (values unused, empty)
  cv::Mat image;      // CV_8U, rows x cols of `grid`; 0 = no data
  cv::Mat valid;      // CV_8U 255 where filled
  cv::Mat source;     // CV_16S index of the source image, -1 none
  SeamStats seams;
  long long cells_filled = 0;
};

// Makes the orthoimage of `dem` (nodata cells stay empty). Cells whose ground point projects behind a
// camera or outside its image take no value from it, nor from an image whose pixel there does not see the
// point (its ray misses it: CAHVOR/CAHVORE distortion folds points far beyond the field into the image),
// nor from an image from which the DEM's terrain hides it (OrthoOptions::occlusion).
OrthoResult makeOrthoimage(const DemGrid& dem, const std::vector<OrthoSource>& sources, const OrthoOptions& options);

// The DEM elevation at a site point (bilinear over the four nearest cells; nodata if any is nodata).
bool demElevation(const DemGrid& dem, double north_m, double east_m, double& elevation_m);

// Sub-pixel shift (cells, east and south) between two orthoimages on the same grid, by NCC of tiles: the
// median over tiles (tile_px square) of the per-tile best shift (+- search_px, parabolic). `mask` (CV_8U,
// optional) restricts the tiles used. Returns the number of tiles used.
int orthoShift(const cv::Mat& a, const cv::Mat& b, const cv::Mat& mask, int tile_px, int search_px,
               double& shift_east_cells, double& shift_south_cells, double* rms_shift_cells = nullptr);

}  // namespace areomap::ortho
