// What the true cameras see against a products folder, with the breakdowns behind report.json's truth
// figures (docs/products.md "Seen and unseen cells"):
//   seen_check DATASET PRODUCTS [--range M]
// DATASET has images, truth/dem.tif and truth/models; PRODUCTS has dem.tif, dem_seen.tif, ortho.tif.
// Prints report.json's three figures recomputed (products::seenAgainstTruth), then per range band the
// cells not seen and seen in truth, how many of the first the DEM fills (measured or interpolated) and how
// many of the second it leaves empty, with the distance from each such cell to the nearest measured cell
// (marginal cells left out). Environment: SEEN_CHECK_PNG=FILE draws the classes against truth
// (SEEN_CHECK_CROP=x,y,w,h a window, 4x); SEEN_CHECK_MARGIN the measured cells' margins over the DEM's own
// horizon; SEEN_CHECK_ORTHO the ortho's agreement per band, same source or not; SEEN_CHECK_NO_OCCLUSION
// the figures for an ortho made without its occlusion rule instead of ortho.tif; SEEN_CHECK_BORDER the seen
// cells left empty by their distance from the border of the images that hold them.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "ground/dataset/Dataset.hpp"
#include "ground/dataset/DemRaster.hpp"
#include "ground/dem/DemSeen.hpp"
#include "ground/dem/Viewshed.hpp"
#include "ground/io/CameraFile.hpp"
#include <limits>
#include "ground/ortho/Orthoimage.hpp"
#include "ground/products/TruthSeen.hpp"
#include "ground/raster/RasterFiles.hpp"
#include "tests/ground/products/TruthDatum.hpp"

using namespace areomap;

constexpr int kBandsO = 5;
constexpr double edgesO[kBandsO + 1] = {0, 2, 5, 10, 20, 1e9};

namespace {

cv::Mat byteRaster(const std::string& path, int rows, int cols) {
  const raster::Float32Raster r = raster::readGeoTiff(path);
  cv::Mat m(rows, cols, CV_8U, cv::Scalar(0));
  if (r.geometry.rows != rows || r.geometry.cols != cols) return m;
  for (int i = 0; i < rows * cols; ++i) m.data[i] = static_cast<uint8_t>(r.values[static_cast<std::size_t>(i)]);
  return m;
}

// Distance (cells) from each cell to the nearest cell where `mask` is set.
cv::Mat distanceTo(const cv::Mat& mask) {
  cv::Mat inv = mask == 0;
  cv::Mat d;
  cv::distanceTransform(inv, d, cv::DIST_L2, 3);
  return d;
}

}  // namespace

