#include "ground/traverse/SiteDatum.hpp"

#include <cmath>
#include <filesystem>
#include <vector>

#include <Eigen/Geometry>

#include "firmware_core/camera/CameraConversion.hpp"
#include "ground/cli/Cli.hpp"
#include "ground/dataset/Dataset.hpp"
#include "ground/io/CameraFile.hpp"

namespace areomap::traverse {

namespace {

// Site-to-camera rotation of a model; false when it cannot be converted.
bool rotationOf(const CameraModel& model, Mat3& r) {
  PhotogrammetricCamera cam;
  ConversionResidual residual;
  if (!ok(cahvorToPhotogrammetric(model, cam, residual))) return false;
  r = cam.m;
  return true;
}

}  // namespace

SiteCameras siteCameras(const ground::SitePass& pass) {
  SiteCameras out;
  for (std::size_t p = 0; p < pass.dataset.pairs.size(); ++p) {
    const Pair& pair = pass.dataset.pairs[p];
    for (const ImageRef* ref : {&pair.left, pair.right ? &*pair.right : nullptr}) {
      if (ref == nullptr) continue;
      const CameraModel* adjusted = pass.adjustedOf(ref->stem);
      if (adjusted == nullptr) continue;
      out.push_back({ref->stem, static_cast<int>(p), *pass.aprioriOf(ref->stem), *adjusted});
    }
  }
  return out;
}

SiteCameras readSiteCameras(const TraverseSite& site, const std::string& models_dir) {
  SiteCameras out;
  const Dataset dataset = readDataset(site.dir);
  for (std::size_t p = 0; p < dataset.pairs.size(); ++p) {
    const Pair& pair = dataset.pairs[p];
    for (const ImageRef* ref : {&pair.left, pair.right ? &*pair.right : nullptr}) {
      if (ref == nullptr) continue;
      const std::string adjusted = models_dir + "/" + ref->stem + ".cahvor";
      if (!std::filesystem::is_regular_file(adjusted)) continue;
      const std::string path = ref->model_path.empty() ? ref->image_path : ref->model_path;
      out.push_back({ref->stem, static_cast<int>(p),
                     io::readCameraModelForImage(path, ref->image_path, dataset.width, dataset.height),
                     io::readCameraModelFile(adjusted)});
    }
  }
  return out;
}

SiteDatum siteDatum(const SiteCameras& cameras) {
  SiteDatum out;
  std::vector<Vec3> corrections;  // one per pair: the mean of its images' rotation corrections (site frame)
  for (std::size_t i = 0; i < cameras.size();) {
    Vec3 sum = Vec3::Zero();
    int n = 0;
    const int pair = cameras[i].pair_index;
    for (; i < cameras.size() && cameras[i].pair_index == pair; ++i) {
      Mat3 r_apriori, r_adjusted;
      if (!rotationOf(cameras[i].apriori, r_apriori) || !rotationOf(cameras[i].adjusted, r_adjusted))
        continue;
      // r_adjusted = r_apriori * G^T for a rotation G of the camera about the site's axes: the correction
      // G's rotation vector, in the site frame.
      const Eigen::AngleAxisd g(Mat3(r_adjusted.transpose() * r_apriori));
      sum += g.angle() * g.axis();
      ++n;
    }
    if (n > 0) corrections.push_back(sum / n);
  }
  out.pairs = static_cast<int>(corrections.size());
  if (out.pairs < 2) return out;
  Vec3 mean = Vec3::Zero();
  for (const Vec3& c : corrections) mean += c;
  mean /= out.pairs;
  Vec3 var = Vec3::Zero();
  for (const Vec3& c : corrections) var += (c - mean).cwiseAbs2();
  out.scatter_rad = (var / (out.pairs - 1)).cwiseSqrt();
  out.sigma_rad = out.scatter_rad / std::sqrt(static_cast<double>(out.pairs));
  out.known = true;
  return out;
}

}  // namespace areomap::traverse
