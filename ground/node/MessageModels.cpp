#include "ground/node/MessageModels.hpp"

namespace areomap::ground {
namespace {

Vec3 vec(const double (&v)[3]) { return Vec3(v[0], v[1], v[2]); }
void put(const Vec3& v, double (&out)[3]) {
  for (int i = 0; i < 3; ++i) out[i] = v[i];
}

}  // namespace

Status modelFromMessage(const camera_model_t& message, CameraModel& model) {
  CameraModel m;
  switch (message.type) {
    case camera_model_t::TYPE_CAHV: m.type = CameraType::kCahv; break;
    case camera_model_t::TYPE_CAHVOR: m.type = CameraType::kCahvor; break;
    case camera_model_t::TYPE_CAHVORE: m.type = CameraType::kCahvore; break;
    default: return Status::kInvalidArgument;
  }
  m.c = vec(message.c_m);
  m.a = vec(message.a);
  m.h = vec(message.h_px);
  m.v = vec(message.v_px);
  m.o = vec(message.o);
  m.r = vec(message.r);
  m.e = vec(message.e);
  switch (message.cahvore_kind) {
    case camera_model_t::CAHVORE_FISHEYE: m.cahvore_kind = CahvoreKind::kFisheye; break;
    case camera_model_t::CAHVORE_GENERAL: m.cahvore_kind = CahvoreKind::kGeneral; break;
    default: m.cahvore_kind = CahvoreKind::kPerspective; break;
  }
  m.linearity = message.linearity;
  m.width = message.width_px;
  m.height = message.height_px;
  model = m;
  return Status::kOk;
}

camera_model_t messageFromModel(const CameraModel& model) {
  camera_model_t m{};
  m.type = model.type == CameraType::kCahv     ? camera_model_t::TYPE_CAHV
           : model.type == CameraType::kCahvor ? camera_model_t::TYPE_CAHVOR
                                               : camera_model_t::TYPE_CAHVORE;
  put(model.c, m.c_m);
  put(model.a, m.a);
  put(model.h, m.h_px);
  put(model.v, m.v_px);
  put(model.o, m.o);
  put(model.r, m.r);
  put(model.e, m.e);
  m.cahvore_kind = model.type != CameraType::kCahvore ? camera_model_t::CAHVORE_INVALID
                   : model.cahvore_kind == CahvoreKind::kFisheye ? camera_model_t::CAHVORE_FISHEYE
                   : model.cahvore_kind == CahvoreKind::kGeneral ? camera_model_t::CAHVORE_GENERAL
                                                                 : camera_model_t::CAHVORE_PERSPECTIVE;
  m.linearity = model.linearity;
  m.width_px = model.width;
  m.height_px = model.height;
  return m;
}

}  // namespace areomap::ground
