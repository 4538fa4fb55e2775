#include "ground/ties/TieCheck.hpp"

#include <cmath>
#include <set>

#include "ground/dataset/DemRaster.hpp"
#include "ground/dataset/TruthFiles.hpp"
#include "ground/io/CameraFile.hpp"

namespace areomap {
namespace {

// Elevation up (m) at site (x north, y east), bilinear over valid cells; false outside or on nodata.
bool elevation(const DemGrid& dem, double x, double y, double& up_m) {
  const double fc = (y - dem.east0_m) / dem.cell_m - 0.5;
  const double fr = (dem.north0_m - x) / dem.cell_m - 0.5;
  const int c0 = static_cast<int>(std::floor(fc)), r0 = static_cast<int>(std::floor(fr));
  if (c0 < 0 || r0 < 0 || c0 + 1 >= dem.cols || r0 + 1 >= dem.rows) return false;
  const double a = fc - c0, b = fr - r0;
  double v[2][2];
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) {
      v[i][j] = dem.at(c0 + j, r0 + i);
      if (v[i][j] == dem.nodata || !std::isfinite(v[i][j])) return false;
    }
  up_m = (1 - b) * ((1 - a) * v[0][0] + a * v[0][1]) + b * ((1 - a) * v[1][0] + a * v[1][1]);
  return true;
}

// First crossing of the ray with the surface (Z down = -elevation), steps of a quarter cell, bisection.
bool surfacePoint(const DemGrid& dem, const Vec3& o, const Vec3& d, Vec3& p) {
  const double step = 0.25 * dem.cell_m;
  const double max_range = 2.0 * std::max(dem.cols, dem.rows) * dem.cell_m;
  double prev_t = -1.0;
  for (double t = step; t < max_range; t += step) {
    const Vec3 q = o + t * d;
    double up = 0.0;
    if (!elevation(dem, q.x(), q.y(), up)) {
      prev_t = -1.0;
      continue;
    }
    if (q.z() >= -up) {
      if (prev_t < 0.0) return false;
      double lo = prev_t, hi = t;
      for (int k = 0; k < 40; ++k) {
        const double mid = 0.5 * (lo + hi);
        const Vec3 m = o + mid * d;
        double u = 0.0;
        if (!elevation(dem, m.x(), m.y(), u)) return false;
        (m.z() >= -u ? hi : lo) = mid;
      }
      p = o + hi * d;
      return true;
    }
    prev_t = t;
  }
  return false;
}

}  // namespace

