// A camera model brought from the rover's frame into its site's frame (DESIGN.md: +X north, +Y east,
// +Z down): X_site = R(attitude) X_rover + xyz, where attitude (s, v1, v2, v3) is the unit quaternion that
// the record or label gives for the rover (it takes rover-frame vectors into the site frame, as MIPL writes
// ORIGIN_ROTATION_QUATERNION) and xyz the rover frame's origin in the site frame. C is rotated and shifted;
// A, H, V and O are rotated; R and E (coefficients) are unchanged, so the model projects a site point to
// the same pixel as the rover model projects the same point in the rover frame.
#pragma once

#include <string>

#include <Eigen/Core>

#include "firmware_core/camera/CameraModel.hpp"
#include "ground/io/CameraFile.hpp"

namespace areomap::ingest {

// The rotation matrix of a unit quaternion (s, v1, v2, v3).
Mat3 rotationFromAttitude(const Eigen::Vector4d& attitude);

CameraModel transformedModel(const CameraModel& model, const Mat3& rotation, const Vec3& offset_m);

// The file's model (in the delivered image's pixels) in its site's frame: as it is when its frame is
// SITE_FRAME, transformed when its frame is the rover frame that the file's attitude and xyz place (the raw-
// image record's ROVER_NAV_FRAME; a label's ROVER_COORDINATE_SYSTEM); false and `why` otherwise (a model in
// another frame, or no pose given).
bool modelInSiteFrame(const io::CameraFile& file, CameraModel& out, std::string& why);

}  // namespace areomap::ingest
