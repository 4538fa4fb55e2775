#include "tests/ground/products/TruthDatum.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "firmware_core/adjust/Datum.hpp"
#include "firmware_core/camera/CameraConversion.hpp"
#include "ground/io/CameraFile.hpp"

namespace areomap::test {

namespace {

// The site -> camera rotation of the project's conversion (identity if the model does not convert).
Mat3 rotationOf(CameraModel m, int width, int height) {
  if (m.width <= 0) m.width = width, m.height = height;
  PhotogrammetricCamera p;
  ConversionResidual residual;
  return cahvorToPhotogrammetric(m, p, residual) == Status::kOk ? p.m : Mat3::Identity();
}

}  // namespace

double TruthDatum::angleRad() const {
  return std::acos(std::min(1.0, 0.5 * (rotation.trace() - 1.0)));
}

TruthDatum truthDatum(const Dataset& ds, const std::string& root, const std::string& products) {
  TruthDatum d;
  std::vector<Mat3> m_est, m_true;
  for (const Pair& p : ds.pairs) {
    for (const ImageRef* ref : {&p.left, p.right ? &*p.right : nullptr}) {
      if (ref == nullptr) continue;
      CameraModel t = io::readCameraModelFile(root + "/truth/models/" + ref->stem + ".cahvor");
      if (t.width <= 0) t.width = ds.width, t.height = ds.height;
      d.truth_models.push_back(t);
      d.centre += t.c;
      const std::string adj = products + "/models/" + ref->stem + ".cahvor";
      if (std::filesystem::exists(adj)) {
        m_est.push_back(rotationOf(io::readCameraModelFile(adj), ds.width, ds.height));
        m_true.push_back(rotationOf(t, ds.width, ds.height));
      }
    }
  }
  if (!d.truth_models.empty()) d.centre /= static_cast<double>(d.truth_models.size());
  if (!ds.rig.gimbal_m.empty()) d.centre = Vec3(ds.rig.gimbal_m.begin()->second);
  if (!m_est.empty())
    d.rotation = commonRotation(m_est.data(), m_true.data(), static_cast<int32_t>(m_est.size()));
  d.adjusted_models = m_est.size();
  return d;
}

}  // namespace areomap::test
