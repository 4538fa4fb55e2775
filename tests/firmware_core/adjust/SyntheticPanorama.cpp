#include "tests/firmware_core/adjust/SyntheticPanorama.hpp"

#include <cmath>
#include <random>

#include "firmware_core/adjust/Datum.hpp"
#include "firmware_core/adjust/FastAdjuster.hpp"

namespace areomap::test {

namespace {

constexpr double kPi = 3.14159265358979323846;

double terrainZ(double x, double y) {
  // Gentle undulations about Z = 0 (site frame, +Z down).
  return 0.15 * std::sin(0.7 * x) * std::cos(0.5 * y) + 0.05 * std::sin(2.3 * x + 1.1 * y);
}

bool intersectTerrain(const Vec3& origin, const Vec3& dir, double max_range, Vec3& hit) {
  if (dir.z() <= 1e-3) return false;
  double t = (0.0 - origin.z()) / dir.z();
  for (int i = 0; i < 30; ++i) {
    const Vec3 p = origin + t * dir;
    const double f = p.z() - terrainZ(p.x(), p.y());
    if (std::fabs(f) < 1e-10) break;
    const double h = 1e-6;
    const Vec3 p2 = origin + (t + h) * dir;
    const double f2 = p2.z() - terrainZ(p2.x(), p2.y());
    const double df = (f2 - f) / h;
    if (std::fabs(df) < 1e-12) return false;
    t -= f / df;
  }
  hit = origin + t * dir;
  return t > 0.5 && t < max_range && std::fabs(hit.z() - terrainZ(hit.x(), hit.y())) < 1e-8;
}

}  // namespace

Mat3 lookRotation(double azimuth_rad, double elevation_down_rad) {
  const Vec3 d(std::cos(elevation_down_rad) * std::cos(azimuth_rad),
               std::cos(elevation_down_rad) * std::sin(azimuth_rad), std::sin(elevation_down_rad));
  const Vec3 z = -d;
  const Vec3 x(-std::sin(azimuth_rad), std::cos(azimuth_rad), 0.0);
  const Vec3 y = z.cross(x);
  Mat3 m;
  m.row(0) = x.transpose();
  m.row(1) = y.transpose();
  m.row(2) = z.transpose();
  return m;
}

InteriorOrientation centredPinhole(double f_px, int32_t width, int32_t height) {
  InteriorOrientation io;
  io.f_px = f_px;
  io.x0_px = 0.5 * (width - 1);
  io.y0_px = 0.5 * (height - 1);
  io.width = width;
  io.height = height;
  return io;
}

PanoramaConfig navcamConfig() {
  return PanoramaConfig{};
}

PanoramaConfig impConfig() {
  PanoramaConfig c;
  c.tiers = 4;
  c.azimuths = 16;
  c.azimuth_step_deg = 12.0;
  c.first_elevation_deg = 12.0;
  c.elevation_step_deg = 11.0;
  c.width = 256;
  c.height = 256;
  c.f_px = 1000.0;
  c.baseline_m = 0.15;
  c.mast_height_m = 1.2;
  c.grid = 4;
  c.max_range_m = 30.0;
  c.single_image = true;
  return c;
}

void makePanorama(const PanoramaConfig& cfg, Network& net, PanoramaTruth& truth) {
  net.clear();
  truth = PanoramaTruth{};
  std::mt19937 rng(cfg.seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::uniform_real_distribution<double> uni(0.0, 1.0);

  const Vec3 gimbal(0.0, 0.0, -cfg.mast_height_m);
  truth.gimbal_m = gimbal;
  const Vec3 left_offset(-0.5 * cfg.baseline_m, 0.02, 0.03);
  const Vec3 right_offset(0.5 * cfg.baseline_m, 0.02, 0.03);
  // A small toe-in of the right camera: M_R = toe * M_L.
  const Mat3 toe = rotationFromVector(Vec3(0.0, 0.004, 0.001));

  RigConstraints& rig = net.rig;
  rig = RigConstraints{};
  rig.gimbal_m[0] = gimbal;
  rig.gimbal_set[0] = true;
  rig.left_offset_m = left_offset;
  rig.right_offset_m = right_offset;

  const InteriorOrientation io = centredPinhole(cfg.f_px, cfg.width, cfg.height);

  const int32_t n_pairs = cfg.tiers * cfg.azimuths + (cfg.single_image ? 1 : 0);
  for (int32_t p = 0; p < n_pairs; ++p) {
    const bool single = p == cfg.tiers * cfg.azimuths;
    const int32_t tier = single ? 0 : p / cfg.azimuths;
    const int32_t az = single ? cfg.azimuths : p % cfg.azimuths;
    const Mat3 ml = lookRotation(az * cfg.azimuth_step_deg * kPi / 180.0,
                                 (cfg.first_elevation_deg + tier * cfg.elevation_step_deg) * kPi / 180.0);
    const Mat3 mr = toe * ml;
    const Vec3 cl = gimbal + ml.transpose() * left_offset;
    const Vec3 cr = gimbal + mr.transpose() * right_offset;
    if (p == 0) rig.base_m = ml * (cr - cl);
    // Pointing error: a rigid rotation of the pair about the gimbal centre, 3-15 px.
    Vec3 axis(gauss(rng), gauss(rng), gauss(rng));
    axis.normalize();
    const double err_px = cfg.pointing_min_px + (cfg.pointing_max_px - cfg.pointing_min_px) * uni(rng);
    const Mat3 q = rotationFromVector(axis * (err_px / cfg.f_px));
    const Mat3 ml_ap = ml * q.transpose();
    const Mat3 mr_ap = mr * q.transpose();
    const Vec3 cl_ap = gimbal + q * (cl - gimbal);
    const Vec3 cr_ap = gimbal + q * (cr - gimbal);
    int32_t index = 0;
    const Status s = net.addPair(0, tier, io, cl_ap, ml_ap, single ? nullptr : &io, cr_ap, mr_ap, index);
    (void)s;
    truth.centres.push_back(cl);
    truth.rotations.push_back(ml);
    if (!single) {
      truth.centres.push_back(cr);
      truth.rotations.push_back(mr);
    }
  }
  // Tie points from a grid in each left image.
  for (int32_t p = 0; p < net.pairCount(); ++p) {
    const int32_t li = net.pair(p).left;
    for (int32_t gy = 0; gy < cfg.grid; ++gy) {
      for (int32_t gx = 0; gx < cfg.grid; ++gx) {
        const Vec2 px((gx + 0.3 + 0.4 * uni(rng)) * cfg.width / cfg.grid,
                      (gy + 0.3 + 0.4 * uni(rng)) * cfg.height / cfg.grid);
        const Vec3 ray = rayOfIdealPixel(io, truth.rotations[li], px);
        Vec3 xyz;
        if (!intersectTerrain(truth.centres[li], ray, cfg.max_range_m, xyz)) continue;
        // Observed in every image that sees it.
        int32_t seen[kMaxObsPerPoint];
        Vec2 pix[kMaxObsPerPoint];
        int32_t n = 0;
        for (int32_t i = 0; i < net.imageCount() && n < kMaxObsPerPoint; ++i) {
          Vec2 q;
          if (!ok(collinearity(io, truth.centres[i], truth.rotations[i], xyz, q))) continue;
          if (q.x() < 0.0 || q.y() < 0.0 || q.x() > cfg.width - 1 || q.y() > cfg.height - 1) continue;
          seen[n] = i;
          pix[n] = q;
          ++n;
        }
        if (n < 2) continue;
        int32_t point = 0;
        if (!ok(net.addPoint(xyz, point))) return;
        truth.points.push_back(xyz);
        for (int32_t k = 0; k < n; ++k) {
          Vec2 obs = pix[k] + cfg.noise_px * Vec2(gauss(rng), gauss(rng));
          bool outlier = false;
          if (uni(rng) < cfg.outlier_fraction) {
            const double a = 2.0 * kPi * uni(rng);
            obs += (10.0 + 40.0 * uni(rng)) * Vec2(std::cos(a), std::sin(a));
            outlier = true;
          }
          if (ok(net.addObservation(point, seen[k], obs, cfg.noise_px > 0.0 ? cfg.noise_px : 0.3)))
            truth.outlier.push_back(outlier);
        }
      }
    }
  }
  int32_t failed = 0;
  (void)net.triangulateAll(failed);
}

TruthError truthError(const Network& net, const PanoramaTruth& truth, bool aligned, double range_m) {
  const TruthErrors e = truthErrors(net, truth.centres.data(), truth.rotations.data(), truth.points.data(),
                                    truth.gimbal_m, aligned, range_m);
  return TruthError{e.eo_px, e.ground_m};
}

double largestEoDifferencePx(const Network& a, const Network& b, double range_m) {
  double d = 0.0;
  for (int32_t i = 0; i < a.imageCount(); ++i) {
    d = std::fmax(d, eoPixelEquivalent(a.image(i).io.f_px, a.image(i).centre_m - b.image(i).centre_m,
                                       rotationAngle(a.image(i).m, b.image(i).m), range_m));
  }
  return d;
}

double largestCovarianceDifference(const Network& a, const Network& b) {
  double worst = 0.0;
  for (int32_t p = 0; p < a.pairCount(); ++p) {
    const Mat12& x = a.pair(p).covariance;
    const Mat12& y = b.pair(p).covariance;
    for (int r = 0; r < 12; ++r) {
      for (int c = 0; c < 12; ++c) {
        const double scale = std::sqrt(std::fabs(y(r, r) * y(c, c)));
        if (scale > 0.0) worst = std::fmax(worst, std::fabs(x(r, c) - y(r, c)) / scale);
      }
    }
  }
  return worst;
}

void restartFromApriori(const Network& from, Network& to) {
  to = from;
  to.resetToApriori();
  for (int32_t k = 0; k < from.observationCount(); ++k)
    to.observation(k).rejected = from.observation(k).rejected;
  int32_t failed = 0;
  (void)to.triangulateAll(failed);
}

FastAdjustOptions plainFastOptions() {
  FastAdjustOptions o;
  o.robust = false;
  o.eo_step_tolerance_px = 1e-6;
  o.relative_cost_tolerance = 1e-12;
  return o;
}

void drawImageNoise(const Network& exact, uint32_t seed, Network& net) {
  net = exact;
  std::mt19937 rng(seed * 7919u + 17u);
  std::normal_distribution<double> gauss(0.0, 1.0);
  for (int32_t k = 0; k < net.observationCount(); ++k) {
    NetObservation& o = net.observation(k);
    o.ideal_px += o.sigma_px * Vec2(gauss(rng), gauss(rng));
  }
  net.resetToApriori();
  int32_t failed = 0;
  (void)net.triangulateAll(failed);
}

}  // namespace areomap::test
