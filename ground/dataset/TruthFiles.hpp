// CSV files of the dataset contract (DESIGN.md "Names"): true check points `truth/points.csv`
// (point,x_m,y_m,z_m, site frame), true observations `truth/observations.csv` and tie-point lists
// (point,image,sample_px,line_px[,kind]; image = the image file's stem, pixels with (0,0) the centre of the
// first pixel). Readers take the columns by header name (order free, unknown columns ignored, blank lines
// and lines starting with '#' skipped) and throw DatasetError naming the file, line and column.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "ground/dataset/DatasetError.hpp"

namespace areomap {

// Where the truth files of a synthetic dataset live, relative to the dataset folder.
constexpr const char* kTruthFolder = "truth";
constexpr const char* kTruthPointsFile = "truth/points.csv";
constexpr const char* kTruthObservationsFile = "truth/observations.csv";
constexpr const char* kTruthModelsFolder = "truth/models";
constexpr const char* kTruthDemFile = "truth/dem.tif";

struct CheckPoint {
  int64_t point = 0;
  Eigen::Vector3d site_m = Eigen::Vector3d::Zero();  // x north, y east, z down
};

struct ImageObservation {
  int64_t point = 0;
  std::string image;  // image stem
  double sample_px = 0.0;
  double line_px = 0.0;
  std::string kind;   // optional column (e.g. "intra", "inter"); empty when absent
};

std::vector<CheckPoint> readPointsCsv(const std::string& path);
void writePointsCsv(const std::string& path, const std::vector<CheckPoint>& points);

// point,image,sample_px,line_px[,kind]: observations.csv, tiepoints.csv and --ties lists.
std::vector<ImageObservation> readObservationsCsv(const std::string& path);
inline std::vector<ImageObservation> readTiePointsCsv(const std::string& path) { return readObservationsCsv(path); }
// Writes the kind column only when `with_kind`.
void writeObservationsCsv(const std::string& path, const std::vector<ImageObservation>& observations,
                          bool with_kind = false);

// Shortest text that reads back to the same double (std::to_chars).
std::string formatDouble(double value);

}  // namespace areomap
