// areomap-camera FILE [--json] [--size W H]: inspect a camera model (JPL text, PDS3 label, M2020 JSON), its
// photogrammetric form and the conversion residual. DESIGN.md "Camera tool".
#include <cmath>
#include <cstdio>
#include <string>

#include <nlohmann/json.hpp>

#include "firmware_core/camera/CameraConversion.hpp"
#include "ground/cli/Cli.hpp"
#include "ground/io/CameraFile.hpp"

namespace {

constexpr const char* kUsage =
    "usage: areomap-camera FILE [--json] [--size W H]\n"
    "\n"
    "Prints the camera model of FILE -- a JPL text model (.cahvor: 'C = x y z' lines), a PDS3 label or\n"
    "image (GEOMETRIC_CAMERA_MODEL as MER writes it, GEOMETRIC_CAMERA_MODEL_PARMS as MSL and Mars 2020 do),\n"
    "a VICAR product (PROPERTY GEOMETRIC_CAMERA_MODEL) or PDS4 label (geom:CAHVORE_Model, ...) read through\n"
    "GDAL, or a Mars 2020 raw-image record (as served: \"camera\" / \"extended\"; or flattened) -- in the\n"
    "frame of the file and in the pixel frame of the delivered image (a model given in full-resolution\n"
    "detector pixels is scaled and shifted to it), its photogrammetric form and the residual of the\n"
    "conversion. The model's reference frame is the label's; a raw-image record does not state it (its\n"
    "models are in the rover navigation frame of its site and drive: printed as implied).\n"
    "\n"
    "M2020 JSON: the delivered image is X.png (.jpg, .pgm, .tif, .IMG, ...) beside X-metadata.json or\n"
    "X.json when there is one (its size wins over the JSON's \"dimension\", with a warning). The model's\n"
    "frame is the one whose principal point fits the image: as given, the metadata's scale_factor from\n"
    "subframe_rect, or 1/1..1/64 of the detector from the subframe origin. When the instrument's detector\n"
    "is known (M2020 Navcam/Hazcam 5120x3840; MER, MSL 1024x1024) the frame that puts the principal point\n"
    "nearest the detector's centre wins; otherwise full frames first, then subframes at the metadata's\n"
    "scale. A model that fits none is an error listing each frame tried.\n"
    "\n"
    "  --json      print one JSON object: reference_frame, reference_frame_stated, acquisition {mission,\n"
    "              instrument, product_id, sol, sclk_s, site, drive, attitude, xyz_m, rover_frame as "
    "given},\n"
    "              model {type, C, A, H, V, O, R, E as present, width, height},\n"
    "              model_in_file (same keys, the file's own pixel frame), scale_to_image {scale,\n"
    "              offset_px, frame}, photogrammetric {f_px, x0_px, y0_px, omega_deg, phi_deg,\n"
    "              kappa_deg, center_m, R_site_to_camera, distortion},\n"
    "              conversion_residual_px {rms, max}\n"
    "  --size W H  image size for a file that gives none (default 1024 1024, with a warning)\n"
    "\n"
    "Conventions: x0_px, y0_px are the principal point in pixel coordinates of the delivered image\n"
    "(sample, line; (0,0) the centre of the first pixel); the oracle convention in mm is\n"
    "x0_mm = (x0_px - width/2) * pixel, y0_mm = -(y0_px - height/2) * pixel. f_px = vs (the line scale; the\n"
    "difference from hs is in the distortion's affinity b1, b2). R_site_to_camera = M = R_kappa R_phi "
    "R_omega,\n"
    "rows = camera x (image right), y (image up), z (backwards, -A) in the model's frame;\n"
    "omega = atan2(-m32, m33), phi = asin(m31), kappa = atan2(-m21, m11). The distortion maps a measured "
    "pixel\n"
    "to the ideal one (firmware_core/camera/Photogrammetric.hpp, LensDistortion). The residual is the "
    "distance\n"
    "between the direct projection of each pixel's ray and its photogrammetric projection over a 32x32 "
    "grid.\n"
    "\n"
    "Exit: 0 ok, 2 usage error, 1 bad file (the message names the file and the field).\n";

using areomap::CameraModel;
using areomap::CameraType;
using nlohmann::json;

json vec(const areomap::Vec3& v) {
  return json::array({v.x(), v.y(), v.z()});
}

const char* typeName(CameraType t) {
  return t == CameraType::kCahv ? "CAHV" : t == CameraType::kCahvor ? "CAHVOR" : "CAHVORE";
}

json modelJson(const CameraModel& m) {
  json j;
  j["type"] = typeName(m.type);
  j["C"] = vec(m.c);
  j["A"] = vec(m.a);
  j["H"] = vec(m.h);
  j["V"] = vec(m.v);
  if (m.type != CameraType::kCahv) {
    j["O"] = vec(m.o);
    j["R"] = vec(m.r);
  }
  if (m.type == CameraType::kCahvore) {
    j["E"] = vec(m.e);
    j["cahvore_type"] = static_cast<int>(m.cahvore_kind);
    j["linearity"] = m.linearity;
  }
  j["width"] = m.width;
  j["height"] = m.height;
  return j;
}

json distortionJson(const areomap::LensDistortion& d) {
  return json{{"cx_px", d.cx_px}, {"cy_px", d.cy_px}, {"norm_px", d.norm_px}, {"k0", d.k0}, {"k1", d.k1},
              {"k2", d.k2},       {"k3", d.k3},       {"k4", d.k4},           {"k5", d.k5}, {"p1", d.p1},
              {"p2", d.p2},       {"b1", d.b1},       {"b2", d.b2},           {"t1", d.t1}, {"t2", d.t2},
              {"s1", d.s1},       {"s2", d.s2},       {"q1", d.q1},           {"q2", d.q2}};
}

void printModel(const char* title, const CameraModel& m) {
  std::printf("%s: %s, %d x %d\n", title, typeName(m.type), m.width, m.height);
  const char* names[] = {"C", "A", "H", "V", "O", "R", "E"};
  const areomap::Vec3* v[] = {&m.c, &m.a, &m.h, &m.v, &m.o, &m.r, &m.e};
  const int n = m.type == CameraType::kCahv ? 4 : m.type == CameraType::kCahvor ? 6 : 7;
  for (int i = 0; i < n; ++i)
    std::printf("  %s = %.10g %.10g %.10g\n", names[i], v[i]->x(), v[i]->y(), v[i]->z());
  if (m.type == CameraType::kCahvore) {
    std::printf("  type %d, linearity %g\n", static_cast<int>(m.cahvore_kind), m.linearity);
  }
}

int run(areomap::cli::Args& args) {
  const bool as_json = args.flag("--json");
  const auto size = args.numbers("--size", 2);
  const std::string path = args.positional(0, "FILE");
  if (args.positionalCount() != 1) throw areomap::cli::UsageError("exactly one FILE expected");
  int width = 0, height = 0;
  if (size) {
    if (!((*size)[0] >= 1.0 && (*size)[1] >= 1.0) || (*size)[0] != std::floor((*size)[0]) ||
        (*size)[1] != std::floor((*size)[1])) {
      throw areomap::cli::UsageError("--size W H: two positive integers expected");
    }
    width = static_cast<int>((*size)[0]);
    height = static_cast<int>((*size)[1]);
  }
  areomap::io::CameraFile file = areomap::io::readCameraFile(path, width, height);
  json warnings = json::array();
  for (const std::string& w : file.warnings) {
    areomap::cli::warn(w);
    warnings.push_back(w);
  }
  if (!file.size_from_file && !size) {
    const std::string w = path + " gives no image size: assuming 1024 x 1024 (use --size W H)";
    areomap::cli::warn(w);
    warnings.push_back(w);
    file = areomap::io::readCameraFile(path, 1024, 1024);
  } else if (file.size_from_file && size) {
    const std::string w = "--size ignored: " + path + " gives the image size";
    areomap::cli::warn(w);
    warnings.push_back(w);
  }
  areomap::PhotogrammetricCamera cam;
  areomap::ConversionResidual res;
  const areomap::Status s = areomap::cahvorToPhotogrammetric(file.model, cam, res);
  if (s != areomap::Status::kOk) {
    throw areomap::cli::InputError(
        path, "model",
        std::string("conversion to the photogrammetric form failed: ") + areomap::statusName(s));
  }
  constexpr double kDeg = 180.0 / M_PI;
  if (as_json) {
    json j;
    j["file"] = path;
    j["format"] = areomap::io::formatName(file.format);
    j["reference_frame"] = file.reference_frame;
    j["reference_frame_stated"] = file.reference_frame_stated;
    const areomap::io::Acquisition& a = file.acquisition;
    json acq{{"mission", areomap::io::missionName(a.mission)},
             {"instrument", a.instrument},
             {"product_id", a.product_id}};
    if (a.sol) acq["sol"] = *a.sol;
    if (a.sclk_s) acq["sclk_s"] = *a.sclk_s;
    if (a.site) acq["site"] = *a.site;
    if (a.drive) acq["drive"] = *a.drive;
    if (a.attitude)
      acq["attitude"] = json::array({(*a.attitude)(0), (*a.attitude)(1), (*a.attitude)(2), (*a.attitude)(3)});
    if (a.xyz_m) acq["xyz_m"] = vec(*a.xyz_m);
    if (!a.rover_frame.empty()) acq["rover_frame"] = a.rover_frame;
    j["acquisition"] = acq;
    j["model"] = modelJson(file.model);
    j["model_in_file"] = modelJson(file.file_model);
    j["scale_to_image"] = json{{"scale", file.scale},
                               {"offset_px", json::array({file.offset_px.x(), file.offset_px.y()})},
                               {"frame", file.frame}};
    json rows = json::array();
    for (int r = 0; r < 3; ++r) rows.push_back(json::array({cam.m(r, 0), cam.m(r, 1), cam.m(r, 2)}));
    j["photogrammetric"] = json{{"f_px", cam.io.f_px},
                                {"x0_px", cam.io.x0_px},
                                {"y0_px", cam.io.y0_px},
                                {"omega_deg", cam.eo.omega_rad * kDeg},
                                {"phi_deg", cam.eo.phi_rad * kDeg},
                                {"kappa_deg", cam.eo.kappa_rad * kDeg},
                                {"center_m", vec(cam.eo.centre_m)},
                                {"R_site_to_camera", rows},
                                {"h_scale", cam.h_scale},
                                {"h_shear", cam.h_shear},
                                {"distortion", distortionJson(cam.io.distortion)}};
    j["conversion_residual_px"] = json{{"rms", res.rms_px}, {"max", res.max_px}, {"points", res.points}};
    j["warnings"] = warnings;
    std::printf("%s\n", j.dump(2).c_str());
    return 0;
  }
  std::printf("file: %s (%s)%s%s%s\n", path.c_str(), areomap::io::formatName(file.format),
              file.reference_frame.empty() ? "" : ", frame ", file.reference_frame.c_str(),
              file.reference_frame.empty() || file.reference_frame_stated
                  ? ""
                  : " (implied: not stated by the file)");
  const areomap::io::Acquisition& a = file.acquisition;
  if (!a.product_id.empty() || a.site) {
    std::printf("acquisition: %s %s %s", areomap::io::missionName(a.mission), a.instrument.c_str(),
                a.product_id.c_str());
    if (a.sol) std::printf(", sol %d", *a.sol);
    if (a.site && a.drive) std::printf(", site %d drive %d", *a.site, *a.drive);
    if (a.sclk_s) std::printf(", sclk %.3f", *a.sclk_s);
    std::printf("\n");
  }
  printModel("model in the file's frame", file.file_model);
  if (file.scale != 1.0 || file.offset_px != areomap::Vec2::Zero()) {
    std::printf("scaled to the delivered image (%s): pixel = (detector - (%g, %g)) / %g\n",
                file.frame.c_str(), file.offset_px.x(), file.offset_px.y(), file.scale);
  } else if (!file.frame.empty()) {
    std::printf("the model is in the delivered image's pixels (%s)\n", file.frame.c_str());
  }
  printModel("model in the delivered image", file.model);
  std::printf("photogrammetric:\n  f = %.6f px, x0 = %.6f px, y0 = %.6f px (sample, line)\n", cam.io.f_px,
              cam.io.x0_px, cam.io.y0_px);
  std::printf("  omega = %.6f deg, phi = %.6f deg, kappa = %.6f deg\n", cam.eo.omega_rad * kDeg,
              cam.eo.phi_rad * kDeg, cam.eo.kappa_rad * kDeg);
  std::printf("  centre = %.6f %.6f %.6f m\n", cam.eo.centre_m.x(), cam.eo.centre_m.y(), cam.eo.centre_m.z());
  for (int r = 0; r < 3; ++r) {
    std::printf("  R_site_to_camera[%d] = %.9f %.9f %.9f\n", r, cam.m(r, 0), cam.m(r, 1), cam.m(r, 2));
  }
  const areomap::LensDistortion& d = cam.io.distortion;
  std::printf(
      "  distortion about (%.3f, %.3f) px, norm %.3f px: k0 %.4g k1 %.4g k2 %.4g k3 %.4g k4 %.4g k5 %.4g\n",
      d.cx_px, d.cy_px, d.norm_px, d.k0, d.k1, d.k2, d.k3, d.k4, d.k5);
  std::printf("    p1 %.4g p2 %.4g b1 %.4g b2 %.4g t1 %.4g t2 %.4g s1 %.4g s2 %.4g q1 %.4g q2 %.4g\n", d.p1,
              d.p2, d.b1, d.b2, d.t1, d.t2, d.s1, d.s2, d.q1, d.q2);
  std::printf("conversion residual (32x32 grid): rms %.4f px, max %.4f px\n", res.rms_px, res.max_px);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return areomap::cli::runTool("areomap-camera", argc, argv, kUsage, run);
}
