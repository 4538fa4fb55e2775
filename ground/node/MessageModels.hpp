// Camera models between the LCM message form (msgs/camera_model_t.lcm) and firmware_core/camera.
#pragma once

#include "areomap/camera_model_t.hpp"
#include "firmware_core/camera/CameraModel.hpp"

namespace areomap::ground {

// kInvalidArgument for an unknown type code (then `model` is left as it was).
[[nodiscard]] Status modelFromMessage(const camera_model_t& message, CameraModel& model);
camera_model_t messageFromModel(const CameraModel& model);

}  // namespace areomap::ground
