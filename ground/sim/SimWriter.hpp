// Writes a simulated dataset folder in the DESIGN.md form: panorama.json, images/<stem>.png (8-bit),
// models/<stem>.cahvor (a-priori), truth/models/<stem>.cahvor, truth/dem.tif, truth/points.csv,
// truth/observations.csv and truth/sim.json (the configuration that made it).
#pragma once

#include <functional>
#include <string>

#include "firmware_core/camera/CameraModel.hpp"
#include "ground/sim/SimGeometry.hpp"
#include "ground/sim/Terrain.hpp"

namespace areomap::sim {

struct WriteOptions {
  bool images = true;  // false: everything but images/ (geometry and truth only)
  // Called after each rendered image with (done, total); may be empty.
  std::function<void(int, int)> on_image;
};

// Throws DatasetError (a cli::InputError) naming the file that cannot be written.
void writeSimDataset(const SimGeometry& geometry, const Terrain& terrain, const std::string& out_dir,
                     const WriteOptions& options);

}  // namespace areomap::sim