// Long because: an evaluation tool, its optional diagnostics one after the other over the same rasters.
int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: seen_check DATASET PRODUCTS [--range M]\n");
    return 2;
  }
  const std::string root = argv[1], out = argv[2];
  double range_m = 60.0;
  for (int i = 3; i + 1 < argc; i += 2)
    if (std::string(argv[i]) == "--range") range_m = std::atof(argv[i + 1]);
  const Dataset ds = readDataset(root);
  const DemGrid truth = readDemGeoTiff(root + "/truth/dem.tif");
  const DemGrid dem = readDemGeoTiff(out + "/dem.tif");
  const test::TruthDatum datum = test::truthDatum(ds, root, out);
  std::vector<cv::Mat> images;
  std::vector<std::string> stems;
  for (const Pair& p : ds.pairs)
    for (const ImageRef* ref : {&p.left, p.right ? &*p.right : nullptr})
      if (ref != nullptr) {
        images.push_back(cv::imread(ref->image_path, cv::IMREAD_GRAYSCALE));
        stems.push_back(ref->stem);
      }
  const cv::Mat classes = byteRaster(out + "/dem_seen.tif", dem.rows, dem.cols);
  cv::Mat ortho = byteRaster(out + "/ortho.tif", dem.rows, dem.cols);
  std::vector<uint8_t> class_vec(classes.data, classes.data + classes.total());
  const Vec3 g = datum.centre;
  std::vector<CameraModel> adjusted;
  for (std::size_t k = 0; k < images.size(); ++k)
    adjusted.push_back(io::readCameraModelFile(out + "/models/" + stems[k] + ".cahvor", images[k].cols, images[k].rows));
  const products::TruthFrame frame = products::truthFrame(adjusted, datum.truth_models, g);
  if (std::getenv("SEEN_CHECK_NO_OCCLUSION") != nullptr) {  // the ortho as made without the occlusion rule
    std::vector<ortho::OrthoSource> sources;
    for (std::size_t k = 0; k < images.size(); ++k) sources.push_back({images[k], adjusted[k]});
    ortho::OrthoOptions o;
    o.occlusion = false;
    ortho = ortho::makeOrthoimage(dem, sources, o).image;
  }
  const products::SeenTruth t =
      products::seenAgainstTruth(dem, &ortho, truth, images, datum.truth_models, frame, range_m, &class_vec);
  std::printf("%s: cell %.3f m, %d x %d; datum rotation %.3f mrad\n", out.c_str(), dem.cell_m, dem.cols, dem.rows,
              1e3 * datum.angleRad());
  std::printf("report: marginal %lld; unseen %lld, %.2f %% empty (%lld measured); seen %lld, %.2f %% filled; ortho %.2f %% of %lld\n",
              t.cells_marginal, t.cells_unseen, 100 * t.unseen_empty.value_or(-1), t.unseen_measured, t.cells_seen,
              100 * t.seen_filled.value_or(-1), 100 * t.ortho_agreement.value_or(-1), t.cells_compared);
  const std::vector<uint8_t>& seen = t.seen;
  cv::Mat measured = classes == dem::kCellMeasured, seen_mask(dem.rows, dem.cols, CV_8U);
  for (int i = 0; i < dem.rows * dem.cols; ++i) seen_mask.data[i] = seen[static_cast<std::size_t>(i)];
  if (const char* png = std::getenv("SEEN_CHECK_PNG"); png != nullptr) {
    cv::Mat vis(dem.rows, dem.cols, CV_8UC3);
    for (int r = 0; r < dem.rows; ++r) {
      for (int c = 0; c < dem.cols; ++c) {
        const std::size_t i = static_cast<std::size_t>(r) * dem.cols + c;
        const int k = classes.at<uint8_t>(r, c), o = ortho.at<uint8_t>(r, c);
        cv::Vec3b v(o / 2, o / 2, o / 2);
        if (!seen[i]) v = k == dem::kCellMeasured ? cv::Vec3b(0, 0, 255) : k == dem::kCellInterpolated ? cv::Vec3b(0, 160, 255) : cv::Vec3b(0, 0, 0);
        else if (k == dem::kCellUnseen) v = cv::Vec3b(255, 80, 0);
        vis.at<cv::Vec3b>(r, c) = v;
      }
    }
    if (const char* crop = std::getenv("SEEN_CHECK_CROP"); crop != nullptr) {
      int x = 0, y = 0, w = 0, h = 0;
      std::sscanf(crop, "%d,%d,%d,%d", &x, &y, &w, &h);
      cv::resize(vis(cv::Rect(x, y, w, h)), vis, cv::Size(), 4, 4, cv::INTER_NEAREST);
    }
    cv::imwrite(png, vis);
  }
  if (std::getenv("SEEN_CHECK_MARGIN") != nullptr) {
    // Per measured cell: the best margin (metres, and in its sigma) above the DEM's own horizon over the
    // adjusted cameras whose image holds it.
    const DemGrid sigma = readDemGeoTiff(out + "/dem_sigma.tif");
    std::vector<float> best(dem.values.size(), -1e9f), best_s(dem.values.size(), -1e9f), horizon;
    for (std::size_t k = 0; k < images.size(); ++k) {
      const CameraModel m = io::readCameraModelFile(out + "/models/" + stems[k] + ".cahvor", images[k].cols, images[k].rows);
      dem::horizonFrom(dem, m.c, horizon, false);
      const dem::ImageCone cone = dem::imageCone(m);
      for (int r = 0; r < dem.rows; ++r) {
        for (int c = 0; c < dem.cols; ++c) {
          const std::size_t i = static_cast<std::size_t>(r) * dem.cols + c;
          if (classes.at<uint8_t>(r, c) != dem::kCellMeasured) continue;
          const float z = dem.values[i];
          const double range = std::hypot(dem.northOfRow(r) - g.x(), dem.eastOfCol(c) - g.y());
          if (range < 5 || range > 20) continue;
          if (!dem::imageSees(m, cone, Vec3(dem.northOfRow(r), dem.eastOfCol(c), -z))) continue;
          const float mg = horizon[i] == -std::numeric_limits<float>::infinity() ? 1.0f : z - horizon[i];
          best[i] = std::max(best[i], mg);
          best_s[i] = std::max(best_s[i], mg / std::max(1e-4f, sigma.values[i]));
        }
      }
    }
    for (int which = 0; which < 2; ++which) {
      std::vector<float> a, b;
      for (std::size_t i = 0; i < best.size(); ++i) {
        if (best[i] < -1e8f || seen[i] != which) continue;
        a.push_back(best[i]);
        b.push_back(best_s[i]);
      }
      std::sort(a.begin(), a.end());
      std::sort(b.begin(), b.end());
      std::printf("measured cells 5-20 m %s in truth: %zu; margin over the DEM's horizon (mm) / (sigma) at", which ? "seen" : "unseen", a.size());
      for (double q : {0.05, 0.1, 0.25, 0.5, 0.75, 0.9})
        if (!a.empty()) std::printf(" q%.2f %.1f / %.2f", q, 1e3 * a[static_cast<std::size_t>(q * (a.size() - 1))], b[static_cast<std::size_t>(q * (b.size() - 1))]);
      std::printf("\n");
    }
  }
  if (std::getenv("SEEN_CHECK_ORTHO") != nullptr) {
    const DemGrid sigma = readDemGeoTiff(out + "/dem_sigma.tif");
    std::vector<ortho::OrthoSource> made_src, truth_src;
    for (std::size_t k = 0; k < images.size(); ++k) {
      made_src.push_back({images[k], io::readCameraModelFile(out + "/models/" + stems[k] + ".cahvor", images[k].cols, images[k].rows)});
      truth_src.push_back({images[k], datum.truth_models[k]});
    }
    ortho::OrthoOptions mo;
    mo.dem_sigma = &sigma;
    const ortho::OrthoResult made = ortho::makeOrthoimage(dem, made_src, mo);
    DemGrid ts = dem;
    for (int r = 0; r < dem.rows; ++r)
      for (int c = 0; c < dem.cols; ++c) {
        double z = 0;
        ts.at(c, r) = ortho::demElevation(truth, dem.northOfRow(r), dem.eastOfCol(c), z) ? static_cast<float>(z) : ts.nodata;
      }
    const ortho::OrthoResult tr = ortho::makeOrthoimage(ts, truth_src, ortho::OrthoOptions{});
    long long same_v = 0, n = 0;
    long long cmp[kBandsO] = {}, agr[kBandsO] = {}, same[kBandsO] = {}, agr_same[kBandsO] = {}, agr_own[kBandsO] = {};
    for (int r = 1; r + 1 < dem.rows; ++r) {
      for (int c = 1; c + 1 < dem.cols; ++c) {
        const std::size_t i = static_cast<std::size_t>(r) * dem.cols + c;
        const int v = ortho.at<uint8_t>(r, c), t = tr.image.at<uint8_t>(r, c);
        if (!seen[i] || v == 0 || t == 0) continue;
        ++n;
        same_v += made.image.at<uint8_t>(r, c) == v;
        const double range = std::hypot(dem.northOfRow(r) - g.x(), dem.eastOfCol(c) - g.y());
        int b = 0;
        while (range >= edgesO[b + 1]) ++b;
        int lo = 256, hi = -1;
        for (int dr = -1; dr <= 1; ++dr)
          for (int dc = -1; dc <= 1; ++dc) {
            const int tv = tr.image.at<uint8_t>(r + dr, c + dc);
            if (tv == 0) continue;
            lo = std::min(lo, tv);
            hi = std::max(hi, tv);
          }
        const bool a = v >= lo - 2 && v <= hi + 2;
        const int k = made.source.at<int16_t>(r, c);
        const bool sm = k == tr.source.at<int16_t>(r, c);
        ++cmp[b];
        agr[b] += a;
        same[b] += sm;
        agr_same[b] += sm && a;
        // The same image sampled at the true ground point's true projection (+-2 grey, 1 px around).
        Vec2 px;
        const Vec3 x(dem.northOfRow(r), dem.eastOfCol(c), -ts.at(c, r));
        if (k >= 0 && project(datum.truth_models[k], x, px) == Status::kOk) {
          const cv::Mat& im = images[k];
          int l2 = 256, h2 = -1;
          for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx) {
              const int u = static_cast<int>(std::lround(px.x())) + dx, w = static_cast<int>(std::lround(px.y())) + dy;
              if (u < 0 || w < 0 || u >= im.cols || w >= im.rows) continue;
              l2 = std::min<int>(l2, im.at<uint8_t>(w, u));
              h2 = std::max<int>(h2, im.at<uint8_t>(w, u));
            }
          agr_own[b] += v >= l2 - 2 && v <= h2 + 2;
        }
      }
    }
    std::printf("ortho recomputed equal to ortho.tif on %.2f %% of %lld\n", 100.0 * same_v / std::max(1LL, n), n);
    for (int b = 0; b < kBandsO; ++b)
      std::printf("ortho %g-%g m: %lld compared, %.1f %% agree; same source %.1f %%, agreeing %.1f %% of those; "
                  "within its own image's 3x3 px at the true point %.1f %%\n", edgesO[b], edgesO[b + 1], cmp[b],
                  100.0 * agr[b] / std::max(1LL, cmp[b]), 100.0 * same[b] / std::max(1LL, cmp[b]),
                  100.0 * agr_same[b] / std::max(1LL, same[b]), 100.0 * agr_own[b] / std::max(1LL, cmp[b]));
  }
  if (std::getenv("SEEN_CHECK_BORDER") != nullptr) {
    // The seen cells left empty by how far inside an image their ground lies: per cell the largest
    // distance (pixels) from the border of the true images that hold its true ground point (the horizon not
    // tested: an upper bound), per band. The matcher measures no pixel within its window of the border.
    const DemGrid ts = [&] {
      DemGrid t = dem;
      for (int r = 0; r < dem.rows; ++r)
        for (int c = 0; c < dem.cols; ++c) {
          double z = 0;
          t.at(c, r) = ortho::demElevation(truth, dem.northOfRow(r), dem.eastOfCol(c), z) ? static_cast<float>(z) : t.nodata;
        }
      return t;
    }();
    long long border[6][4] = {};
    std::vector<dem::ImageCone> cones;
    for (const CameraModel& m : datum.truth_models) cones.push_back(dem::imageCone(m));
    const double bedges[] = {0, 2, 5, 10, 20, 40, 1e9};
    for (int r = 0; r < dem.rows; ++r) {
      for (int c = 0; c < dem.cols; ++c) {
        const std::size_t i = static_cast<std::size_t>(r) * dem.cols + c;
        if (seen[i] != products::kTruthSeen || classes.at<uint8_t>(r, c) != dem::kCellUnseen || ts.at(c, r) == ts.nodata) continue;
        const Vec3 x = frame.toTruth(Vec3(dem.northOfRow(r), dem.eastOfCol(c), -ts.at(c, r)));
        double inside = -1;
        for (std::size_t k = 0; k < images.size(); ++k) {
          const CameraModel& m = datum.truth_models[k];
          Vec2 px;
          if (!dem::imageSees(m, cones[k], x) || project(m, x, px) != Status::kOk) continue;
          inside = std::max(inside, std::min({px.x() + 0.5, px.y() + 0.5, m.width - 0.5 - px.x(), m.height - 0.5 - px.y()}));
        }
        const double range = std::hypot(dem.northOfRow(r) - g.x(), dem.eastOfCol(c) - g.y());
        int b = 0;
        while (range >= bedges[b + 1]) ++b;
        ++border[b][inside < 4 ? 0 : inside < 8 ? 1 : inside < 16 ? 2 : 3];
      }
    }
    for (int b = 0; b < 6; ++b)
      std::printf("seen cells empty %g-%g m: within 4 / 8 / 16 / more px of the border of every image holding them: "
                  "%lld / %lld / %lld / %lld\n", bedges[b], bedges[b + 1], border[b][0], border[b][1], border[b][2], border[b][3]);
  }
  const cv::Mat to_measured = distanceTo(measured), to_seen = distanceTo(seen_mask);
  const double edges[] = {0, 2, 5, 10, 20, 40, 1e9};
  constexpr int kBands = 6;
  struct Band {
    long long unseen = 0, unseen_measured = 0, unseen_interp = 0, seen = 0, seen_empty = 0;
    long long unseen_filled_near_seen[4] = {}, seen_empty_to_measured[4] = {};
  } bands[kBands];
  const auto bucket = [](float d) { return d <= 1.5f ? 0 : d <= 3.5f ? 1 : d <= 10.5f ? 2 : 3; };
  for (int r = 0; r < dem.rows; ++r) {
    for (int c = 0; c < dem.cols; ++c) {
      const double range = std::hypot(dem.northOfRow(r) - g.x(), dem.eastOfCol(c) - g.y());
      double tz = 0;
      if (range > range_m || !ortho::demElevation(truth, dem.northOfRow(r), dem.eastOfCol(c), tz)) continue;
      int b = 0;
      while (range >= edges[b + 1]) ++b;
      Band& bd = bands[b];
      const std::size_t i = static_cast<std::size_t>(r) * dem.cols + c;
      const int k = classes.at<uint8_t>(r, c);
      if (seen[i] == products::kTruthMarginal) continue;
      if (!seen[i]) {
        ++bd.unseen;
        bd.unseen_measured += k == dem::kCellMeasured;
        bd.unseen_interp += k == dem::kCellInterpolated;
        if (k != dem::kCellUnseen) ++bd.unseen_filled_near_seen[bucket(to_seen.at<float>(r, c))];
      } else {
        ++bd.seen;
        if (k == dem::kCellUnseen) {
          ++bd.seen_empty;
          ++bd.seen_empty_to_measured[bucket(to_measured.at<float>(r, c))];
        }
      }
    }
  }
  std::printf("| band m | unseen | empty %% | measured | interpolated | filled: seen cell within 1 / 3 / 10 / more "
              "| seen | filled %% | empty: measured within 1 / 3 / 10 / more |\n");
  for (int b = 0; b < kBands; ++b) {
    const Band& d = bands[b];
    std::printf("| %g-%g | %lld | %.1f | %lld | %lld | %lld / %lld / %lld / %lld | %lld | %.1f | %lld / %lld / %lld / %lld |\n",
                edges[b], edges[b + 1], d.unseen, 100.0 * (d.unseen - d.unseen_measured - d.unseen_interp) / std::max(1LL, d.unseen),
                d.unseen_measured, d.unseen_interp, d.unseen_filled_near_seen[0], d.unseen_filled_near_seen[1],
                d.unseen_filled_near_seen[2], d.unseen_filled_near_seen[3], d.seen,
                100.0 * (d.seen - d.seen_empty) / std::max(1LL, d.seen), d.seen_empty_to_measured[0],
                d.seen_empty_to_measured[1], d.seen_empty_to_measured[2], d.seen_empty_to_measured[3]);
  }
  return 0;
}
