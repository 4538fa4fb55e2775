#include "firmware_core/camera/CameraConversion.hpp"

#include <cmath>

#include "firmware_core/camera/CahvInternal.hpp"

namespace areomap {
namespace {

constexpr int32_t kFitUnknowns = 16;  // k0 k1 k2 k3 p1 p2 b1 b2 t1 t2 s1 s2 q1 q2 k4 k5
constexpr int32_t kMinFitPoints = 64; // fewer rays that project than this: the fit is not trusted

// Pixel of grid point i of n over [-0.5, size - 0.5]: cell corners (fit) or cell centres (residual).
double gridCorner(int32_t i, int32_t n, int32_t size) { return -0.5 + static_cast<double>(size) * i / (n - 1); }
double gridCentre(int32_t i, int32_t n, int32_t size) {
  return -0.5 + static_cast<double>(size) * (i + 0.5) / n;
}

// Pinhole ideal pixel of a site-frame direction.
Status pinholeOfDirection(const PhotogrammetricCamera& cam, const Vec3& direction, Vec2& ideal) {
  Vec3 d;
  d.noalias() = cam.m * direction;
  if (!(d.z() < 0.0)) {
    return Status::kBehindCamera;
  }
  ideal.x() = cam.io.x0_px - cam.io.f_px * d.x() / d.z();
  ideal.y() = cam.io.y0_px + cam.io.f_px * d.y() / d.z();
  return Status::kOk;
}

// Site-frame direction (unnormalised) of a pinhole ideal pixel.
Vec3 directionOfPinhole(const PhotogrammetricCamera& cam, const Vec2& ideal) {
  const Vec3 d_cam((ideal.x() - cam.io.x0_px) / cam.io.f_px, -(ideal.y() - cam.io.y0_px) / cam.io.f_px, -1.0);
  Vec3 d;
  d.noalias() = cam.m.transpose() * d_cam;
  return d;
}

// The 2 x 16 design rows of the distortion polynomial at a distorted pixel (normalised coordinates).
void distortionRows(const LensDistortion& d, const Vec2& pixel, Eigen::Matrix<double, 2, kFitUnknowns>& rows) {
  const double x = (pixel.x() - d.cx_px) / d.norm_px;
  const double y = (pixel.y() - d.cy_px) / d.norm_px;
  const double r2 = x * x + y * y, r4 = r2 * r2, r6 = r4 * r2;
  rows << x, x * r2, x * r4, x * r6, r2 + 2.0 * x * x, 2.0 * x * y, x, y, 1.0, 0.0, x * x, x * y, x * x * r2,
      x * y * r2, x * r4 * r4, x * r4 * r6,  //
      y, y * r2, y * r4, y * r6, 2.0 * x * y, r2 + 2.0 * y * y, 0.0, 0.0, 0.0, 1.0, x * y, y * y, x * y * r2,
      y * y * r2, y * r4 * r4, y * r4 * r6;
}

void accumulate(double e, double& sum2, double& max) {
  sum2 += e * e;
  max = std::fmax(max, e);
}

void finish(double sum2, int32_t n, ConversionResidual& residual) {
  residual.points = n;
  residual.rms_px = n > 0 ? std::sqrt(sum2 / n) : 0.0;
}

// Residual of a CAHVOR/CAHVORE model against the photogrammetric camera: for each grid pixel, the ray of
// the pixel (model inverse) projected through the photogrammetric camera with its distortion.
Status residualOverImage(const CameraModel& model, const PhotogrammetricCamera& cam, ConversionResidual& residual) {
  double sum2 = 0.0, max = 0.0;
  int32_t n = 0;
  for (int32_t j = 0; j < kConversionResidualGrid; ++j) {
    for (int32_t i = 0; i < kConversionResidualGrid; ++i) {
      const Vec2 pixel(gridCentre(i, kConversionResidualGrid, cam.io.width),
                       gridCentre(j, kConversionResidualGrid, cam.io.height));
      Vec2 ideal, back;
      if (pixelToIdeal(model, cam, pixel, ideal) != Status::kOk) continue;
      if (distortPixel(cam.io.distortion, ideal, back) != Status::kOk) continue;
      accumulate((back - pixel).norm(), sum2, max);
      ++n;
    }
  }
  residual.max_px = max;
  finish(sum2, n, residual);
  return n >= kMinFitPoints ? Status::kOk : Status::kDegenerate;
}

}  // namespace

Status pixelToIdeal(const CameraModel& model, const PhotogrammetricCamera& camera, const Vec2& pixel, Vec2& ideal) {
  Vec3 origin, direction;
  const Status s = unproject(model, pixel, origin, direction);
  if (s != Status::kOk) {
    return s;
  }
  return pinholeOfDirection(camera, direction, ideal);
}

Status idealToPixel(const CameraModel& model, const PhotogrammetricCamera& camera, const Vec2& ideal, Vec2& pixel) {
  if (!(camera.io.f_px > 0.0)) {
    return Status::kInvalidArgument;
  }
  CameraModel at_infinity = model;  // a direction: the entrance-pupil shift of CAHVORE does not enter
  at_infinity.e = Vec3::Zero();
  return project(at_infinity, model.c + directionOfPinhole(camera, ideal), pixel);
}

Status projectPhotogrammetric(const PhotogrammetricCamera& camera, const Vec3& point, Vec2& pixel) {
  Vec2 ideal;
  const Status s = collinearity(camera.io, camera.eo.centre_m, camera.m, point, ideal);
  if (s != Status::kOk) {
    return s;
  }
  return distortPixel(camera.io.distortion, ideal, pixel);
}

Status cahvorToPhotogrammetric(const CameraModel& model, PhotogrammetricCamera& camera,
                               ConversionResidual& residual) {
  residual = ConversionResidual{};
  const char* field = "";
  const Status valid = validateModel(model, field);
  if (valid != Status::kOk) {
    return valid;
  }
  if (model.width <= 0 || model.height <= 0) {
    return Status::kInvalidArgument;
  }
  const Vec3& a = model.a;
  const CahvInternal internal = cahvInternal(model);
  const double hc = internal.hc_px, vc = internal.vc_px;
  const double hs = internal.hs_px, vs = internal.vs_px;
  const Vec3& h_prime = internal.h_prime;
  const Vec3& v_prime = internal.v_prime;
  const Vec3 m2 = -a.normalized();
  const Vec3 m1 = -(v_prime - v_prime.dot(m2) * m2).normalized();
  const Vec3 m0 = m1.cross(m2);
  const double h_cos = h_prime.dot(m0);
  if (!(h_cos > 0.0)) {
    return Status::kDegenerate;  // H points left of V x A: a mirrored model
  }
  PhotogrammetricCamera cam;
  cam.m.row(0) = m0.transpose();
  cam.m.row(1) = m1.transpose();
  cam.m.row(2) = m2.transpose();
  cam.io.f_px = vs;
  cam.io.x0_px = hc;
  cam.io.y0_px = vc;
  cam.io.width = model.width;
  cam.io.height = model.height;
  cam.h_scale = hs * h_cos / vs;
  cam.h_shear = hs * h_prime.dot(v_prime) / vs;
  cam.eo.centre_m = model.c;
  opkFromRotation(cam.m, cam.eo.omega_rad, cam.eo.phi_rad, cam.eo.kappa_rad);

  LensDistortion& d = cam.io.distortion;
  d.norm_px = vs;
  d.cx_px = hc;
  d.cy_px = vc;
  if (model.type != CameraType::kCahv) {
    // Centre on the image point of the O axis (on the axis the distortion vanishes: CAHV projection of O).
    Vec2 o_point;
    const Status s = project(linearPart(model), model.c + model.o, o_point);
    if (s != Status::kOk) {
      return s;
    }
    d.cx_px = o_point.x();
    d.cy_px = o_point.y();
  }
  // Least squares: ideal - pixel = norm * rows(pixel) * coefficients, over the fit grid.
  Mat16 normal = Mat16::Zero();
  Vec16 rhs = Vec16::Zero();
  int32_t used = 0;
  for (int32_t j = 0; j < kConversionFitGrid; ++j) {
    for (int32_t i = 0; i < kConversionFitGrid; ++i) {
      const Vec2 pixel(gridCorner(i, kConversionFitGrid, model.width), gridCorner(j, kConversionFitGrid, model.height));
      Vec2 ideal;
      if (pixelToIdeal(model, cam, pixel, ideal) != Status::kOk) continue;
      Eigen::Matrix<double, 2, kFitUnknowns> rows;
      distortionRows(d, pixel, rows);
      const Vec2 target = (ideal - pixel) / d.norm_px;
      normal.noalias() += rows.transpose() * rows;
      rhs.noalias() += rows.transpose() * target;
      ++used;
    }
  }
  if (used < kMinFitPoints) {
    return Status::kDegenerate;
  }
  if (model.type != CameraType::kCahv) {
    const Eigen::LDLT<Mat16> ldlt(normal);
    if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) {
      return Status::kDegenerate;
    }
    const Vec16 x = ldlt.solve(rhs);
    if (!x.allFinite()) {
      return Status::kNotFinite;
    }
    d.k0 = x(0);
    d.k1 = x(1);
    d.k2 = x(2);
    d.k3 = x(3);
    d.p1 = x(4);
    d.p2 = x(5);
    d.b1 = x(6);
    d.b2 = x(7);
    d.t1 = x(8);
    d.t2 = x(9);
    d.s1 = x(10);
    d.s2 = x(11);
    d.q1 = x(12);
    d.q2 = x(13);
    d.k4 = x(14);
    d.k5 = x(15);
  } else {
    // CAHV: the only difference from the pinhole is the exact affinity of H, about (hc, vc).
    d.b1 = 1.0 / cam.h_scale - 1.0;
    d.b2 = -cam.h_shear / cam.h_scale;
  }
  camera = cam;
  return residualOverImage(model, camera, residual);
}

