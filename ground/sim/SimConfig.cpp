#include "ground/sim/SimConfig.hpp"

#include <cmath>
#include <sstream>

#include "firmware_core/base/Capacities.hpp"
#include "ground/cli/Cli.hpp"

namespace areomap::sim {
namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr double kMinOverlapFraction = 0.05;  // neighbours must share at least 5 % of the field of view

[[noreturn]] void planError(const std::string& option, const std::string& what) {
  throw cli::UsageError("impossible plan: " + option + ": " + what);
}

std::string num(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

TierPlan fullTier(double tilt_deg, int pairs) {
  TierPlan t;
  t.tilt_deg = tilt_deg;
  t.pairs = pairs;
  t.pan_step_deg = 360.0 / pairs;
  return t;
}

}  // namespace

double SimConfig::focalPx() const {
  return 0.5 * width / std::tan(0.5 * hfov_deg * kDeg);
}

int SimConfig::pairCount() const {
  int n = 0;
  for (const TierPlan& t : tiers) n += t.pairs;
  return n;
}

SimConfig presetConfig(const std::string& name) {
  SimConfig c;
  c.preset = name;
  if (name == "tiny") {
    c.tiers = {fullTier(-30.0, 8)};
    return c;
  }
  if (name == "navcam") {
    // MER Navcam-like: 1024x1024, 45 degrees, 20 cm base, gimbal ~1.5 m up; one 360-degree tier of 18
    // pairs like the paper's FIDO set.
    c.width = 1024;
    c.height = 1024;
    c.hfov_deg = 45.0;
    c.rho1 = 0.006;
    c.rho2 = -0.004;
    c.base_m = 0.20;
    c.mast_m = 1.5;
    c.tiers = {fullTier(-26.0, 18)};
    c.half_extent_m = 48.0;
    c.cell_m = 0.02;
    c.min_rock_m = 0.05;
    c.check_points = 2500;
    c.min_range_m = 1.5;
    c.max_range_m = 40.0;
    return c;
  }
  if (name == "imp") {
    // Pathfinder IMP-like: 256x256 frames, 14.4 degrees, 15 cm base; upper and lower 360-degree tiers of
    // 32 pairs (64 pairs) plus one single left image looking down: 129 images.
    c.width = 256;
    c.height = 256;
    c.hfov_deg = 14.4;
    c.rho1 = 0.0;
    c.rho2 = 0.0;
    c.o_tilt_deg = 0.1;
    c.base_m = 0.15;
    c.head_forward_m = 0.05;
    c.head_up_m = 0.03;
    c.toe_in_deg = 0.3;
    c.mast_m = 1.5;
    c.tiers = {fullTier(-11.0, 32), fullTier(-23.0, 32)};
    TierPlan single;
    single.tilt_deg = -34.0;
    single.pairs = 1;
    single.pan_step_deg = 0.0;
    single.left_only = true;
    c.tiers.push_back(single);
    c.half_extent_m = 38.0;
    c.cell_m = 0.02;
    c.min_rock_m = 0.05;
    c.check_points = 3000;
    c.min_range_m = 1.5;
    c.max_range_m = 32.0;
    return c;
  }
  if (name == "fido") {
    // FIDO-like: navcam cameras on a mast head whose tilt axis is 10 cm ahead of the pan axis, two
    // 360-degree tiers of 12 pairs; panorama.json has no gimbal centre or camera offsets.
    c = presetConfig("navcam");
    c.preset = name;
    c.tilt_axis_forward_m = 0.10;
    c.tiers = {fullTier(-20.0, 12), fullTier(-42.0, 12)};
    c.half_extent_m = 30.0;
    c.max_range_m = 25.0;
    return c;
  }
  throw cli::UsageError("--preset: unknown preset '" + name + "' (navcam, imp, fido or tiny)");
}

void setPairCount(SimConfig& config, int pairs) {
  std::vector<TierPlan*> full;
  int fixed = 0;
  for (TierPlan& t : config.tiers) {
    if (t.left_only) {
      fixed += t.pairs;
    } else {
      full.push_back(&t);
    }
  }
  const int n_full = static_cast<int>(full.size());
  if (pairs - fixed < n_full || n_full == 0) {
    planError("--pairs", std::to_string(pairs) + " pairs cannot fill " + std::to_string(n_full) + " tier(s)" +
                             (fixed > 0 ? " plus " + std::to_string(fixed) + " single image(s)" : ""));
  }
  const int share = (pairs - fixed) / n_full;
  int extra = (pairs - fixed) % n_full;
  for (TierPlan* t : full) {
    const int n = share + (extra > 0 ? 1 : 0);
    if (extra > 0) --extra;
    const double preset_step = t->pan_step_deg;
    t->pairs = n;
    // Enough pairs to close the circle: spread them; else keep the preset's overlap and make an arc.
    t->pan_step_deg = n * preset_step >= 360.0 - 1e-9 ? 360.0 / n : preset_step;
  }
}

void validatePlan(const SimConfig& c) {
  if (c.width < 16 || c.width > 4096)
    planError("--size", "width " + std::to_string(c.width) + " outside 16..4096");
  if (c.height < 16 || c.height > 4096)
    planError("--size", "height " + std::to_string(c.height) + " outside 16..4096");
  if (!(c.hfov_deg >= 5.0 && c.hfov_deg <= 120.0))
    planError("--fov-deg", num(c.hfov_deg) + " outside 5..120 degrees");
  if (!(std::fabs(c.rho1) <= 0.5 && std::fabs(c.rho2) <= 0.5)) planError("--distortion", "|rho| above 0.5");
  if (c.sol < 0 || c.sol > 100000) planError("--sol", "outside 0..100000");
  if (!(c.base_m > 0.0 && c.base_m <= 2.0)) planError("--base-m", num(c.base_m) + " outside (0, 2] m");
  if (!(c.mast_m >= 0.2 && c.mast_m <= 5.0)) planError("--mast-m", num(c.mast_m) + " outside 0.2..5 m");
  if (!(c.tilt_axis_forward_m >= 0.0 && c.tilt_axis_forward_m <= 0.5)) {
    planError("--tilt-axis-forward-m", num(c.tilt_axis_forward_m) + " outside 0..0.5 m");
  }
  if (!(std::fabs(c.toe_in_deg) <= 10.0)) planError("--toe-in-deg", "more than 10 degrees");
  if (c.tiers.empty()) planError("--tilts", "no tiers");
  const int pairs = c.pairCount();
  if (pairs < 1 || pairs > kMaxPairs) {
    planError("--pairs",
              std::to_string(pairs) + " pairs outside 1.." + std::to_string(kMaxPairs) + " (kMaxPairs)");
  }
  const double f = c.focalPx();
  const double vfov_deg = 2.0 * std::atan(0.5 * c.height / f) / kDeg;
  const TierPlan* previous = nullptr;
  for (std::size_t i = 0; i < c.tiers.size(); ++i) {
    const TierPlan& t = c.tiers[i];
    const std::string tier = "tier " + std::to_string(i);
    if (t.pairs < 1) planError("--pairs", tier + " has no pairs");
    if (!(t.tilt_deg > -89.0 && t.tilt_deg < 60.0))
      planError("--tilts", tier + " tilt " + num(t.tilt_deg) + " outside (-89, 60)");
    if (t.tilt_deg - 0.5 * vfov_deg >= -1.0) {
      planError("--tilts", tier + " at tilt " + num(t.tilt_deg) + " with a " + num(vfov_deg) +
                               "-degree vertical field sees no ground");
    }
    if (t.pairs > 1) {
      if (!(t.pan_step_deg > 0.0)) planError("--pan-step-deg", tier + ": pan step must be positive");
      if (t.pan_step_deg > (1.0 - kMinOverlapFraction) * c.hfov_deg) {
        planError("--pan-step-deg", tier + ": pan step " + num(t.pan_step_deg) +
                                        " degrees leaves less than " + num(100 * kMinOverlapFraction) +
                                        " % overlap with a " + num(c.hfov_deg) +
                                        "-degree field (more pairs or a wider field needed)");
      }
      if (t.pairs * t.pan_step_deg > 360.0 + t.pan_step_deg - 1e-9) {
        planError("--pairs", tier + ": " + std::to_string(t.pairs) + " pairs at " + num(t.pan_step_deg) +
                                 " degrees go round more than once");
      }
    }
    if (!t.left_only) {
      if (previous != nullptr &&
          std::fabs(previous->tilt_deg - t.tilt_deg) > (1.0 - kMinOverlapFraction) * vfov_deg) {
        planError("--tilts", tier + ": tilt step " + num(std::fabs(previous->tilt_deg - t.tilt_deg)) +
                                 " degrees leaves a vertical gap with a " + num(vfov_deg) + "-degree field");
      }
      previous = &t;
    }
  }
  if (!(c.pointing_min_px >= 0.0 && c.pointing_max_px >= c.pointing_min_px && c.pointing_max_px <= 500.0)) {
    planError("--pointing-error-px", "need 0 <= MIN <= MAX <= 500");
  }
  if (!(c.half_extent_m >= 5.0 && c.half_extent_m <= 500.0))
    planError("--extent-m", num(c.half_extent_m) + " outside 5..500 m");
  if (!(c.cell_m >= 0.005 && c.cell_m <= 0.5)) planError("--cell-m", num(c.cell_m) + " outside 0.005..0.5 m");
  if (2.0 * c.half_extent_m / c.cell_m > 12000.0) {
    planError("--cell-m",
              "terrain grid larger than 12000 x 12000 cells (" + num(2.0 * c.half_extent_m / c.cell_m) + ")");
  }
  if (!(c.relief_m >= 0.0 && c.relief_m <= 5.0)) planError("--relief-m", "outside 0..5 m");
  if (!(c.max_slope_deg >= 0.0 && c.max_slope_deg <= kMaxSlopeDeg))
    planError("--max-slope-deg", num(c.max_slope_deg) + " outside 0.." + num(kMaxSlopeDeg) + " degrees");
  if (!(c.rock_k >= 0.0 && c.rock_k <= 0.5)) planError("--rock-k", "outside 0..0.5");
  if (!(c.min_rock_m > 0.0)) planError("--min-rock-m", "must be positive");
  if (c.supersample < 1 || c.supersample > 4) planError("--supersample", "outside 1..4");
  if (!(c.noise_dn >= 0.0 && c.noise_dn <= 50.0)) planError("--noise-dn", "outside 0..50");
  if (!(c.blur_px >= 0.0 && c.blur_px <= 20.0)) planError("--blur-px", "outside 0..20 (0 = none)");
  if (c.jpeg_quality < 0 || c.jpeg_quality > 100) planError("--jpeg-quality", "outside 0..100 (0 = none)");
  if (!(c.sun_elevation_deg > 0.0 && c.sun_elevation_deg <= 90.0))
    planError("--sun-el-deg", "outside (0, 90]");
  if (c.check_points < 0 || c.check_points > 200000) planError("--check-points", "outside 0..200000");
  if (!(c.min_range_m > 0.0 && c.max_range_m > c.min_range_m)) planError("--range-m", "need 0 < MIN < MAX");
  if (c.threads < 0 || c.threads > 256) planError("--threads", "outside 0..256");
}

}  // namespace areomap::sim
