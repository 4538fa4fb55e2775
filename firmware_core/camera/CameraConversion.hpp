// Conversion between the JPL models (CAHV, CAHVOR, CAHVORE) and the paper's photogrammetric model
// (Di & Li 2004, JGR 109 E04004; Di, Xu, Li §3.1). No heap, no exceptions; fixed-size normal equations.
//
// Conventions (see Photogrammetric.hpp for the rotation and collinearity):
// - Rotation: M = [m0; m1; m2] site -> camera with m2 = -A, m1 = -V' (V' = (V - vc A) / vs) and
//   m0 = m1 x m2 (= H' when H is orthogonal to V). The camera's line axis is kept exact, so that the part
//   of H that a square-pixel pinhole cannot hold (hs != vs, H not orthogonal to V) lies in x only:
//   it is carried exactly by h_scale and h_shear below, and absorbed by the affinity b1, b2 of the fitted
//   image-space distortion. Angles: omega = atan2(-m32, m33), phi = asin(m31), kappa = atan2(-m21, m11).
// - Interior orientation: f = vs (pixels), principal point (x0, y0) = (hc, vc) in pixel coordinates
//   (sample, line) of the delivered image. Di & Li take f = hs; the two differ by |hs - vs| (0.4 px on a
//   MER Navcam). In the oracle's convention (mm, origin at the image centre, y up):
//   x0_mm = (x0_px - cols/2) * pixel, y0_mm = -(y0_px - rows/2) * pixel.
// - Distortion: fitted by least squares over a 33 x 33 grid of the whole image, centred on the image point
//   of the O axis (terms k0..k3, p1, p2, b1, b2, t1, t2 of LensDistortion; norm_px = f); its residual is
//   measured over a 32 x 32 grid of cell centres as the distance between the direct model projection of a
//   pixel's ray and the photogrammetric projection (collinearity then distortPixel) of the same ray.
// - Exact route for the adjuster: pixelToIdeal maps a measured pixel to the ideal pixel of the
//   photogrammetric camera through the model's own inverse (no polynomial), so that
//   collinearity(cam.io, cam.eo.centre_m, cam.m, P) == pixelToIdeal(project(model, P)) exactly for CAHV and
//   CAHVOR (and CAHVORE with E = 0; with E != 0 the entrance pupil moves along O by under
//   (theta / sin theta - 1) |E| metres, which is below 1e-6 px for real M2020 models at 1 m and more).
#pragma once

#include "firmware_core/base/EigenTypes.hpp"
#include "firmware_core/base/Status.hpp"
#include "firmware_core/camera/CameraModel.hpp"
#include "firmware_core/camera/Photogrammetric.hpp"

namespace areomap {

struct PhotogrammetricCamera {
  InteriorOrientation io;
  ExteriorOrientation eo;
  Mat3 m = Mat3::Identity();  // site -> camera, rows = camera x, y, z axes in the model's frame
  // The CAHV horizontal vector relative to the pinhole: CAHV ideal sample - x0 =
  // h_scale * (pinhole sample - x0) + h_shear * (pinhole line - y0); 1 and 0 for a camera with square
  // pixels and orthogonal H, V. photogrammetricToCahvor uses them to write H back exactly.
  double h_scale = 1.0;
  double h_shear = 0.0;
};

struct ConversionResidual {
  double rms_px = 0.0;
  double max_px = 0.0;
  int32_t points = 0;  // grid points that entered (pixels whose rays project)
};

// Number of grid points per axis of the residual (cell centres) and of the fit (cell corners).
constexpr int32_t kConversionResidualGrid = 32;
constexpr int32_t kConversionFitGrid = 33;

// CAHV/CAHVOR/CAHVORE -> photogrammetric. Needs model.width/height > 0 (field "width"/"height").
[[nodiscard]] Status cahvorToPhotogrammetric(const CameraModel& model, PhotogrammetricCamera& camera,
                                             ConversionResidual& residual);

// Photogrammetric -> CAHVOR (CAHV when the distortion is zero): C, A, H, V from f, x0, y0, h_scale,
// h_shear and the EO; O = the ray of the distortion centre (A if none is set) and R fitted by linear least
// squares to the image-space distortion over the image;
// `residual` compares the written model with the photogrammetric projection over the 32 x 32 grid.
[[nodiscard]] Status photogrammetricToCahvor(const PhotogrammetricCamera& camera, CameraModel& model,
                                             ConversionResidual& residual);
// The same without the residual (the lead's original signature).
[[nodiscard]] Status photogrammetricToCahvor(const PhotogrammetricCamera& camera, CameraModel& model);

// The exact observation maps of the adjuster (see the header comment).
[[nodiscard]] Status pixelToIdeal(const CameraModel& model, const PhotogrammetricCamera& camera,
                                  const Vec2& pixel, Vec2& ideal);
[[nodiscard]] Status idealToPixel(const CameraModel& model, const PhotogrammetricCamera& camera,
                                  const Vec2& ideal, Vec2& pixel);

// An adjusted model written back without loss: the a-priori model moved rigidly by the change of the
// site -> camera rotation (M_new^T M_old) to the new centre.
CameraModel adjustedModel(const CameraModel& apriori, const Mat3& m_old, const Mat3& m_new, const Vec3& centre_new);

// Projection of a site point through the photogrammetric camera with its fitted distortion (collinearity,
// then distortPixel): the pixel that the converted model predicts.
[[nodiscard]] Status projectPhotogrammetric(const PhotogrammetricCamera& camera, const Vec3& point, Vec2& pixel);

}  // namespace areomap