TieCheck checkTiesAgainstTruth(const Dataset& dataset, const TieRun& run) {
  TieCheck check;
  const DemGrid dem = readDemGeoTiff(dataset.root + "/" + kTruthDemFile);
  std::map<std::string, CameraModel> truth;
  std::map<std::string, int> pair_of;
  std::map<std::string, int> side_of;  // 0 left, 1 right camera of its pair
  for (size_t k = 0; k < dataset.pairs.size(); ++k) {
    const Pair& p = dataset.pairs[k];
    for (const ImageRef* ref : {&p.left, p.right ? &*p.right : nullptr}) {
      if (ref == nullptr) continue;
      truth[ref->stem] =
          io::readCameraModelFile(dataset.root + "/" + kTruthModelsFolder + "/" + ref->stem + ".cahvor");
      pair_of[ref->stem] = static_cast<int>(k);
      side_of[ref->stem] = ref == &p.left ? 0 : 1;
    }
  }
  // Claimed surface point of each tie point: its first observation.
  std::map<int64_t, Vec3> claimed;
  std::set<int64_t> failed;
  std::map<int64_t, std::set<int>> pairs_of_point;
  double sum_sq = 0.0;
  Vec2 intra_sum = Vec2::Zero();
  int intra_n = 0;
  Vec2 inter_sum[2] = {Vec2::Zero(), Vec2::Zero()};
  int inter_n[2] = {0, 0};
  for (const ImageObservation& o : run.observations) {
    pairs_of_point[o.point].insert(pair_of.at(o.image));
    const CameraModel& m = truth.at(o.image);
    if (failed.count(o.point)) continue;
    auto it = claimed.find(o.point);
    if (it == claimed.end()) {
      Vec3 origin, dir, p;
      if (!ok(unproject(m, Vec2(o.sample_px, o.line_px), origin, dir)) ||
          !surfacePoint(dem, origin, dir, p)) {
        failed.insert(o.point);
        ++check.no_surface;
        continue;
      }
      claimed[o.point] = p;
      continue;
    }
    Vec2 px;
    double e = 1e9;
    if (ok(project(m, it->second, px))) e = (px - Vec2(o.sample_px, o.line_px)).norm();
    ++check.checked;
    if (o.kind != "inter" && e <= 1.0) {
      intra_sum += Vec2(o.sample_px, o.line_px) - px;
      ++intra_n;
      const double range = (it->second - m.c).norm();
      for (int b = 0; b < TieCheck::kRangeBands; ++b) {
        if (range >= TieCheck::kRangeBands_m[b] && range < TieCheck::kRangeBands_m[b + 1]) {
          check.intra_mean_dx_by_range_px[b] += o.sample_px - px.x();
          ++check.intra_by_range[b];
        }
      }
    } else if (o.kind == "inter" && e <= 1.0) {
      const int side = side_of.at(o.image);
      inter_sum[side] += Vec2(o.sample_px, o.line_px) - px;
      ++inter_n[side];
    }
    check.within_1px += e <= 1.0 ? 1 : 0;
    if (o.kind == "inter") {
      ++check.inter_checked;
      check.inter_within_1px += e <= 1.0 ? 1 : 0;
    }
    sum_sq += std::min(e, 100.0) * std::min(e, 100.0);
  }
  check.rms_px = check.checked > 0 ? std::sqrt(sum_sq / check.checked) : 0.0;
  for (int b = 0; b < TieCheck::kRangeBands; ++b) {
    if (check.intra_by_range[b] > 0) check.intra_mean_dx_by_range_px[b] /= check.intra_by_range[b];
  }
  if (intra_n > 0) {
    check.intra_mean_dx_px = intra_sum.x() / intra_n;
    check.intra_mean_dy_px = intra_sum.y() / intra_n;
  }
  for (int side = 0; side < 2; ++side) {
    if (inter_n[side] == 0) continue;
    check.inter_mean_dx_px[side] = inter_sum[side].x() / inter_n[side];
    check.inter_mean_dy_px[side] = inter_sum[side].y() / inter_n[side];
    check.inter_within_1px_by_side[side] = inter_n[side];
  }
  // Adjacency from the truth check points.
  std::map<int64_t, std::set<int>> truth_pairs;
  for (const ImageObservation& o : readObservationsCsv(dataset.root + "/" + kTruthObservationsFile)) {
    auto it = pair_of.find(o.image);
    if (it != pair_of.end()) truth_pairs[o.point].insert(it->second);
  }
  std::map<std::pair<int, int>, int> truth_shared;
  for (const auto& [point, pairs] : truth_pairs)
    for (int a : pairs)
      for (int b : pairs)
        if (a < b) ++truth_shared[{a, b}];
  std::map<std::pair<int, int>, int> shared;
  for (const auto& [point, pairs] : pairs_of_point)
    for (int a : pairs)
      for (int b : pairs)
        if (a < b) ++shared[{a, b}];
  check.min_link = -1;
  for (const auto& [key, n] : truth_shared) {
    if (n < 10) continue;  // a sliver of overlap: not an adjacent pair
    ++check.adjacent_pairs;
    const int links = shared.count(key) ? shared.at(key) : 0;
    check.links[key] = links;
    if (check.min_link < 0 || links < check.min_link) {
      check.min_link = links;
      check.worst_link = std::to_string(key.first) + "-" + std::to_string(key.second) + ": " +
                         std::to_string(links) + " ties (" + std::to_string(n) + " truth points shared)";
    }
  }
  if (check.min_link < 0) check.min_link = 0;
  return check;
}

}  // namespace areomap
