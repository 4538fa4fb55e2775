// Camera models from files, for the ground side and the tools: the JPL text form (.cahvor, .cahvore, …),
// PDS3 labels (.IMG with an attached label, .LBL; GROUP = GEOMETRIC_CAMERA_MODEL as MER writes it,
// GEOMETRIC_CAMERA_MODEL_PARMS as MSL and Mars 2020 write it, CAHVORE type and parameter as components 8
// and 9), VICAR labels (PROPERTY = 'GEOMETRIC_CAMERA_MODEL') and PDS4 labels (geom:CAHVORE_Model, …) read
// through GDAL (GdalLabel.hpp), and the record of the Mars 2020 raw-image service, as served (the model
// under "camera", the pixel frame under "extended", tuples written as strings) or flattened
// (camera_model_component_list = "C;A;H;V;O;R;E;type;parameter" at the top level).
// The format is told by the content, not the extension. Errors: cli::InputError naming file and field.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "firmware_core/camera/Binning.hpp"
#include "firmware_core/camera/CameraModel.hpp"
#include "ground/io/Detector.hpp"

namespace areomap::io {

class Pds3Label;

enum class CameraFileFormat { kJplText, kPds3, kM2020Json, kVicar, kPds4 };
const char* formatName(CameraFileFormat format);  // "jpl-text", "pds3", "m2020-json", "vicar", "pds4"

// What a record or label says of the exposure and of the rover, where it says it (absent: not given).
struct Acquisition {
  Mission mission = Mission::kUnknown;
  std::string instrument;  // "NAVCAM_LEFT", "NAV_LEFT_B", ... ("" when not given)
  std::string product_id;  // the record's imageid, the label's PRODUCT_ID (else the file's stem)
  std::optional<int> sol;
  std::optional<double> sclk_s;  // spacecraft clock of the exposure, seconds
  std::optional<int> site;       // rover motion counter: site and drive
  std::optional<int> drive;
  // The rover's attitude (s, v1, v2, v3): the rotation that takes rover-frame vectors into the site frame
  // (X_site = R(attitude) X_rover + xyz_m), as MIPL writes ORIGIN_ROTATION_QUATERNION and the raw-image
  // service "attitude".
  std::optional<Eigen::Vector4d> attitude;
  std::optional<Vec3> xyz_m;  // the rover frame's origin in the site frame, metres
  std::string rover_frame;    // the frame that attitude and xyz_m place ("ROVER_FRAME", "ROVER_NAV_FRAME")
  std::optional<double> mast_az_deg;  // the record's mast azimuth and elevation (relative to the rover)
  std::optional<double> mast_el_deg;
};

struct CameraFile {
  CameraFileFormat format = CameraFileFormat::kJplText;
  // The model as the file gives it (detector pixels for a full-resolution M2020 model).
  CameraModel file_model;
  // The model in the pixel frame of the delivered image: pixel = (detector - offset) / scale.
  CameraModel model;
  double scale = 1.0;
  Vec2 offset_px = Vec2::Zero();
  // false: width/height came from the caller's fallback (or are 0); true: from the file or its image.
  bool size_from_file = false;
  // The model's reference frame: the label's REFERENCE_COORD_SYSTEM_NAME ("ROVER_FRAME", "ROVER_NAV_FRAME",
  // "SITE_FRAME", ...; PDS4 its coordinate_space_frame_type), "ROVER_NAV_FRAME" for the M2020 raw-image
  // record (which does not state it: its models are in the rover navigation frame of its site and drive);
  // "" when not known. reference_frame_stated: the file says it.
  std::string reference_frame;
  bool reference_frame_stated = false;
  Acquisition acquisition;
  std::string frame;  // the M2020 model's pixel frame (PixelFrame::name); "" for the other formats
  std::vector<std::string> warnings;  // e.g. the image's size differs from the JSON's "dimension"
};

// Reads a camera file. `width`/`height` are used when the file gives no image size (0 = leave unknown).
// An M2020 JSON X-metadata.json or X.json with an image X.png (.jpg, .pgm, .tif, .IMG, …) beside it takes
// the delivered size from that image's header (it wins over the JSON's "dimension", with a warning); the
// model's pixel frame is then decided by choosePixelFrame (PixelFrame.hpp), and a model that fits no frame
// of the image is an error naming the file, the field and every frame tried.
CameraFile readCameraFile(const std::string& path, int width = 0, int height = 0);
// The model of readCameraFile(path, width, height), in the delivered image's pixel frame; warnings go to
// stderr (cli::warn).
CameraModel readCameraModelFile(const std::string& path, int width = 0, int height = 0);
// The camera file of a known image (a dataset's pair side): for an M2020 JSON, `image_path` is the
// delivered image, `width` x `height` its size (0 x 0: read from its header), whatever the JSON's
// "dimension" says or lies beside it; the other formats read as readCameraFile(path, width, height).
CameraFile readCameraFileForImage(const std::string& path, const std::string& image_path, int width = 0,
                                  int height = 0);
CameraModel readCameraModelForImage(const std::string& path, const std::string& image_path, int width = 0,
                                    int height = 0);
// The image beside an M2020 metadata file (X-metadata.json or X.json -> X.png, X.jpg, …), or "".
std::string imageBeside(const std::string& path);
// Parses text already in memory (`path` names it in errors).
CameraFile parseCameraText(const std::string& text, const std::string& path, int width = 0, int height = 0);
// The GEOMETRIC_CAMERA_MODEL group of a PDS3 label already parsed (label.file() names it in errors).
CameraFile readPds3Camera(const Pds3Label& label, int width = 0, int height = 0);

// Writes the JPL text form (formatModelText) whole or not at all (cli::writeFileAtomic: temporary name,
// fsync, rename; the previous file is kept on failure; the parent folder created); throws cli::InputError
// naming `path` if it cannot. A dataset's models/ and truth/models/ are written and read here.
void writeCameraModelFile(const std::string& path, const CameraModel& model);

// The same camera in a resampled pixel frame (firmware_core/camera/Binning.hpp, shared with the rover).
using ::areomap::rescaledModel;

}  // namespace areomap::io
