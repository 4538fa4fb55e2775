#include "firmware_core/camera/CahvInternal.hpp"

namespace areomap {

CahvInternal cahvInternal(const CameraModel& model) {
  const Vec3& a = model.a;
  CahvInternal in;
  in.hc_px = a.dot(model.h);
  in.vc_px = a.dot(model.v);
  in.hs_px = a.cross(model.h).norm();
  in.vs_px = a.cross(model.v).norm();
  in.h_prime = (model.h - in.hc_px * a) / in.hs_px;
  in.v_prime = (model.v - in.vc_px * a) / in.vs_px;
  return in;
}

}  // namespace areomap