Status photogrammetricToCahvor(const PhotogrammetricCamera& camera, CameraModel& model,
                               ConversionResidual& residual) {
  residual = ConversionResidual{};
  const InteriorOrientation& io = camera.io;
  if (!(io.f_px > 0.0) || io.width <= 0 || io.height <= 0 || !(camera.h_scale > 0.0)) {
    return Status::kInvalidArgument;
  }
  CameraModel out;
  out.type = CameraType::kCahv;
  out.c = camera.eo.centre_m;
  const Vec3 m0 = camera.m.row(0).transpose();
  const Vec3 m1 = camera.m.row(1).transpose();
  out.a = -camera.m.row(2).transpose();
  out.v = io.f_px * (-m1) + io.y0_px * out.a;
  out.h = io.f_px * (camera.h_scale * m0 - camera.h_shear * m1) + io.x0_px * out.a;
  out.width = io.width;
  out.height = io.height;

  // O: the ray of the distortion centre (the image point of the O axis when the camera came from a CAHVOR
  // model; A when no centre was set). R by linear least squares: with O fixed, the CAHVOR projection of
  // the ray p of a pixel d is d exactly when (p + mu lambda) . (H - d_x A) = 0 and the same with V, which
  // is linear in mu = rho0 + rho1 tau + rho2 tau^2 (p scaled to p . A = 1, so the residual is in pixels).
  const LensDistortion& d = io.distortion;
  const bool distorted = d.k0 != 0.0 || d.k1 != 0.0 || d.k2 != 0.0 || d.k3 != 0.0 || d.p1 != 0.0 || d.p2 != 0.0 ||
                         d.t1 != 0.0 || d.t2 != 0.0 || d.s1 != 0.0 || d.s2 != 0.0 || d.q1 != 0.0 || d.q2 != 0.0 || d.k4 != 0.0 || d.k5 != 0.0;
  if (distorted) {
    out.type = CameraType::kCahvor;
    out.o = out.a;
    if (d.cx_px != 0.0 || d.cy_px != 0.0) {
      const Vec3 o = directionOfPinhole(camera, undistortPixel(d, Vec2(d.cx_px, d.cy_px))).normalized();
      if (o.dot(out.a) > 0.5) {
        out.o = o;
      }
    }
    Mat3 normal = Mat3::Zero();
    Vec3 rhs = Vec3::Zero();
    int32_t used = 0;
    for (int32_t j = 0; j < kConversionFitGrid; ++j) {
      for (int32_t i = 0; i < kConversionFitGrid; ++i) {
        const Vec2 pixel(gridCorner(i, kConversionFitGrid, io.width), gridCorner(j, kConversionFitGrid, io.height));
        Vec3 p = directionOfPinhole(camera, undistortPixel(d, pixel));
        const double p_a = p.dot(out.a);
        const double zeta = p.dot(out.o);
        if (!(p_a > 0.0) || !(zeta > 0.0)) continue;
        p /= p_a;
        const Vec3 lambda = p - (zeta / p_a) * out.o;
        const double tau = lambda.squaredNorm() / ((zeta / p_a) * (zeta / p_a));
        const Vec3 gh = out.h - pixel.x() * out.a;
        const Vec3 gv = out.v - pixel.y() * out.a;
        Eigen::Matrix<double, 2, 3> rows;
        const Vec2 l(lambda.dot(gh), lambda.dot(gv));
        rows.col(0) = l;
        rows.col(1) = tau * l;
        rows.col(2) = tau * tau * l;
        const Vec2 target(-p.dot(gh), -p.dot(gv));
        normal.noalias() += rows.transpose() * rows;
        rhs.noalias() += rows.transpose() * target;
        ++used;
      }
    }
    if (used < kMinFitPoints) {
      return Status::kDegenerate;
    }
    const Eigen::LDLT<Mat3> ldlt(normal);
    if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) {
      return Status::kDegenerate;
    }
    out.r = ldlt.solve(rhs);
  }
  const char* field = "";
  const Status valid = validateModel(out, field);
  if (valid != Status::kOk) {
    return valid;
  }
  model = out;
  // Residual: the written model against the photogrammetric projection of the same rays.
  double sum2 = 0.0, max = 0.0;
  int32_t n = 0;
  for (int32_t j = 0; j < kConversionResidualGrid; ++j) {
    for (int32_t i = 0; i < kConversionResidualGrid; ++i) {
      const Vec2 pixel(gridCentre(i, kConversionResidualGrid, io.width), gridCentre(j, kConversionResidualGrid, io.height));
      Vec2 back;
      if (project(model, model.c + directionOfPinhole(camera, undistortPixel(d, pixel)), back) != Status::kOk) {
        continue;
      }
      accumulate((back - pixel).norm(), sum2, max);
      ++n;
    }
  }
  residual.max_px = max;
  finish(sum2, n, residual);
  return Status::kOk;
}

Status photogrammetricToCahvor(const PhotogrammetricCamera& camera, CameraModel& model) {
  ConversionResidual ignored;
  return photogrammetricToCahvor(camera, model, ignored);
}

CameraModel adjustedModel(const CameraModel& apriori, const Mat3& m_old, const Mat3& m_new, const Vec3& centre_new) {
  Mat3 rotation;
  rotation.noalias() = m_new.transpose() * m_old;
  return movedModel(apriori, rotation, centre_new);
}

}  // namespace areomap
