// CAHV, CAHVOR and CAHVORE: validation, projection and back-projection, the distortion maps; the text form
// is in CameraModelText.cpp.
#include "firmware_core/camera/CameraModel.hpp"

#include <cmath>

#include "firmware_core/base/Capacities.hpp"

namespace areomap {
namespace {

constexpr double kUnitTolerance = 1e-4;        // |A| and |O| must be 1 within this (labels carry ~6 digits)
constexpr double kParallelTolerance = 1e-6;    // |A x H| / |H| below this: H parallel to A
constexpr double kSmallAngleRad = 1e-8;        // below this a ray is on the O axis (JPL's small-angle branch)
constexpr double kNewtonToleranceRad = 1e-13;  // Newton stop on theta / chi / u steps
constexpr double kNewtonAcceptRad = 1e-9;      // a last step above this is a failure to converge
constexpr double kHalfPi = 1.57079632679489661923;

bool finite3(const Vec3& v) {
  return std::isfinite(v.x()) && std::isfinite(v.y()) && std::isfinite(v.z());
}

bool hasDistortion(const CameraModel& m) {
  return m.type == CameraType::kCahvor || m.type == CameraType::kCahvore;
}

// CAHV projection of a camera-relative vector pp, with d(pixel)/d(pp).
Status projectLinear(const CameraModel& m, const Vec3& pp, Vec2& pixel, Mat2x3* d_pixel_d_pp) {
  const double alpha = pp.dot(m.a);
  if (!(alpha > 0.0)) {
    return Status::kBehindCamera;
  }
  const double x = pp.dot(m.h) / alpha;
  const double y = pp.dot(m.v) / alpha;
  pixel = Vec2(x, y);
  if (d_pixel_d_pp != nullptr) {
    d_pixel_d_pp->row(0) = ((m.h - x * m.a) / alpha).transpose();
    d_pixel_d_pp->row(1) = ((m.v - y * m.a) / alpha).transpose();
  }
  return Status::kOk;
}

// CAHVOR: pp = p + mu * lambda (JPL cmod_cahvor_3d_to_2d), o = the model's O normalised.
Status distortCahvorUnit(const CameraModel& m, const Vec3& o, const Vec3& p, Vec3& pp, Mat3* d_pp_d_p) {
  const double zeta = p.dot(o);
  if (!(zeta > 0.0) || !(p.dot(m.a) > 0.0)) {
    return Status::kBehindCamera;
  }
  const Vec3 lambda = p - zeta * o;
  const double tau = lambda.squaredNorm() / (zeta * zeta);
  const double mu = m.r.x() + m.r.y() * tau + m.r.z() * tau * tau;
  pp = p + mu * lambda;
  if (d_pp_d_p != nullptr) {
    const Mat3 d_lambda = Mat3::Identity() - o * o.transpose();
    // d tau / dp = 2 lambda' / zeta^2 - 2 tau / zeta O'   (lambda . O = 0)
    const Vec3 d_tau = 2.0 * lambda / (zeta * zeta) - (2.0 * tau / zeta) * o;
    const Vec3 d_mu = (m.r.y() + 2.0 * m.r.z() * tau) * d_tau;
    d_pp_d_p->noalias() = Mat3::Identity() + mu * d_lambda + lambda * d_mu.transpose();
  }
  return Status::kOk;
}

// chi(theta) for linearity L, and d chi / d theta.
void chiOfTheta(double linearity, double theta, double& chi, double& d_chi) {
  if (linearity > 0.0) {
    const double c = std::cos(linearity * theta);
    chi = std::tan(linearity * theta) / linearity;
    d_chi = 1.0 / (c * c);
  } else if (linearity < 0.0) {
    chi = std::sin(linearity * theta) / linearity;
    d_chi = std::cos(linearity * theta);
  } else {
    chi = theta;
    d_chi = 1.0;
  }
}

// CAHVORE: solve for the incidence angle theta, then pp = (|lambda| / chi) O + (1 + mu) lambda
// (JPL cmod_cahvore_3d_to_2d).
Status distortCahvore(const CameraModel& m, const Vec3& p, Vec3& pp, Mat3* d_pp_d_p) {
  const Vec3 o = m.o.normalized();  // labels give O to ~6 digits: |O| = 1 +- 1e-6
  const double linearity = cahvoreLinearity(m);
  const double zeta = p.dot(o);
  const Vec3 lambda = p - zeta * o;
  const double l = lambda.norm();
  const double e0 = m.e.x(), e1 = m.e.y(), e2 = m.e.z();
  double theta = std::atan2(l, zeta);
  double f_theta = 1.0;  // dF/dtheta at the solution
  double last_step = 0.0;
  for (int32_t i = 0; i < kMaxCameraInverseIterations; ++i) {
    const double c = std::cos(theta), s = std::sin(theta);
    const double t2 = theta * theta, t4 = t2 * t2;
    const double g = e0 + e1 * t2 + e2 * t4;
    const double dg = 2.0 * e1 * theta + 4.0 * e2 * t2 * theta;
    f_theta = zeta * c + l * s - (1.0 - c) * g - (theta - s) * dg;
    if (f_theta == 0.0 || !std::isfinite(f_theta)) {
      return Status::kDegenerate;
    }
    const double f = zeta * s - l * c - (theta - s) * g;
    last_step = f / f_theta;
    theta -= last_step;
    if (std::fabs(last_step) < kNewtonToleranceRad) {
      break;
    }
  }
  if (!(std::fabs(last_step) < kNewtonAcceptRad)) {
    return Status::kNoConvergence;
  }
  if (theta * std::fabs(linearity) > kHalfPi || !(theta < 2.0 * kHalfPi)) {
    return Status::kBehindCamera;
  }
  const double r0 = m.r.x(), r1 = m.r.y(), r2 = m.r.z();
  if (theta < kSmallAngleRad || l <= 0.0) {
    // On the axis: chi -> theta -> l / zeta, so |lambda| / chi -> zeta.
    if (!(zeta > 0.0)) {
      return Status::kBehindCamera;
    }
    pp = zeta * o + (1.0 + r0) * lambda;
    if (d_pp_d_p != nullptr) {
      d_pp_d_p->noalias() = o * o.transpose() + (1.0 + r0) * (Mat3::Identity() - o * o.transpose());
    }
    return Status::kOk;
  }
  double chi = 0.0, d_chi_d_theta = 1.0;
  chiOfTheta(linearity, theta, chi, d_chi_d_theta);
  const double chi2 = chi * chi;
  const double mu = r0 + r1 * chi2 + r2 * chi2 * chi2;
  const double scale = l / chi;
  pp = scale * o + (1.0 + mu) * lambda;
  if (d_pp_d_p != nullptr) {
    // Implicit function theorem on F(theta, zeta, l) = zeta sin - l cos - (theta - sin) g = 0.
    const Vec3 d_zeta = o;
    const Vec3 d_l = lambda / l;
    const Vec3 d_theta = -(std::sin(theta) * d_zeta - std::cos(theta) * d_l) / f_theta;
    const Vec3 d_chi = d_chi_d_theta * d_theta;
    const Vec3 d_scale = d_l / chi - (l / chi2) * d_chi;
    const Vec3 d_mu = (2.0 * r1 * chi + 4.0 * r2 * chi2 * chi) * d_chi;
    d_pp_d_p->noalias() = o * d_scale.transpose() + lambda * d_mu.transpose() +
                          (1.0 + mu) * (Mat3::Identity() - o * o.transpose());
  }
  return Status::kOk;
}

// The CAHV ray of a pixel, scaled so that ray . A = 1 (JPL: (V - yA) x (H - xA) / (A . (V x H))).
Status linearRay(const CameraModel& m, const Vec2& pixel, Vec3& ray) {
  const double avh = m.a.dot(m.v.cross(m.h));
  if (avh == 0.0 || !std::isfinite(avh)) {
    return Status::kDegenerate;
  }
  ray = (m.v - pixel.y() * m.a).cross(m.h - pixel.x() * m.a) / avh;
  return Status::kOk;
}

// CAHVOR inverse: solve k5 u^5 + k3 u^3 + k1 u = 1 (JPL cmod_cahvor_2d_to_3d) and remove the distortion.
Status undistortCahvorRay(const CameraModel& m, const Vec3& rr, Vec3& direction) {
  const Vec3 o = m.o.normalized();  // labels give O to ~6 digits: |O| = 1 +- 1e-6
  const double omega = rr.dot(o);
  if (!(omega > 0.0)) {
    return Status::kDegenerate;
  }
  const Vec3 lambda = rr - omega * o;
  const double tau = lambda.squaredNorm() / (omega * omega);
  const double k1 = 1.0 + m.r.x();
  const double k3 = m.r.y() * tau;
  const double k5 = m.r.z() * tau * tau;
  double u = 1.0 - (m.r.x() + k3 + k5);
  double du = 1.0;
  for (int32_t i = 0; i < kMaxCameraInverseIterations; ++i) {
    const double u2 = u * u;
    const double poly = ((k5 * u2 + k3) * u2 + k1) * u - 1.0;
    const double deriv = (5.0 * k5 * u2 + 3.0 * k3) * u2 + k1;
    if (!(deriv > 0.0)) {
      return Status::kDegenerate;
    }
    du = poly / deriv;
    u -= du;
    if (std::fabs(du) < kNewtonToleranceRad) {
      break;
    }
  }
  if (!(std::fabs(du) < kNewtonAcceptRad)) {
    return Status::kNoConvergence;
  }
  const Vec3 p = rr - (1.0 - u) * lambda;
  direction = p.normalized();
  return Status::kOk;
}

// CAHVORE inverse (JPL cmod_cahvore_2d_to_3d): chi by Newton, theta from chi, entrance-pupil shift.
Status undistortCahvoreRay(const CameraModel& m, const Vec3& rp, Vec3& origin, Vec3& direction) {
  const Vec3 o = m.o.normalized();  // labels give O to ~6 digits: |O| = 1 +- 1e-6
  const double zeta = rp.dot(o);
  const Vec3 lambda = rp - zeta * o;
  const double l = lambda.norm();
  if (!(zeta > 0.0)) {
    return Status::kDegenerate;
  }
  const double chip = l / zeta;
  if (chip < kSmallAngleRad) {
    origin = m.c;
    direction = o;
    return Status::kOk;
  }
  const double r0 = m.r.x(), r1 = m.r.y(), r2 = m.r.z();
  double chi = chip;
  double dchi = 1.0;
  for (int32_t i = 0; i < kMaxCameraInverseIterations; ++i) {
    const double chi2 = chi * chi, chi4 = chi2 * chi2;
    const double deriv = (1.0 + r0) + 3.0 * r1 * chi2 + 5.0 * r2 * chi4;
    if (deriv == 0.0 || !std::isfinite(deriv)) {
      return Status::kDegenerate;
    }
    dchi = ((1.0 + r0) * chi + r1 * chi2 * chi + r2 * chi4 * chi - chip) / deriv;
    chi -= dchi;
    if (std::fabs(dchi) < kNewtonToleranceRad * std::fmax(1.0, chi)) {
      break;
    }
  }
  if (!(std::fabs(dchi) < kNewtonAcceptRad * std::fmax(1.0, chi))) {
    return Status::kNoConvergence;
  }
  const double linearity = cahvoreLinearity(m);
  const double lin_chi = linearity * chi;
  double theta = chi;
  if (linearity < 0.0) {
    if (std::fabs(lin_chi) > 1.0) {
      return Status::kDegenerate;
    }
    theta = std::asin(lin_chi) / linearity;
  } else if (linearity > 0.0) {
    theta = std::atan(lin_chi) / linearity;
  }
  const double t2 = theta * theta;
  const double s_theta = std::sin(theta);
  const double shift = (theta / s_theta - 1.0) * (m.e.x() + m.e.y() * t2 + m.e.z() * t2 * t2);
  origin = m.c + shift * o;
  direction = (s_theta / l) * lambda + std::cos(theta) * o;
  direction.normalize();
  return Status::kOk;
}

}  // namespace

double cahvoreLinearity(const CameraModel& model) {
  switch (model.cahvore_kind) {
    case CahvoreKind::kPerspective:
      return 1.0;
    case CahvoreKind::kFisheye:
      return 0.0;
    case CahvoreKind::kGeneral:
      return model.linearity;
  }
  return model.linearity;
}

Status validateModel(const CameraModel& model, const char*& field) {
  field = "";
  const Vec3* vectors[] = {&model.c, &model.a, &model.h, &model.v, &model.o, &model.r, &model.e};
  const char* names[] = {"C", "A", "H", "V", "O", "R", "E"};
  const int32_t count = model.type == CameraType::kCahv ? 4 : (model.type == CameraType::kCahvor ? 6 : 7);
  for (int32_t i = 0; i < count; ++i) {
    if (!finite3(*vectors[i])) {
      field = names[i];
      return Status::kNotFinite;
    }
  }
  if (std::fabs(model.a.norm() - 1.0) > kUnitTolerance) {
    field = "A";
    return Status::kInvalidArgument;
  }
  const double h_norm = model.h.norm();
  if (!(h_norm > 0.0) || model.a.cross(model.h).norm() < kParallelTolerance * h_norm) {
    field = "H";
    return Status::kDegenerate;
  }
  const double v_norm = model.v.norm();
  if (!(v_norm > 0.0) || model.a.cross(model.v).norm() < kParallelTolerance * v_norm) {
    field = "V";
    return Status::kDegenerate;
  }
  if (std::fabs(model.a.dot(model.v.cross(model.h))) < kParallelTolerance * h_norm * v_norm) {
    field = "V";  // H and V parallel: no image plane
    return Status::kDegenerate;
  }
  if (hasDistortion(model)) {
    if (std::fabs(model.o.norm() - 1.0) > kUnitTolerance) {
      field = "O";
      return Status::kInvalidArgument;
    }
    if (!(model.o.dot(model.a) > 0.0)) {
      field = "O";  // the distortion axis must point forwards
      return Status::kInvalidArgument;
    }
  }
  if (model.type == CameraType::kCahvore) {
    const bool kind_ok = model.cahvore_kind == CahvoreKind::kPerspective ||
                         model.cahvore_kind == CahvoreKind::kFisheye ||
                         model.cahvore_kind == CahvoreKind::kGeneral;
    if (!kind_ok) {
      field = "type";
      return Status::kInvalidArgument;
    }
    if (!std::isfinite(model.linearity)) {
      field = "parameter";
      return Status::kNotFinite;
    }
  }
  if (model.type != CameraType::kCahv && model.type != CameraType::kCahvor &&
      model.type != CameraType::kCahvore) {
    field = "type";
    return Status::kUnsupported;
  }
  if (model.width < 0 || model.height < 0) {
    field = model.width < 0 ? "width" : "height";
    return Status::kInvalidArgument;
  }
  if (model.width > kMaxModelImageSidePx || model.height > kMaxModelImageSidePx) {
    field = model.width > kMaxModelImageSidePx ? "width" : "height";
    return Status::kCapacityExceeded;
  }
  return Status::kOk;
}

namespace {

// CAHVOR's unit O (the zero vector for the other models, which do not read it).
Vec3 unitO(const CameraModel& model) {
  return model.type == CameraType::kCahvor ? Vec3(model.o.normalized()) : Vec3::Zero();
}

// project() with the model's unitO made by the caller (once for many points).
Status projectUnitO(const CameraModel& model, const Vec3& o_unit, const Vec3& point, Vec2& pixel,
                    Mat2x3* d_pixel_d_point) {
  const Vec3 p = point - model.c;
  if (model.type == CameraType::kCahv) {
    return projectLinear(model, p, pixel, d_pixel_d_point);
  }
  Vec3 pp;
  Mat3 d_pp;
  Mat3* d_pp_ptr = d_pixel_d_point != nullptr ? &d_pp : nullptr;
  const Status s = model.type == CameraType::kCahvor ? distortCahvorUnit(model, o_unit, p, pp, d_pp_ptr)
                                                     : distortCahvore(model, p, pp, d_pp_ptr);
  if (s != Status::kOk) {
    return s;
  }
  if (d_pixel_d_point == nullptr) {
    return projectLinear(model, pp, pixel, nullptr);
  }
  Mat2x3 d_pixel_d_pp;
  const Status s2 = projectLinear(model, pp, pixel, &d_pixel_d_pp);
  if (s2 == Status::kOk) {
    d_pixel_d_point->noalias() = d_pixel_d_pp * d_pp;
  }
  return s2;
}

}  // namespace

Status project(const CameraModel& model, const Vec3& point, Vec2& pixel, Mat2x3* d_pixel_d_point) {
  return projectUnitO(model, unitO(model), point, pixel, d_pixel_d_point);
}

void projectPoints(const CameraModel& model, const Vec3* points, int32_t count, Vec2* pixels, Status* statuses) {
  const Vec3 o = unitO(model);
  for (int32_t i = 0; i < count; ++i) statuses[i] = projectUnitO(model, o, points[i], pixels[i], nullptr);
}

Status unproject(const CameraModel& model, const Vec2& pixel, Vec3& ray_origin, Vec3& ray_direction) {
  Vec3 rr;
  const Status s = linearRay(model, pixel, rr);
  if (s != Status::kOk) {
    return s;
  }
  switch (model.type) {
    case CameraType::kCahv:
      ray_origin = model.c;
      ray_direction = rr.normalized();
      return Status::kOk;
    case CameraType::kCahvor:
      ray_origin = model.c;
      return undistortCahvorRay(model, rr, ray_direction);
    case CameraType::kCahvore:
      return undistortCahvoreRay(model, rr, ray_origin, ray_direction);
  }
  return Status::kUnsupported;
}

CameraModel linearPart(const CameraModel& model) {
  CameraModel m = model;
  m.type = CameraType::kCahv;
  m.o = Vec3::Zero();
  m.r = Vec3::Zero();
  m.e = Vec3::Zero();
  m.cahvore_kind = CahvoreKind::kPerspective;
  m.linearity = 1.0;
  return m;
}

// The distortion maps work on ray directions only: for CAHVORE the entrance-pupil terms E move the ray's
// origin but not its direction, so they do not enter (a point at infinity).
Status distortedToIdeal(const CameraModel& model, const Vec2& pixel, Vec2& ideal) {
  if (model.type == CameraType::kCahv) {
    ideal = pixel;
    return Status::kOk;
  }
  Vec3 origin, direction;
  const Status s = unproject(model, pixel, origin, direction);
  if (s != Status::kOk) {
    return s;
  }
  return projectLinear(model, direction, ideal, nullptr);
}

Status idealToDistorted(const CameraModel& model, const Vec2& ideal, Vec2& pixel) {
  if (model.type == CameraType::kCahv) {
    pixel = ideal;
    return Status::kOk;
  }
  Vec3 rr;
  const Status s = linearRay(model, ideal, rr);
  if (s != Status::kOk) {
    return s;
  }
  CameraModel at_infinity = model;
  at_infinity.e = Vec3::Zero();
  return project(at_infinity, model.c + rr, pixel, nullptr);
}

CameraModel movedModel(const CameraModel& model, const Mat3& rotation, const Vec3& centre) {
  CameraModel m = model;
  m.c = centre;
  m.a.noalias() = rotation * model.a;
  m.h.noalias() = rotation * model.h;
  m.v.noalias() = rotation * model.v;
  m.o.noalias() = rotation * model.o;
  return m;
}

}  // namespace areomap
