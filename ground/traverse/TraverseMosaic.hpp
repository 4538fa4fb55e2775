// One raster over a whole traverse from the sites' own rasters (dem.tif, dem_sigma.tif, ortho.tif, each in
// its site frame: ground/dataset/Traverse.hpp), placed by the sites' poses: the nearest-site rule. Every
// cell of the traverse grid (north-up, the traverse frame) takes the value of the site whose origin is
// nearest to it horizontally among the sites that have data there, so each part of the map comes from the
// panorama that saw it from closest, and a site's gap is filled from the next nearest.
#pragma once

#include <vector>

#include "ground/dataset/DemRaster.hpp"
#include "ground/dataset/Traverse.hpp"

namespace areomap::traverse {

enum class MosaicKind {
  kElevation,  // up (-Z) in the site frame: the traverse value is up - position.z
  kSigma,      // a standard deviation: sqrt(value^2 + extra_variance of its site)
  kGrey,       // a grey value: taken as it is (nearest cell, no interpolation)
};

struct MosaicInput {
  SitePose pose;  // the site frame in the traverse frame
  const DemGrid* raster = nullptr;
  double extra_variance = 0.0;  // kSigma: variance added (e.g. the pose's vertical variance), m^2
};

struct Mosaic {
  DemGrid grid;                   // the traverse raster (nodata where no site has data)
  std::vector<int> site_of_cell;  // per cell, the input that gave it (-1: none)
};

// The traverse grid (cell `cell_m`) covering every input raster's footprint.
DemGrid traverseGrid(const std::vector<MosaicInput>& inputs, double cell_m);

// The raster's value at (north, east) of its own frame: bilinear between the four cell centres around it
// when all hold data (`interpolate`), else the nearest cell's; false outside or on nodata.
bool sampleRaster(const DemGrid& g, double north_m, double east_m, bool interpolate, double& value);

// RMS and count of `dem` - `truth` (both in one frame) over the cells of `dem` within `radius_m` of one of
// `centres` (north, east) where both hold data.
struct RasterDifference {
  double rms_m = 0.0;
  long long cells = 0;
};
RasterDifference differenceNear(const DemGrid& dem, const DemGrid& truth,
                                const std::vector<Eigen::Vector3d>& centres, double radius_m);

// Fills `grid`'s geometry with the inputs' values by the nearest-site rule. Elevations and sigmas are
// interpolated bilinearly inside a site raster (the nearest cell where a neighbour is nodata).
Mosaic mosaic(const std::vector<MosaicInput>& inputs, const DemGrid& grid, MosaicKind kind);

}  // namespace areomap::traverse
