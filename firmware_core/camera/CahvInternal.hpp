// The internal parameters of a CAHV model (its linear part; JPL cmod_cahv_internal): with A a unit vector,
// H = hs H' + hc A and V = vs V' + vc A, where H' and V' are unit vectors perpendicular to A. (hc, vc) is
// the principal point, the image point of the axis A, in pixels of the model's frame; hs and vs are the
// focal lengths in pixels along the sample and the line axis. Every user (the photogrammetric conversion,
// rectification, the camera files, the orthoimage) takes them from here.
#pragma once

#include "firmware_core/base/EigenTypes.hpp"
#include "firmware_core/camera/CameraModel.hpp"

namespace areomap {

struct CahvInternal {
  double hc_px = 0.0;
  double vc_px = 0.0;
  double hs_px = 0.0;
  double vs_px = 0.0;
  Vec3 h_prime = Vec3::Zero();  // (H - hc A) / hs
  Vec3 v_prime = Vec3::Zero();  // (V - vc A) / vs
};

// hc = A.H, vc = A.V, hs = |A x H|, vs = |A x V| (for |A| = 1, |A x H| = |H - hc A|). The model must be
// valid (validateModel): H and V not parallel to A, so that hs, vs > 0.
CahvInternal cahvInternal(const CameraModel& model);

}  // namespace areomap
