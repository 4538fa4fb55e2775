// Synthetic camera models for the firmware camera tests, built from stated parameters (focal length,
// principal point, pointing, distortion-axis tilt, R, E) with magnitudes like the real MER/M2020 models
// in ../shared/data (those are tested through ground/io in tests/ground/io). No data is copied here.
#pragma once

#include <array>
#include <cmath>

#include "firmware_core/camera/CameraModel.hpp"
#include "firmware_core/camera/Photogrammetric.hpp"

namespace areomap::test {

struct NamedModel {
  const char* name;
  CameraModel model;
};

struct ModelSpec {
  double hs, vs, hc, vc;   // pixels
  double shear_rad;        // H' tilted towards V' by this angle (non-orthogonal H, V)
  double omega, phi, kappa;
  double o_tilt_rad;       // angle between O and A
  Vec3 r;                  // rho0 rho1 rho2
  int32_t width, height;
};

// M = [H'; -V'; -A] as in Photogrammetric.hpp: A = -row 2, H' = row 0, V' = -row 1.
inline CameraModel modelFromSpec(const ModelSpec& s, const Vec3& c) {
  const Mat3 m = rotationFromOpk(s.omega, s.phi, s.kappa);
  const Vec3 a = -m.row(2).transpose();
  const Vec3 v_prime = -m.row(1).transpose();
  const Vec3 h_prime = (std::cos(s.shear_rad) * m.row(0).transpose() + std::sin(s.shear_rad) * v_prime);
  CameraModel model;
  model.type = CameraType::kCahvor;
  model.c = c;
  model.a = a;
  model.h = s.hs * h_prime + s.hc * a;
  model.v = s.vs * v_prime + s.vc * a;
  // O: A tilted about an axis between H' and V'.
  const Vec3 axis = (0.6 * h_prime + 0.8 * v_prime).normalized();
  model.o = Eigen::AngleAxisd(s.o_tilt_rad, axis).toRotationMatrix() * a;
  model.r = s.r;
  model.width = s.width;
  model.height = s.height;
  return model;
}

// A MER Navcam-like CAHVOR: f ~1223 px, O 0.8 deg off A, R like the Opportunity label.
inline CameraModel navcamLike() {
  return modelFromSpec({1223.3, 1223.7, 500.75, 502.8, 0.0002, 1.3, -0.35, 0.4, 0.8 * M_PI / 180.0,
                        Vec3(0.00096, -0.002183, 0.018547), 1024, 1024},
                       Vec3(0.44, -0.06, -1.25));
}

// A CAHVOR whose O is 7.5 deg off A (like Spirit's left Navcam) with non-orthogonal H, V.
inline CameraModel tiltedAxis() {
  return modelFromSpec({1240.0, 1235.0, 520.0, 490.0, 0.003, -0.4, 0.9, 2.6, 7.5 * M_PI / 180.0,
                        Vec3(0.019876, -0.014281, 0.020876), 1024, 1024},
                       Vec3(0.39, -0.06, -1.24));
}

// An M2020 Navcam-like CAHVORE (the real frame's model scaled 1/4 to its 1288 x 968 browse image).
inline CameraModel m2020Like(CahvoreKind kind, double linearity) {
  CameraModel model = modelFromSpec({740.0, 740.3, 648.0, 485.0, 0.0005, 0.1, 1.0, -0.3, 0.1 * M_PI / 180.0,
                                     Vec3(0.0000017, 0.0501396, -0.0171254), 1288, 968},
                                    Vec3(0.95, 0.35, -1.89));
  model.type = CameraType::kCahvore;
  model.cahvore_kind = kind;
  model.linearity = linearity;
  model.e = Vec3(-8e-9, 1e-8, -2.9e-8);  // the real frame's magnitudes
  return model;
}

// A CAHVORE whose entrance pupil moves by millimetres (E much larger than real), to exercise E.
inline CameraModel largePupilShift() {
  CameraModel model = m2020Like(CahvoreKind::kGeneral, 0.6);
  model.e = Vec3(-0.002, 0.004, -0.003);
  return model;
}

inline std::array<NamedModel, 6> syntheticModels() {
  return {NamedModel{"navcam-like CAHVOR", navcamLike()}, NamedModel{"tilted-O CAHVOR", tiltedAxis()},
          NamedModel{"CAHVORE fisheye", m2020Like(CahvoreKind::kFisheye, 0.0)},
          NamedModel{"CAHVORE general L=0.4", m2020Like(CahvoreKind::kGeneral, 0.4)},
          NamedModel{"CAHVORE perspective", m2020Like(CahvoreKind::kPerspective, 1.0)},
          NamedModel{"CAHVORE large E", largePupilShift()}};
}

// Relative difference with a floor of 1, for comparing analytic and numeric derivatives.
inline double relErr(double a, double b) {
  return std::fabs(a - b) / std::fmax(1.0, std::fmax(std::fabs(a), std::fabs(b)));
}

}  // namespace areomap::test
