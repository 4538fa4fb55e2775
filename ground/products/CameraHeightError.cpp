#include "ground/products/CameraHeightError.hpp"

#include <Eigen/Dense>

#include "firmware_core/camera/Photogrammetric.hpp"

namespace areomap::products {

bool heightGradient(const NetImage& left, const NetImage& right, const Vec3& point_site_m, double* g) {
  Eigen::Matrix<double, 4, 3> a;
  Eigen::Matrix<double, 4, 12> b = Eigen::Matrix<double, 4, 12>::Zero();
  const NetImage* cameras[2] = {&left, &right};
  for (int s = 0; s < 2; ++s) {
    const NetImage& cam = *cameras[s];
    Vec2 pixel;
    Mat2x3 d_centre, d_rotation, d_point;
    if (!ok(collinearity(cam.io, cam.centre_m, cam.m, point_site_m, pixel, &d_centre, &d_rotation, &d_point)))
      return false;
    a.middleRows<2>(2 * s) = d_point;
    b.block<2, 3>(2 * s, 6 * s) = d_centre;
    b.block<2, 3>(2 * s, 6 * s + 3) = d_rotation;
  }
  const Mat3 normal = a.transpose() * a;
  Eigen::LDLT<Mat3> ldlt(normal);
  if (ldlt.info() != Eigen::Success || !(ldlt.rcond() > 1e-12)) return false;
  // dX/de = -N^-1 A^T B; the height is -Z, so its gradient is +row 2 of N^-1 A^T B.
  const Eigen::Matrix<double, 3, 12> dx = ldlt.solve(a.transpose() * b);
  for (int d = 0; d < 12; ++d) g[d] = dx(2, d);
  return dx.allFinite();
}

std::optional<dem::SharedHeightError> cameraHeightError(const ProductInputs& in) {
  if (!in.eo_uncertainty) return std::nullopt;
  const EoUncertainty& eo = *in.eo_uncertainty;
  dem::SharedHeightError shared;
  shared.covariance = eo.covariance;
  // Per block: its two cameras (the block's pair), by block index.
  std::vector<std::pair<const NetImage*, const NetImage*>> cameras(
      static_cast<std::size_t>(eo.covariance.rows() / dem::kSharedErrorDims), {nullptr, nullptr});
  for (std::size_t p = 0; p < in.pairs.size() && p < eo.block_of_pair.size(); ++p) {
    const int block = eo.block_of_pair[p];
    const ProductPair& pair = in.pairs[p];
    if (block < 0 || static_cast<std::size_t>(block) >= cameras.size() || pair.left < 0 || pair.right < 0)
      continue;
    if (static_cast<std::size_t>(std::max(pair.left, pair.right)) >= eo.cameras.size()) continue;
    shared.block_of_pair[pair.id] = block;
    cameras[static_cast<std::size_t>(block)] = {&eo.cameras[static_cast<std::size_t>(pair.left)],
                                                &eo.cameras[static_cast<std::size_t>(pair.right)]};
  }
  if (shared.block_of_pair.empty()) return std::nullopt;
  shared.gradient = [cameras](int block, double north_m, double east_m, double elevation_m, double* g) {
    const auto& c = cameras[static_cast<std::size_t>(block)];
    if (c.first == nullptr) return false;
    return heightGradient(*c.first, *c.second, Vec3(north_m, east_m, -elevation_m), g);
  };
  return shared;
}

}  // namespace areomap::products
