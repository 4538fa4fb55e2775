// Test-only generator of a synthetic panoramic stereo network with truth (its own generator, independent of
// the simulator's makeGeometry, so the adjuster is checked against geometry the simulator does not share). A
// rig of two cameras on a mast spins about a gimbal centre (Eq. 3 holds exactly in truth); pairs are taken at
// `azimuths` x `tiers` pointings; tie points are terrain points seen from the left camera on a pixel grid and
// observed in every image that sees them; observations = true ideal pixels + Gaussian noise (+ optional gross
// outliers). The a-priori EO rotates each pair rigidly about the gimbal centre by a random 3-15 px pointing
// error (so it satisfies the constraints, as pointing-derived models do).
#pragma once

#include <cstdint>
#include <vector>

#include "firmware_core/adjust/FastAdjustOptions.hpp"
#include "firmware_core/adjust/Network.hpp"

namespace areomap::test {

struct PanoramaConfig {
  int32_t tiers = 2;
  int32_t azimuths = 10;
  double azimuth_step_deg = 36.0;
  double first_elevation_deg = 20.0;  // below the horizon
  double elevation_step_deg = 25.0;
  int32_t width = 1024;
  int32_t height = 1024;
  double f_px = 1236.0;
  double baseline_m = 0.2;
  double mast_height_m = 1.5;
  int32_t grid = 8;  // tie-point grid per left image (grid x grid)
  double max_range_m = 40.0;
  double noise_px = 0.3;
  double pointing_min_px = 3.0;
  double pointing_max_px = 15.0;
  double outlier_fraction = 0.0;  // gross errors of 10-50 px
  bool single_image = false;      // an extra left-only image (the paper's 64 pairs + 1)
  uint32_t seed = 1;
};

// The rotation (site -> camera, Photogrammetric.hpp axes) of a camera looking at `azimuth_rad` (from +X
// towards +Y) and `elevation_down_rad` below the horizon, image right horizontal.
Mat3 lookRotation(double azimuth_rad, double elevation_down_rad);
// A distortion-free camera of `f_px` with the principal point at the image centre.
InteriorOrientation centredPinhole(double f_px, int32_t width, int32_t height);

PanoramaConfig navcamConfig();
PanoramaConfig impConfig();  // IMP-like: 64 pairs + 1 single image, 256x256, narrow field

struct PanoramaTruth {
  std::vector<Vec3> centres;  // per network image
  std::vector<Mat3> rotations;
  std::vector<Vec3> points;   // per network point
  std::vector<bool> outlier;  // per observation
  Vec3 gimbal_m = Vec3::Zero();
};

// Fills `net` (cleared first) and `truth`. Points are triangulated from the a-priori EO.
void makePanorama(const PanoramaConfig& config, Network& net, PanoramaTruth& truth);

// EO error of the network against truth after removing the best-fit common rotation about the gimbal
// centre (aligned = true) or raw: RMS over images of eoPixelEquivalent at `range_m`; points: RMS 3-D.
struct TruthError {
  double eo_px = 0.0;
  double ground_m = 0.0;
};
TruthError truthError(const Network& net, const PanoramaTruth& truth, bool aligned, double range_m = 5.0);

// The largest EO difference between two networks of the same images, pixel equivalent at `range_m`.
double largestEoDifferencePx(const Network& a, const Network& b, double range_m = 5.0);

// The largest difference of two networks' pair covariances, |a_rc - b_rc| / sqrt(b_rr b_cc).
double largestCovarianceDifference(const Network& a, const Network& b);

// `to` = `from` restarted from the a-priori EO with the same rejection flags, points re-triangulated (the
// start of the integrated adjusters after the fast adjuster's rejection).
void restartFromApriori(const Network& from, Network& to);

// Options for comparing solutions over noise seeds: no robust rejection (the same observations on every
// path and seed), converged far below the noise.
FastAdjustOptions plainFastOptions();

// `net` = `exact` (noise-free observations) with Gaussian noise of each observation's sigma (seeded),
// restarted from the a-priori EO with its points triangulated.
void drawImageNoise(const Network& exact, uint32_t seed, Network& net);

}  // namespace areomap::test
