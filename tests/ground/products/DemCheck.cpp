// A made DEM against a synthetic dataset's truth, per range band (BENCHMARKS.md "DEM sigma"):
//   dem_check DATASET PRODUCTS [--bands 2,5,10,20] [--stem dem|dem_near]
// DATASET has truth/dem.tif and truth/models/<stem>.cahvor; PRODUCTS has dem.tif, dem_sigma.tif and
// models/<stem>.cahvor (the adjusted models; absent: the true ones, no datum rotation). Cells are those the
// true cameras see (projects inside a true image and the ray from its centre, marched through truth/dem.tif,
// reaches the surface within 3 cm). The common datum rotation of the adjusted models (firmware_core/adjust
// Datum.hpp) is removed first: a DEM cell (n, e, z) is the point X_G + R (P - X_G) compared with the truth
// there. Prints per band: seen cells, filled %, RMSE, sigma RMS, % of errors within 1 and 2 sigma.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>
#include <vector>

#include "ground/dataset/Dataset.hpp"
#include "ground/dataset/DemRaster.hpp"
#include "ground/io/CameraFile.hpp"
#include "ground/ortho/Orthoimage.hpp"
#include "tests/ground/products/TruthDatum.hpp"

using namespace areomap;

namespace {

// The ray from `c` to `p` stays above the truth surface until 3 cm before p.
bool clearRay(const DemGrid& truth, const Vec3& c, const Vec3& p) {
  const Vec3 d = p - c;
  const double dist = d.norm();
  const double step = 0.5 * truth.cell_m;
  for (double s = step; s < dist - 0.03; s += step) {
    const Vec3 q = c + d * (s / dist);
    double t = 0;
    if (!ortho::demElevation(truth, q.x(), q.y(), t)) continue;
    if (-q.z() < t - 1e-3) return false;
  }
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr,
                 "usage: dem_check DATASET PRODUCTS [--bands 2,5,10,20] [--stem dem|dem_near] [--sectors]\n");
    return 2;
  }
  const std::string root = argv[1], out = argv[2];
  std::vector<double> edges = {2, 5, 10, 20};
  std::string stem = "dem";
  bool sectors = false;
  for (int i = 3; i < argc; i += 2) {
    const std::string flag = argv[i];
    if (flag == "--sectors") {
      sectors = true;
      --i;
    } else if (i + 1 >= argc) {
      std::fprintf(stderr, "dem_check: option '%s' needs a value\n", flag.c_str());
      return 2;
    } else if (flag == "--bands") {
      edges.clear();
      std::stringstream in(argv[i + 1]);
      std::string item;
      while (std::getline(in, item, ',')) edges.push_back(std::atof(item.c_str()));
    } else if (flag == "--stem") {
      stem = argv[i + 1];
    } else {
      std::fprintf(stderr, "dem_check: unknown option '%s'\n", flag.c_str());
      return 2;
    }
  }
  const Dataset ds = readDataset(root);
  const DemGrid truth = readDemGeoTiff(root + "/truth/dem.tif");
  const DemGrid dem = readDemGeoTiff(out + "/" + stem + ".tif");
  const DemGrid sigma = readDemGeoTiff(out + "/" + stem + "_sigma.tif");
  const test::TruthDatum datum = test::truthDatum(ds, root, out);
  const std::vector<CameraModel>& cams = datum.truth_models;
  const Vec3& g = datum.centre;
  const Mat3& r = datum.rotation;
  const double angle = datum.angleRad();
  std::printf("%s: datum rotation removed %.3f mrad (%zu adjusted models)\n", out.c_str(), 1e3 * angle,
              datum.adjusted_models);
  struct Band {
    long long seen = 0, filled = 0, w1 = 0, w2 = 0;
    double s2 = 0, sig2 = 0, sum = 0;
    std::vector<double> abs_err, sig;
  };
  std::vector<Band> bands(edges.size() - 1);
  // Per 20-degree azimuth sector about the gimbal centre: the mean signed error over range (mrad), cells
  // from the first to the last band edge (a pair's EO error moves its sector as a whole; a datum tilt is
  // a sinusoid over the sectors).
  constexpr int kSectors = 18;
  double sector_sum[kSectors] = {}, sector_n[kSectors] = {};
  for (int row = 0; row < dem.rows; ++row) {
    for (int col = 0; col < dem.cols; ++col) {
      const double n = dem.northOfRow(row), e = dem.eastOfCol(col);
      const double range = std::hypot(n - g.x(), e - g.y());
      int b = -1;
      for (std::size_t k = 0; k + 1 < edges.size(); ++k)
        if (range >= edges[k] && range < edges[k + 1]) b = static_cast<int>(k);
      if (b < 0) continue;
      double t = 0;
      if (!ortho::demElevation(truth, n, e, t)) continue;
      const Vec3 pt(n, e, -t);
      bool seen = false;
      for (const CameraModel& c : cams) {
        Vec2 px;
        if (project(c, pt, px) != Status::kOk) continue;
        if (px.x() < 0 || px.y() < 0 || px.x() > c.width - 1 || px.y() > c.height - 1) continue;
        if (clearRay(truth, c.c, pt)) {
          seen = true;
          break;
        }
      }
      if (!seen) continue;
      Band& bd = bands[static_cast<std::size_t>(b)];
      ++bd.seen;
      const float v = dem.at(col, row);
      if (v == dem.nodata) continue;
      const Vec3 aligned = g + r * (Vec3(n, e, -static_cast<double>(v)) - g);
      double ta = 0;
      if (!ortho::demElevation(truth, aligned.x(), aligned.y(), ta)) continue;
      ++bd.filled;
      const double err = -aligned.z() - ta;
      const double s = sigma.at(col, row);
      bd.s2 += err * err;
      bd.sum += err;
      bd.sig2 += s * s;
      bd.w1 += std::fabs(err) <= s;
      bd.w2 += std::fabs(err) <= 2 * s;
      bd.abs_err.push_back(std::fabs(err));
      const double az = std::atan2(e - g.y(), n - g.x());
      const int sector = std::clamp(static_cast<int>((az + M_PI) / (2 * M_PI) * kSectors), 0, kSectors - 1);
      sector_sum[sector] += err / range;
      sector_n[sector] += 1;
      bd.sig.push_back(s);
    }
  }
  std::printf(
      "| band | seen cells | filled | RMSE | sigma RMS | within 1 sigma | within 2 sigma | median abs error "
      "| median sigma | mean error |\n|---|---|---|---|---|---|---|---|---|---|\n");
  const auto median = [](std::vector<double> v) {
    if (v.empty()) return 0.0;
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  for (std::size_t k = 0; k < bands.size(); ++k) {
    const Band& b = bands[k];
    const double f = std::max(1LL, b.filled);
    std::printf(
        "| %g-%g m | %lld | %.1f %% | %.4f m | %.4f m | %.1f %% | %.1f %% | %.4f m | %.4f m | %+.4f m |\n",
        edges[k], edges[k + 1], b.seen, 100.0 * b.filled / std::max(1LL, b.seen), std::sqrt(b.s2 / f),
        std::sqrt(b.sig2 / f), 100.0 * b.w1 / f, 100.0 * b.w2 / f, median(b.abs_err), median(b.sig),
        b.sum / f);
  }
  if (sectors) {
    std::printf("mean error / range per 20-degree sector from -180 deg (mrad):");
    for (int k = 0; k < kSectors; ++k)
      std::printf(" %.3f", sector_n[k] > 0 ? 1e3 * sector_sum[k] / sector_n[k] : 0.0);
    std::printf("\n");
  }
  return 0;
}
