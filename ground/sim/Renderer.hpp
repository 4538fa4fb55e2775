// Renders 8-bit grayscale images of the terrain through CAHVOR models: per supersampled pixel the CAHVOR
// ray (unproject) is cast into the height field (occlusion), shaded Lambertian from the sun with cast
// shadows and a sky/ambient term, its radiance integrated over the ray's footprint along the surface (long at
// grazing incidence), then an optional Gaussian optical blur (SimConfig::blur_px), sensor noise and an
// optional JPEG round trip. Rows are shared among threads; every random number is a hash of (seed, image, pixel), so the bytes do not depend on the thread
// count.
#pragma once

#include <cstdint>
#include <vector>

#include "firmware_core/camera/CameraModel.hpp"
#include "ground/sim/SimConfig.hpp"
#include "ground/sim/Terrain.hpp"

namespace areomap::sim {

struct RenderedImage {
  int width = 0;
  int height = 0;
  std::vector<uint8_t> pixels;  // row-major, width * height
};

// `image_index` decorrelates the noise of different images.
RenderedImage renderImage(const Terrain& terrain, const SimConfig& config, const CameraModel& model, int image_index);

}  // namespace areomap::sim
