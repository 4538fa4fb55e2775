// JPL camera models CAHV, CAHVOR and CAHVORE as stateless functions over a parameter struct (after
// COLMAP sensor/models). Site frame (MER: +X north, +Y east, +Z down, metres); image x = sample (column),
// y = line (row), pixels, (0,0) the centre of the first pixel. Equations: shared/reference/camera-models.md;
// the JPL sources (VICAR cmod_cahv.c, cmod_cahvor.c, cmod_cahvore.c) are the authority.
#pragma once

#include <cstddef>
#include <cstdint>

#include "firmware_core/base/EigenTypes.hpp"
#include "firmware_core/base/Status.hpp"

namespace areomap {

enum class CameraType : uint8_t { kCahv = 0, kCahvor = 1, kCahvore = 2 };

// CAHVORE model types (JPL): the linearity parameter L is 1 for perspective, 0 for fisheye, given for
// general.
enum class CahvoreKind : uint8_t { kPerspective = 1, kFisheye = 2, kGeneral = 3 };

// The largest image side a model may declare (width, height): 10^6 px. validateModel and the text reader use
// the same bound, so every valid model can be written and read back (the fuzzer found a model
// of width 1786706496 from a message validated but its text form did not parse).
constexpr int32_t kMaxModelImageSidePx = 1000000;

struct CameraModel {
  CameraType type = CameraType::kCahv;
  Vec3 c = Vec3::Zero();  // camera centre, metres, in the model's reference frame
  Vec3 a = Vec3::Zero();  // unit optical axis
  Vec3 h = Vec3::Zero();  // horizontal image-plane vector, pixels
  Vec3 v = Vec3::Zero();  // vertical image-plane vector, pixels
  Vec3 o = Vec3::Zero();  // CAHVOR/CAHVORE: unit distortion axis
  Vec3 r = Vec3::Zero();  // CAHVOR/CAHVORE: radial terms rho0 rho1 rho2
  Vec3 e = Vec3::Zero();  // CAHVORE: entrance-pupil terms e0 e1 e2
  CahvoreKind cahvore_kind = CahvoreKind::kPerspective;
  double linearity = 1.0;  // CAHVORE L
  int32_t width = 0;       // delivered image size, pixels (0 = unknown)
  int32_t height = 0;
};

// The linearity L of a CAHVORE model (JPL): 1 for type 1 (perspective), 0 for type 2 (fisheye), the model's
// own `linearity` for type 3 (general).
double cahvoreLinearity(const CameraModel& model);

// Checks a model: finite numbers, |A| = 1 (and |O| = 1), H and V not parallel to A, 0 <= sizes <=
// kMaxModelImageSidePx.
// On failure `field` names the offending component ("A", "H", "O", "R", ...).
[[nodiscard]] Status validateModel(const CameraModel& model, const char*& field);

// Projects a site-frame point to a pixel. Returns kBehindCamera for points behind (or on) the camera's
// image plane; `d_pixel_d_point` (optional) receives the 2x3 analytic derivative.
[[nodiscard]] Status project(const CameraModel& model, const Vec3& point, Vec2& pixel,
                             Mat2x3* d_pixel_d_point = nullptr);

// project() of `count` points through one model, without derivatives: the same pixels and statuses as a
// call per point (a pixel is left as it is where its status is not kOk), the model's own terms (CAHVOR's
// unit O) made once instead of per point.
void projectPoints(const CameraModel& model, const Vec3* points, int32_t count, Vec2* pixels, Status* statuses);

// Back-projects a pixel to a unit ray (origin = C for CAHV/CAHVOR; the entrance-pupil point for CAHVORE),
// pointing along +A. Iterative for CAHVOR/CAHVORE with at most kMaxCameraInverseIterations steps.
[[nodiscard]] Status unproject(const CameraModel& model, const Vec2& pixel, Vec3& ray_origin,
                               Vec3& ray_direction);

// The CAHV model of a CAHVOR/CAHVORE model (same C, A, H, V; no distortion), and the exact maps between
// a distorted pixel and the ideal pixel of that CAHV model (distortion depends on ray direction only).
CameraModel linearPart(const CameraModel& model);
[[nodiscard]] Status distortedToIdeal(const CameraModel& model, const Vec2& pixel, Vec2& ideal);
[[nodiscard]] Status idealToDistorted(const CameraModel& model, const Vec2& ideal, Vec2& pixel);

// Moves a model rigidly: every direction vector (A, H, V, O) is rotated by `rotation` (site frame) and the
// centre set to `centre`. This is how an adjusted exterior orientation is written back without loss.
CameraModel movedModel(const CameraModel& model, const Mat3& rotation, const Vec3& centre);

// The JPL text form ("C = x y z" lines; O, R, E, type/parameter and image size as present; other lines
// ignored). parseModelText fills `field` with the name of the offending or missing component on error.
[[nodiscard]] Status parseModelText(const char* text, std::size_t length, CameraModel& model,
                                    const char*& field);
// Writes the text form into `buffer` (NUL-terminated); returns the length, or 0 if it does not fit.
std::size_t formatModelText(const CameraModel& model, char* buffer, std::size_t capacity);

}  // namespace areomap
