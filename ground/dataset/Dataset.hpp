// The input dataset of DESIGN.md ("Frames and formats", "The contract in detail"): a folder with
// panorama.json, its images and a-priori models, and for synthetic datasets a truth/ folder.
//
// Only pairs[].left.image is required. What is absent stays absent here (std::optional, width/height 0)
// and is listed in Dataset::notes; estimating a missing rig from the a-priori models is the job of the code
// that has the models loaded. Paths are relative to the dataset folder: absolute paths and any ".."
// component are rejected (safe inputs), as are duplicate ids and duplicate image stems.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "ground/dataset/DatasetError.hpp"

namespace areomap {

struct ImageRef {
  std::string image;                 // as written in panorama.json (relative to the dataset folder)
  std::string image_path;            // resolved: absolute path of root / image
  std::string stem;                  // the image file's name without folder and extension
  std::optional<std::string> model;  // a-priori model as written; absent = from the PDS3 label
  std::string model_path;            // resolved model path; empty when absent
};

struct Pair {
  int id = 0;
  int sol = 0;
  int tier = 0;
  ImageRef left;
  std::optional<ImageRef> right;  // a pair may have a left image only
};

// Rig constants of the constrained adjustment (Eq. 3, Eq. 4). Absent values are to be estimated.
struct Rig {
  std::map<int, Eigen::Vector3d> gimbal_m;       // gimbal centre per sol, site frame
  std::optional<Eigen::Vector3d> left_offset_m;  // C_L - X_G in the left camera frame
  std::optional<Eigen::Vector3d> right_offset_m; // C_R - X_G in the right camera frame
  std::optional<Eigen::Vector3d> base_m;         // C_R - C_L in the left camera frame
  std::optional<double> sigma_gimbal_m;  // absent: the constraint is held (ground/dataset/RigSigmas.hpp)
  std::optional<double> sigma_base_m;
};

struct Dataset {
  std::string root;  // the dataset folder as given to readDataset (or the folder written to)
  std::string name;
  int width = 0;     // image_size[0], samples; 0 = not given (read it from the images)
  int height = 0;    // image_size[1], lines
  Rig rig;
  std::vector<Pair> pairs;
  // One sentence per optional item that was absent and what was (or is to be) done about it, e.g.
  // "rig.base_m: absent, to be estimated from the a-priori models". For the report.
  std::vector<std::string> notes;

  int imageCount() const;
  // The pair and side of an image stem; false if no image has that stem.
  bool findStem(const std::string& stem, int& pair_index, bool& is_right) const;
};

// The file name of the dataset description inside the folder.
constexpr const char* kPanoramaFileName = "panorama.json";

// Reads DIR/panorama.json. Throws DatasetError naming "panorama.json" (with the folder) and the field,
// e.g. "…/panorama.json: pairs[3].left.image: absolute paths are not allowed".
Dataset readDataset(const std::string& dir);

// The notes readDataset adds for the rig values a dataset leaves absent (to be estimated, or held), for a
// Dataset made in memory with every other field given.
void noteRigDefaults(Dataset& dataset);
// Writes DIR/panorama.json in the contract's form (creating DIR). Only what is present is written;
// paths are the relative ones of each ImageRef (checked like the reader checks them).
// Throws DatasetError when the folder or file cannot be written.
void writeDataset(const Dataset& dataset, const std::string& dir);

// Throws DatasetError naming the field if an image (and, when `models`, a given model) file is missing.
void checkDatasetFiles(const Dataset& dataset, bool images, bool models);

// A relative path is safe when it is not empty, not absolute and has no ".." component. `why` receives
// the reason when it is not.
bool isSafeRelativePath(const std::string& path, std::string& why);

// The stem of a path: its file name without folder and (last) extension.
std::string pathStem(const std::string& path);

// Fills an ImageRef from a relative image path (and optional model path) under `root`.
ImageRef makeImageRef(const std::string& root, const std::string& image,
                      const std::optional<std::string>& model = std::nullopt);

}  // namespace areomap
