// Configuration of the simulator: terrain, camera head, panorama plan, rendering. Presets
// `navcam`, `imp` and `tiny` fill every field; the tool overrides single fields from the command line,
// then validatePlan() rejects what cannot be made (cli::UsageError naming the option).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace areomap::sim {

struct TierPlan {
  double tilt_deg = -25.0;     // head elevation, up positive
  int pairs = 8;               // stereo pairs (or single images) in this tier
  double pan0_deg = 0.0;       // azimuth of the first pair, clockwise from north
  double pan_step_deg = 45.0;  // azimuth step between pairs
  bool left_only = false;      // single left images (IMP's extra frame)
};

// The wavelength of the large-scale swells (SimConfig::max_slope_deg): ridge to ridge, much longer than a
// rover (1-2 m) so that it stands on a plane, about the spacing of sites (10-30 m apart) so that they see
// different slopes.
constexpr double kSlopeWavelengthM = 60.0;
// The steepest large-scale slope a traverse may ask for.
constexpr double kMaxSlopeDeg = 35.0;

struct SimConfig {
  std::string preset = "tiny";
  uint64_t seed = 1;
  int sol = 1;

  // Cameras (identical left and right): delivered size, horizontal field of view, CAHVOR distortion.
  int width = 256;
  int height = 192;
  double hfov_deg = 60.0;
  double rho1 = 0.004;  // CAHVOR R = (0, rho1, rho2)
  double rho2 = -0.002;
  double o_tilt_deg = 0.3;  // angle between O and A

  // Head: camera centres relative to the gimbal in the head frame (x forward, y right, z down) at pan 0,
  // tilt 0; the stereo base is their distance. Small toe-in (each camera yawed inwards).
  double base_m = 0.20;
  double head_forward_m = 0.08;
  double head_up_m = 0.05;
  double toe_in_deg = 0.5;
  double mast_m = 1.5;  // gimbal height above the ground at the rover
  // A FIDO-like mast head: the tilt axis this far ahead of the pan axis (0: the two axes meet at the
  // gimbal centre and Eq. 3 holds). Off it, each tier's camera centres lie on a circle about the pan axis
  // (a virtual spin centre per tier, distances fixed: the FIDO-style constraints) and no fixed camera offset
  // from one gimbal point fits every tilt, so panorama.json gives the stereo base only, as for a rig without
  // a calibration report.
  double tilt_axis_forward_m = 0.0;

  std::vector<TierPlan> tiers;
  double pointing_min_px = 3.0;  // a-priori pointing error per pair (pan/tilt of the head), pixels
  double pointing_max_px = 15.0;

  // Terrain around the rover (site origin): half extent of the square, grid cell, relief and rocks.
  double half_extent_m = 20.0;
  double cell_m = 0.03;
  double relief_m = 0.25;  // RMS of the multi-octave relief
  double rock_k = 0.08;    // Golombek cumulative fractional area of rocks
  double crater_density_per_km2 = 800.0;
  double min_rock_m = 0.06;  // smallest rock diameter near the rover (grows with range)
  // Where the terrain lies (a traverse sets these; one site keeps the defaults): the fine square is centred
  // on terrain_centre_m; the rovers' positions (empty: one rover at the origin) keep rocks and crater walls
  // off the rovers' footprints, and the smallest rock and the fine texture grow with the range from the
  // nearest rover; the coarse grid covers +-cover_half_extent_m about the centre (0:
  // Terrain::kMinCoverHalfM).
  Eigen::Vector2d terrain_centre_m = Eigen::Vector2d::Zero();
  std::vector<Eigen::Vector2d> rover_xy_m;
  double cover_half_extent_m = 0.0;
  // Large-scale slopes (a traverse on sloped ground, --max-slope-deg; 0: none, the terrain as before):
  // concentric swells about slope_centre_m, e(r) = -tan(max_slope) L / (2 pi) cos(2 pi r / L) with
  // L = kSlopeWavelengthM, added to the relief. Their gradient is tan(max_slope) |sin(2 pi r / L)|: at most
  // max_slope, reached on every circle r = L / 4 + k L / 2, smooth at the centre; the downhill direction
  // turns with the azimuth about the centre, so sites along a path stand on different slopes.
  double max_slope_deg = 0.0;
  Eigen::Vector2d slope_centre_m = Eigen::Vector2d::Zero();

  // Rendering.
  int supersample = 2;    // s x s rays per pixel
  double noise_dn = 1.5;  // sensor noise sigma
  double blur_px =
      0.0;  // sigma of a Gaussian optical blur of the rendered image (0 = none), before the noise
  int jpeg_quality = 0;  // 0 = no JPEG round trip
  double sun_azimuth_deg = 120.0;
  double sun_elevation_deg = 40.0;
  bool shadows = true;
  int threads = 0;  // 0 = all cores

  // Truth check points.
  int check_points = 400;  // wanted points seen by two or more images
  double min_range_m = 1.5;
  double max_range_m = 15.0;

  double focalPx() const;  // principal distance from width and hfov
  int pairCount() const;   // all pairs of all tiers
};

// The named presets; throws cli::UsageError for an unknown name.
SimConfig presetConfig(const std::string& name);

// Sets the total pair count over the full-circle tiers (left-only tiers are kept): each tier keeps its
// preset pan step when the pairs no longer close the circle (an arc), else spreads them over 360 degrees.
void setPairCount(SimConfig& config, int pairs);

// Checks that the plan can be made: sizes, field of view, pairs (1..kMaxPairs), no horizontal gap between
// neighbouring pairs of a tier, no vertical gap between tiers, sane terrain and rendering values.
// Throws cli::UsageError naming the option and the reason.
void validatePlan(const SimConfig& config);

}  // namespace areomap::sim
