#include "ground/ingest/SiteFrame.hpp"

#include <Eigen/Geometry>

namespace areomap::ingest {

Mat3 rotationFromAttitude(const Eigen::Vector4d& attitude) {
  const Eigen::Quaterniond q(attitude(0), attitude(1), attitude(2), attitude(3));
  return q.normalized().toRotationMatrix();
}

CameraModel transformedModel(const CameraModel& model, const Mat3& rotation, const Vec3& offset_m) {
  CameraModel m = model;
  m.c = rotation * model.c + offset_m;
  m.a = rotation * model.a;
  m.h = rotation * model.h;
  m.v = rotation * model.v;
  m.o = rotation * model.o;
  return m;
}

bool modelInSiteFrame(const io::CameraFile& file, CameraModel& out, std::string& why) {
  const std::string& frame = file.reference_frame;
  const io::Acquisition& a = file.acquisition;
  if (frame == "SITE_FRAME") {
    out = file.model;
    return true;
  }
  if (frame.empty()) {
    why = "the file does not say the model's frame";
    return false;
  }
  if (a.rover_frame.empty() || frame != a.rover_frame) {
    why = "the model is in " + frame + ", which the file does not place in the site frame" +
          (a.rover_frame.empty() ? std::string(" (it gives no rover pose)")
                                 : " (it gives the pose of " + a.rover_frame + " only)");
    return false;
  }
  if (!a.attitude || !a.xyz_m) {
    why = "the model is in " + frame + " and the file gives no " + (a.attitude ? "xyz" : "attitude") +
          " to bring it to the site frame";
    return false;
  }
  out = transformedModel(file.model, rotationFromAttitude(*a.attitude), *a.xyz_m);
  return true;
}

}  // namespace areomap::ingest
