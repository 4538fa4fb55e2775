// The common datum rotation of a products folder's adjusted models against a synthetic dataset's true ones
// (firmware_core/adjust/Datum.hpp), which every comparison with truth removes first (DESIGN.md "Datum"):
// the evaluation tools dem_check and point_error_check.
#pragma once

#include <string>
#include <vector>

#include "firmware_core/base/EigenTypes.hpp"
#include "firmware_core/camera/CameraModel.hpp"
#include "ground/dataset/Dataset.hpp"

namespace areomap::test {

struct TruthDatum {
  std::vector<CameraModel> truth_models;  // DATASET/truth/models, one per image of the dataset (pair order)
  Vec3 centre = Vec3::Zero();             // the rotation's centre: the gimbal centre (else the cameras' mean)
  Mat3 rotation = Mat3::Identity();       // adjusted -> truth; identity without adjusted models
  std::size_t adjusted_models = 0;        // PRODUCTS/models/<stem>.cahvor found
  double angleRad() const;
  // A site point of the adjusted products in the truth's frame.
  Vec3 align(const Vec3& p) const { return centre + rotation * (p - centre); }
};

// From DATASET/truth/models and PRODUCTS/models (absent: the true models were used, no rotation).
TruthDatum truthDatum(const Dataset& ds, const std::string& root, const std::string& products);

}  // namespace areomap::test
