// A panorama loaded once (DESIGN.md panorama.json): every image of a dataset decoded as 8-bit grey with its
// a-priori camera model, so that the ground's stages (tie points, overlays, products) share one decode of
// each image and one read of each model instead of re-opening the dataset's files stage by stage.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "firmware_core/camera/CameraModel.hpp"
#include "ground/dataset/Dataset.hpp"

namespace areomap::io {

struct PanoramaImage {
  std::string stem;
  std::string image_path;  // names the image in errors
  cv::Mat grey;            // 8-bit, continuous
  CameraModel model;       // a-priori, in the image's pixel frame
};

// One image of a dataset: its pixels as 8-bit grey (PNG/JPEG/PGM/PDS3, loadImage8) and its a-priori model
// (the model file panorama.json names, else the image's own PDS3 label), read for the image's size.
// Throws cli::InputError naming the file and the field.
PanoramaImage loadPanoramaImage(const ImageRef& ref);

struct Panorama {
  Dataset dataset;
  std::vector<PanoramaImage> left;                  // per pair, panorama.json order
  std::vector<std::optional<PanoramaImage>> right;  // per pair; none for a mono pair
  // The image of `stem`, or nullptr.
  const PanoramaImage* find(const std::string& stem) const;
};

// Every image of `dataset` (loadPanoramaImage), in pair order.
Panorama loadPanorama(Dataset dataset);

}  // namespace areomap::io
