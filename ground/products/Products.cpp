#include "ground/products/Products.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <set>
#include <stdexcept>
#include <unordered_map>

#include <gdal_priv.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "ground/cli/AtomicFile.hpp"
#include "ground/cli/Cli.hpp"
#include "ground/dem/BinnedCloud.hpp"
#include "ground/dem/DemProducts.hpp"
#include "ground/dem/EquiParallax.hpp"
#include "ground/dem/Kriging.hpp"
#include "ground/dense/DenseMatcher.hpp"
#include "ground/dense/PairCloud.hpp"
#include "ground/dense/LineId.hpp"
#include "ground/dense/Rectification.hpp"
#include "ground/dense/Triangulation.hpp"
#include "ground/ortho/Orthoimage.hpp"
#include "ground/products/Previews.hpp"
#include "ground/products/ReportHtml.hpp"

namespace areomap::products {

namespace {

namespace fs = std::filesystem;

// Standard deviation of a dense match (pixels) for the intersection's covariance: the matcher's
// sub-pixel precision, calibrated against truth (ground/dense/DenseMatcher.hpp).
constexpr double kMatchSigmaPx = dense::kMatchSigmaPx;

// The two corners (south-west, north-east) of the points that `keep` accepts, as points: dem::gridAround of
// them is the grid around those points. Empty when it accepts none; `count` (optional) gets how many it does.
template <class Keep>
std::vector<dem::DemPoint> boundingCorners(const std::vector<dem::DemPoint>& points, const Keep& keep,
                                           std::size_t* count = nullptr) {
  std::vector<dem::DemPoint> corners(2);
  corners[0].north_m = corners[0].east_m = 1e300;
  corners[1].north_m = corners[1].east_m = -1e300;
  std::size_t kept = 0;
  for (const dem::DemPoint& p : points) {
    if (!keep(p)) continue;
    ++kept;
    corners[0].north_m = std::min(corners[0].north_m, p.north_m);
    corners[0].east_m = std::min(corners[0].east_m, p.east_m);
    corners[1].north_m = std::max(corners[1].north_m, p.north_m);
    corners[1].east_m = std::max(corners[1].east_m, p.east_m);
  }
  if (kept == 0) corners.clear();
  if (count != nullptr) *count = kept;
  return corners;
}

struct Context {
  ProductsResult result;
  ground::AdjustReport& report;
  void warn(const std::string& text) {
    cli::warn(text);
    result.warnings.push_back(text);
  }
  // A product that could not be written (full disk, folder not writable): the message names it.
  void writeFailed(const std::exception& e) {
    warn(e.what());
    result.write_errors.push_back(e.what());
  }
};

void writePng(Context& ctx, const std::string& path, const cv::Mat& image) {
  std::vector<unsigned char> bytes;
  if (!cv::imencode(".png", image, bytes)) {
    ctx.warn(path + ": PNG encoding failed");
    return;
  }
  try {
    cli::writeFileAtomic(path, bytes.data(), bytes.size());
    ctx.result.files.push_back(path);
  } catch (const std::exception& e) {
    ctx.writeFailed(e);
  }
}

// An image is usable when it is present and its model describes an image of its size.
bool usable(Context& ctx, const ProductImage& im, std::set<std::string>& warned) {
  if (im.grey.empty()) {
    if (warned.insert(im.stem).second) ctx.warn("image " + im.stem + ": missing; its products are skipped");
    return false;
  }
  if (im.grey.type() != CV_8U) {
    if (warned.insert(im.stem).second) ctx.warn("image " + im.stem + ": not 8-bit grey; skipped");
    return false;
  }
  const char* field = "";
  if (validateModel(im.model, field) != Status::kOk) {
    if (warned.insert(im.stem).second) ctx.warn("model " + im.stem + ": invalid component " + field + "; skipped");
    return false;
  }
  if (im.model.width > 0 && (im.model.width != im.grey.cols || im.model.height != im.grey.rows)) {
    if (warned.insert(im.stem).second) {
      ctx.warn("model " + im.stem + ": size " + std::to_string(im.model.width) + "x" +
               std::to_string(im.model.height) + " is inconsistent with the image (" + std::to_string(im.grey.cols) +
               "x" + std::to_string(im.grey.rows) + "); skipped");
    }
    return false;
  }
  return true;
}

CameraModel sized(const ProductImage& im) {
  CameraModel m = im.model;
  m.width = im.grey.cols;
  m.height = im.grey.rows;
  return m;
}

// Automatic DEM cell: 2 cm near the rover (the paper's navcam DEM), coarser when the cloud is large, so
// that the grid stays within ~4e6 cells.
double autoCell(double extent_m) {
  const double cells = 2000.0;
  const double c = std::max(0.02, extent_m / cells);
  for (double nice : {0.02, 0.025, 0.05, 0.1, 0.2, 0.25, 0.5, 1.0}) {
    if (nice >= c) return nice;
  }
  return 1.0;
}

// The kriging's support rule (dem::KrigingOptions::min_cluster_points) as a progress line.
void supportInfo(const std::string& product, const dem::KrigingResult& kr) {
  char b[240];
  std::snprintf(
      b, sizeof b,
      "%s: %lld binned points in clusters of fewer than %d (farther than %.3f m from the rest): their %lld "
      "cells left empty",
      product.c_str(), kr.isolated_points, kr.min_cluster_points, kr.max_gap_m, kr.cells_unsupported);
  cli::info(b);
}

// The dense cloud as the products keep it (a navcam panorama has ~1.7e7 points): the DEM points (40 B
// each) in a vector of their own, so that the DEM step takes them over by a move, and beside them what
// points.ply needs besides (sigma per axis, grey: 16 B), freed before the DEM is made.
struct PlyExtra {
  float sigma_xyz_m[3] = {0.f, 0.f, 0.f};
  uint8_t grey = 0;
};

struct Cloud {
  std::vector<dem::DemPoint> dem;
  std::vector<PlyExtra> extra;  // extra[i] belongs to dem[i]
  std::size_t size() const { return dem.size(); }
  bool empty() const { return dem.empty(); }
  void reserve(std::size_t n) {
    dem.reserve(n);
    extra.reserve(n);
  }
  void push(const dense::CloudPoint& c) {
    dem::DemPoint p;
    p.north_m = c.site_m.x();
    p.east_m = c.site_m.y();
    p.elevation_m = -c.site_m.z();
    p.sigma_m = c.sigmaHeight_m();
    p.line = c.line;
    dem.push_back(p);
    PlyExtra e;
    for (int k = 0; k < 3; ++k) e.sigma_xyz_m[k] = static_cast<float>(std::sqrt(std::max(0.0, c.covariance_m2(k, k))));
    e.grey = c.grey;
    extra.push_back(e);
  }
  dense::CloudPoint cloudPoint(std::size_t i) const {
    const dem::DemPoint& p = dem[i];
    dense::CloudPoint c;
    c.site_m = Vec3(p.north_m, p.east_m, -p.elevation_m);
    for (int k = 0; k < 3; ++k) {
      c.covariance_m2(k, k) = static_cast<double>(extra[i].sigma_xyz_m[k]) * extra[i].sigma_xyz_m[k];
    }
    c.grey = extra[i].grey;
    c.line = p.line;
    return c;
  }
};

// Drops gross outliers before gridding: points whose height sigma exceeds `max_sigma_m`, and points far
// from the median height of their polar bin (1 m in range x 2 degrees in azimuth about the gimbal centre):
// more than max(0.3 m, 6 MAD-sigmas) away. Mismatches at depth edges and near the horizon are such points.
// In place (the cloud of a full panorama is gigabytes).
void dropOutliers(Cloud& cloud, const Vec3& centre, double max_sigma_m, long long& dropped) {
  std::vector<dem::DemPoint>& in = cloud.dem;
  std::unordered_map<long long, std::vector<float>> bins;
  auto key = [&](const dem::DemPoint& p) {
    const double dn = p.north_m - centre.x(), de = p.east_m - centre.y();
    const long long r = static_cast<long long>(std::floor(std::hypot(dn, de)));
    const long long a = static_cast<long long>(std::floor((std::atan2(de, dn) + M_PI) / (2.0 * M_PI / 180.0)));
    return r * 1000 + a;
  };
  for (const dem::DemPoint& p : in) {
    if (p.sigma_m <= max_sigma_m) bins[key(p)].push_back(static_cast<float>(p.elevation_m));
  }
  std::unordered_map<long long, std::pair<float, float>> stat;  // median, tolerance
  for (auto& kv : bins) {
    std::vector<float>& v = kv.second;
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    const float med = v[v.size() / 2];
    for (float& x : v) x = std::fabs(x - med);
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    const float mad = v[v.size() / 2];
    stat[kv.first] = {med, std::max(0.3f, 6.0f * 1.4826f * mad)};
  }
  std::unordered_map<long long, std::vector<float>>().swap(bins);
  std::size_t kept = 0;
  for (std::size_t i = 0; i < in.size(); ++i) {
    const dem::DemPoint& p = in[i];
    if (p.sigma_m > max_sigma_m) continue;
    const auto& st = stat[key(p)];
    if (std::fabs(p.elevation_m - st.first) > st.second) continue;
    if (kept != i) {
      in[kept] = p;
      cloud.extra[kept] = cloud.extra[i];
    }
    ++kept;
  }
  dropped = static_cast<long long>(in.size() - kept);
  in.resize(kept);
  cloud.extra.resize(kept);
}

// An observation farther than this from the intersection of its point's other rays is an outlier (the
// adjustment rejects such observations): it is left out of the point and keeps its residual.
constexpr double kTieOutlierPx = 5.0;

// Back-projection residual |v| of every tie observation (-1: unknown). Given residuals are kept; the
// others (the ground node hands over the observations only) are computed with the adjusted models: each
// tie point is intersected again from all its observations, which at the adjustment's convergence is the
// adjustment's own point, so these are the adjustment's residuals (precision method 1).
std::vector<double> tieResiduals(const ProductInputs& in, const std::vector<CameraModel>& models,
                                 const std::vector<bool>& ok) {
  std::vector<double> res(in.ties.size());
  std::map<int, std::vector<std::size_t>> of_point;
  for (std::size_t i = 0; i < in.ties.size(); ++i) {
    res[i] = in.ties[i].residual_px;
    of_point[in.ties[i].point].push_back(i);
  }
  for (const auto& kv : of_point) {
    std::vector<std::size_t> obs;  // usable, one per image, at most kMaxIntersectionViews
    std::set<int> seen;
    bool unknown = false;
    for (std::size_t i : kv.second) {
      const ProductTie& t = in.ties[i];
      unknown |= t.residual_px < 0;
      if (t.image < 0 || t.image >= static_cast<int>(ok.size()) || !ok[t.image] || !seen.insert(t.image).second) continue;
      if (obs.size() < static_cast<std::size_t>(dense::kMaxIntersectionViews)) obs.push_back(i);
    }
    if (!unknown || obs.size() < 2) continue;
    auto intersect = [&](std::size_t skip, Vec3& point, std::vector<double>& r) {
      std::vector<const CameraModel*> m;
      std::vector<Vec2> px;
      for (std::size_t k = 0; k < obs.size(); ++k) {
        if (k == skip) continue;
        m.push_back(&models[in.ties[obs[k]].image]);
        px.push_back(in.ties[obs[k]].pixel_px);
      }
      return dense::intersectRays(m, px, point, r);
    };
    Vec3 point;
    std::vector<double> r;
    if (!intersect(obs.size(), point, r)) continue;
    const std::size_t worst = static_cast<std::size_t>(std::max_element(r.begin(), r.end()) - r.begin());
    if (obs.size() > 2 && r[worst] > kTieOutlierPx) {
      Vec3 without;
      std::vector<double> r2;
      Vec2 uv;
      const ProductTie& w = in.ties[obs[worst]];
      if (intersect(worst, without, r2) && project(models[w.image], without, uv) == Status::kOk) {
        r2.insert(r2.begin() + static_cast<std::ptrdiff_t>(worst), (uv - w.pixel_px).norm());
        r = r2;
      }
    }
    for (std::size_t k = 0; k < obs.size(); ++k) {
      if (res[obs[k]] < 0) res[obs[k]] = r[k];
    }
  }
  return res;
}

void writeOrthoTif(const std::string& path, const ortho::OrthoResult& o, const dem::DemMetadata& meta) {
  cli::writeViaTemporary(path, [&](const std::string& tmp) {
    GDALAllRegister();
    GDALDriver* drv = GetGDALDriverManager()->GetDriverByName("GTiff");
    if (drv == nullptr) throw std::runtime_error(path + ": GDAL GTiff driver missing");
    GDALDataset* ds = drv->Create(tmp.c_str(), o.grid.cols, o.grid.rows, 1, GDT_Byte, nullptr);
    if (ds == nullptr) throw std::runtime_error(path + ": cannot create");
    double gt[6] = {o.grid.east0_m, o.grid.cell_m, 0.0, o.grid.north0_m, 0.0, -o.grid.cell_m};
    ds->SetGeoTransform(gt);
    ds->SetMetadataItem("AREA_OR_POINT", "Area");
    GDALRasterBand* band = ds->GetRasterBand(1);
    band->SetNoDataValue(0.0);
    cv::Mat img = o.image.isContinuous() ? o.image : o.image.clone();
    const CPLErr err = band->RasterIO(GF_Write, 0, 0, o.grid.cols, o.grid.rows, img.data, o.grid.cols, o.grid.rows,
                                      GDT_Byte, 0, 0);
    GDALClose(ds);
    if (err != CE_None) throw std::runtime_error(path + ": write failed");
    dem::tagSiteRaster(tmp, meta, "grey value (8-bit), 0 = no data");
    dem::verifyRaster(tmp, o.grid.cols, o.grid.rows, false, img.data);
  });
}

}  // namespace

ProductsResult makeProducts(const ProductInputs& in, const ProductOptions& options, const std::string& out_dir,
                            ground::AdjustReport& report) {
  std::error_code ec;
  fs::create_directories(out_dir, ec);
  if (ec || !fs::is_directory(out_dir)) throw cli::InputError(out_dir, "out", "cannot create the folder");
  Context ctx{ProductsResult{}, report};
  auto stage = [&](const std::string& name, double t0) { report.seconds.emplace_back(name, cli::nowSeconds() - t0); };
  std::set<std::string> warned;

  // Tie observations per image and point: pixels for the parallax ranges.
  std::map<std::pair<int, int>, Vec2> tie_px;  // (image, point) -> pixel
  for (const ProductTie& t : in.ties) tie_px[{t.image, t.point}] = t.pixel_px;

  // 1. Rectify, match and triangulate every pair.
  Cloud cloud;
  {
    // Reserved for the largest possible cloud (address space only: pages are touched as points arrive), so
    // that growing never copies gigabytes or doubles the footprint.
    std::size_t most = 0;
    for (const ProductPair& pair : in.pairs) {
      if (pair.left >= 0 && pair.left < static_cast<int>(in.images.size())) most += in.images[pair.left].grey.total();
    }
    cloud.reserve(most);
  }
  double t_rect = 0, t_dense = 0, t_tri = 0;
  std::set<int> sols;
  {
    cli::Progress progress("dense matching", in.pairs.size());
    for (const ProductPair& pair : in.pairs) {
      progress.step();
      const std::string name = "pair " + std::to_string(pair.id);
      if (pair.left < 0 || pair.left >= static_cast<int>(in.images.size())) continue;
      const ProductImage& L = in.images[pair.left];
      const bool left_ok = usable(ctx, L, warned);
      if (left_ok) sols.insert(pair.sol);
      if (pair.right < 0 || pair.right >= static_cast<int>(in.images.size())) continue;
      const ProductImage& R = in.images[pair.right];
      const bool right_ok = usable(ctx, R, warned);
      if (!left_ok || !right_ok) {
        ctx.warn(name + ": not matched (image or model unusable)");
        continue;
      }
      std::vector<Vec2> lp, rp;
      for (const auto& kv : tie_px) {
        if (kv.first.first != pair.left) continue;
        auto it = tie_px.find({pair.right, kv.first.second});
        if (it == tie_px.end()) continue;
        lp.push_back(kv.second);
        rp.push_back(it->second);
      }
      dense::PairCloudOptions popt;
      popt.max_disparity_px = options.dense_max_disparity_px;
      popt.match_sigma_px = kMatchSigmaPx;
      popt.max_range_m = options.max_range_m;
      const dense::PairCloud pc = dense::pairCloud(sized(L), sized(R), L.grey, R.grey, lp, rp, pair.id, popt);
      t_rect += pc.seconds_rectify;
      t_dense += pc.seconds_dense;
      if (!pc.error.empty()) {
        ctx.warn(name + ": " + pc.error);
        continue;
      }
      const double t0 = cli::nowSeconds();
      long long kept = 0;
      for (const dense::CloudPoint& p : pc.points) {
        const double range = (p.site_m - in.gimbal_site_m).head<2>().norm();
        if (range > pc.support_range_m) continue;
        cloud.push(p);
        ++kept;
      }
      t_tri += pc.seconds_triangulate + cli::nowSeconds() - t0;
      {
        char b[200];
        std::snprintf(b, sizeof b,
                      "%s: %zu ties, %.1f %% matched, %lld triangulated (%lld geometry, %lld residual "
                      "rejected), %lld kept",
                      name.c_str(), pc.ties, 100 * pc.matched_fraction, pc.stats.triangulated,
                      pc.stats.rejected_geometry, pc.stats.rejected_residual, kept);
        cli::info(b);
      }
      if (kept == 0) {
        ctx.warn(name + ": no valid matches triangulated");
        continue;
      }
      ++ctx.result.pairs_matched;
    }
    progress.done();
  }
  report.seconds.emplace_back("rectify", t_rect);
  report.seconds.emplace_back("dense", t_dense);
  if (!cloud.empty()) {
    long long dropped = 0;
    dropOutliers(cloud, in.gimbal_site_m, options.max_point_sigma_m, dropped);
    cli::info("dense cloud: " + std::to_string(cloud.size()) + " points (" + std::to_string(dropped) +
              " outliers dropped)");
  }
  report.seconds.emplace_back("triangulate", t_tri);
  ctx.result.points = static_cast<long long>(cloud.size());
  dem::DemMetadata meta;
  meta.site = in.site;
  meta.sols.assign(sols.begin(), sols.end());

  if (!cloud.empty()) {
    try {
      // Thinned evenly to at most ply_max_points (a full navcam panorama has ~1.7e7 matches, 0.7 GB).
      const std::size_t stride =
          std::max<std::size_t>(1, (cloud.size() + options.ply_max_points - 1) / std::max<std::size_t>(1, options.ply_max_points));
      // Streamed from the cloud (a thinned copy would be 0.24 GB at the peak of the pass).
      const std::size_t count = (cloud.size() + stride - 1) / stride;
      cli::writeViaTemporary(out_dir + "/points.ply", [&](const std::string& tmp) {
        dense::writePly(tmp, count, [&cloud, stride](std::size_t i) { return cloud.cloudPoint(i * stride); },
                        "areomap " + in.site + " site frame; every " + std::to_string(stride) + ". dense point");
      });
      ctx.result.files.push_back(out_dir + "/points.ply");
    } catch (const std::exception& e) {
      ctx.writeFailed(e);
    }
  } else {
    ctx.warn("no dense points: no points.ply, dem.tif or ortho.tif");
  }

  // 2. DEM: kriging of the binned cloud, equi-parallax beyond the seam, blended.
  double t0 = cli::nowSeconds();
  if (!cloud.empty()) {
    // The DEM needs only the DEM points: taken over (no copy), and the rest of the cloud freed.
    std::vector<dem::DemPoint> pts = std::move(cloud.dem);
    std::vector<PlyExtra>().swap(cloud.extra);
    // The grid covers the points within max_range_m (those beyond only support it).
    const auto in_range = [&](double north_m, double east_m) {
      return std::hypot(north_m - in.gimbal_site_m.x(), east_m - in.gimbal_site_m.y()) <= options.max_range_m;
    };
    const auto in_range_point = [&](const dem::DemPoint& p) { return in_range(p.north_m, p.east_m); };
    std::vector<dem::DemPoint> box = boundingCorners(pts, in_range_point);
    if (box.empty()) box = boundingCorners(pts, [](const dem::DemPoint&) { return true; });  // all beyond it
    double extent = 0;
    for (const dem::DemPoint& c : box) {
      extent = std::max({extent, std::fabs(c.north_m - in.gimbal_site_m.x()), std::fabs(c.east_m - in.gimbal_site_m.y())});
    }
    const double cell = options.cell_m > 0 ? options.cell_m : autoCell(2 * extent);
    DemGrid grid = dem::gridAround(box, cell);
    const auto all = [](const dem::DemPoint&) { return true; };
    const dem::BinnedCloud binned = dem::binPoints(pts, grid, all, dense::kMatchErrorCorrelationPx);
    {
      char b[160];
      std::snprintf(
          b, sizeof b,
          "DEM noise: %.3f of the points' variance does not average down (from %lld bins seen by two pairs)",
          binned.shared_noise_fraction, binned.overlap_bins);
      cli::info(b);
    }
    dem::EquiParallaxOptions eo;
    eo.centre_north_m = in.gimbal_site_m.x();
    eo.centre_east_m = in.gimbal_site_m.y();
    eo.centre_up_m = -in.gimbal_site_m.z();
    eo.seam_m = options.seam_m;
    std::vector<dem::DemPoint> far;
    for (const dem::DemPoint& p : pts) {
      if (std::hypot(p.north_m - eo.centre_north_m, p.east_m - eo.centre_east_m) > eo.seam_m - eo.blend_m - 1.0) {
        far.push_back(p);
      }
    }
    // The finer DEM near the rover (DESIGN.md fixes dem.tif as one grid): when dem.tif is coarser than
    // near_cell_m, the points within near_range_m are kriged again at near_cell_m into dem_near.tif. Its
    // points are binned here, so that the cloud is freed before any kriging.
    std::optional<DemGrid> near_grid;
    dem::BinnedCloud near_binned;
    if (options.near_cell_m > 0 && options.near_range_m > 0 && cell > options.near_cell_m * 1.001) {
      const double reach = options.near_range_m + 0.5;  // points just beyond the edge support it
      const auto is_near = [&](const dem::DemPoint& p) {
        return std::fabs(p.north_m - in.gimbal_site_m.x()) <= reach && std::fabs(p.east_m - in.gimbal_site_m.y()) <= reach;
      };
      std::size_t count = 0;
      const std::vector<dem::DemPoint> corners = boundingCorners(pts, is_near, &count);
      if (count >= 16) {
        try {
          near_grid = dem::gridAround(corners, options.near_cell_m);
          near_binned = dem::binPoints(pts, *near_grid, is_near, dense::kMatchErrorCorrelationPx);
        } catch (const std::exception& e) {
          ctx.warn(std::string("near-rover DEM not made: ") + e.what());
        }
      }
    }
    std::vector<dem::DemPoint>().swap(pts);
    try {
      dem::KrigingResult kr = dem::krigeDem(
          binned.points, grid, dem::binnedKrigingOptions(binned, grid, dense::kMatchErrorCorrelationPx));
      supportInfo("dem.tif", kr);
      if (!far.empty()) {
        DemGrid far_sigma;
        const DemGrid far_dem = dem::equiParallaxDem(far, grid, eo, &far_sigma);
        dem::blendFarRange(kr, far_dem, &far_sigma, eo);
      }
      std::vector<dem::DemPoint>().swap(far);
      for (int r = 0; r < grid.rows; ++r) {
        for (int c = 0; c < grid.cols; ++c) {
          if (in_range(grid.northOfRow(r), grid.eastOfCol(c))) continue;
          kr.elevation.at(c, r) = kr.elevation.nodata;
          kr.sigma.at(c, r) = kr.sigma.nodata;
        }
      }
      ctx.result.dem = kr.elevation;
      try {
        dem::writeDemProducts(out_dir, kr, meta);
        ctx.result.files.push_back(out_dir + "/dem.tif");
        ctx.result.files.push_back(out_dir + "/dem_sigma.tif");
      } catch (const cli::InputError& e) {
        ctx.writeFailed(e);  // the DEM is still used for the ortho and the previews
      }
      if (in.truth_dem) {
        double s2 = 0;
        long long n = 0;
        const DemGrid& g = kr.elevation;
        for (int r = 0; r < g.rows; ++r) {
          for (int c = 0; c < g.cols; ++c) {
            const float v = g.at(c, r);
            if (v == g.nodata) continue;
            double t = 0;
            if (!ortho::demElevation(*in.truth_dem, g.northOfRow(r), g.eastOfCol(c), t)) continue;
            s2 += (v - t) * (v - t);
            ++n;
          }
        }
        if (n > 0) {
          ctx.result.dem_rmse_m = std::sqrt(s2 / n);
          if (report.truth) report.truth->dem_rmse_m = ctx.result.dem_rmse_m;
        }
      }
    } catch (const std::exception& e) {
      ctx.warn(std::string("DEM not made: ") + e.what());
    }
    if (ctx.result.dem && near_grid) {
      try {
        const dem::KrigingResult nk = dem::krigeDem(
            near_binned.points, *near_grid,
            dem::binnedKrigingOptions(near_binned, *near_grid, dense::kMatchErrorCorrelationPx));
        supportInfo("dem_near.tif", nk);
        ctx.result.dem_near = nk.elevation;
        try {
          dem::writeDemProducts(out_dir, nk, meta, "dem_near");
          ctx.result.files.push_back(out_dir + "/dem_near.tif");
          ctx.result.files.push_back(out_dir + "/dem_near_sigma.tif");
        } catch (const cli::InputError& e) {
          ctx.writeFailed(e);
        }
      } catch (const std::exception& e) {
        ctx.warn(std::string("near-rover DEM not made: ") + e.what());
      }
    }
  }
  stage("dem", t0);

  // 3. Orthoimage on the DEM grid.
  t0 = cli::nowSeconds();
  ortho::OrthoResult orth;
  bool have_ortho = false;
  if (ctx.result.dem) {
    std::vector<ortho::OrthoSource> sources;
    for (const ProductImage& im : in.images) {
      ortho::OrthoSource s;
      if (usable(ctx, im, warned)) {
        s.grey = im.grey;
        s.model = sized(im);
      }
      sources.push_back(s);
    }
    try {
      orth = ortho::makeOrthoimage(*ctx.result.dem, sources, ortho::OrthoOptions{});
      have_ortho = true;  // the preview and the report show it even when ortho.tif cannot be written
      if (orth.seams.checked > 0) {
        ctx.result.ortho_seam_px = orth.seams.geometric_median_px;
        if (orth.seams.geometric_median_px > 0.5) {
          char b[200];
          std::snprintf(b, sizeof b,
                        "ortho seams: images disagree by %.2f px (median; RMS %.2f, 95 %% %.2f px) at %lld seam cells",
                        orth.seams.geometric_median_px, orth.seams.geometric_rms_px, orth.seams.geometric_p95_px,
                        orth.seams.checked);
          ctx.warn(b);
        }
      }
      writeOrthoTif(out_dir + "/ortho.tif", orth, meta);
      ctx.result.files.push_back(out_dir + "/ortho.tif");
    } catch (const cli::InputError& e) {
      ctx.writeFailed(e);
    } catch (const std::exception& e) {
      ctx.warn(std::string("ortho.tif not made: ") + e.what());
    }
  }
  stage("ortho", t0);

  // 4. Previews, overlays, report.html.
  t0 = cli::nowSeconds();
  HtmlInputs html;
  html.site = in.site;
  html.report = &report;
  if (ctx.result.dem) {
    const cv::Mat p = demPreview(*ctx.result.dem);
    writePng(ctx, out_dir + "/dem.png", p);
    char caption[96];
    std::snprintf(caption, sizeof caption, "DEM (colour relief, hillshade from the north-west), cell %.3f m",
                  ctx.result.dem->cell_m);
    html.products.push_back({caption, p});
  }
  if (have_ortho) {
    const cv::Mat p = orthoPreview(orth.image, orth.valid, orth.grid.cell_m);
    writePng(ctx, out_dir + "/ortho.png", p);
    html.products.push_back({"Orthoimage", p});
  }
  std::vector<CameraModel> models;
  std::vector<bool> ok;
  for (const ProductImage& im : in.images) {
    ok.push_back(usable(ctx, im, warned));
    models.push_back(ok.back() ? sized(im) : im.model);
  }
  const std::vector<double> residuals = tieResiduals(in, models, ok);
  std::map<int, std::pair<double, int>> per_image;  // sum of squares, count
  for (std::size_t i = 0; i < in.ties.size(); ++i) {
    const double v = residuals[i];
    if (v < 0) continue;
    html.residuals_px.push_back(v);
    auto& acc = per_image[in.ties[i].image];
    acc.first += v * v;
    acc.second += 1;
  }
  ctx.result.residuals_px = html.residuals_px;
  for (const auto& kv : per_image) {
    if (kv.first < 0 || kv.first >= static_cast<int>(in.images.size())) continue;
    html.image_rms_px.emplace_back(in.images[kv.first].stem, std::sqrt(kv.second.first / kv.second.second));
  }
  for (std::size_t i = 0; i < in.images.size(); ++i) {
    const ProductImage& im = in.images[i];
    if (im.grey.empty() || im.grey.type() != CV_8U) continue;
    std::vector<Vec2> px;
    std::vector<bool> inter;
    for (const ProductTie& t : in.ties) {
      if (t.image != static_cast<int>(i)) continue;
      px.push_back(t.pixel_px);
      inter.push_back(t.inter);
    }
    const cv::Mat o = tieOverlay(im.grey, px, inter);
    if (options.write_overlays) {
      fs::create_directories(out_dir + "/overlays", ec);
      writePng(ctx, out_dir + "/overlays/" + im.stem + ".png", o);
    }
    html.overlays.push_back({im.stem + " (" + std::to_string(px.size()) + " tie points)", o});
  }
  stage("previews", t0);

  for (const std::string& w : ctx.result.warnings) report.warnings.push_back(w);
  html.warnings = report.warnings;
  char b[128];
  html.summary.emplace_back("site", in.site);
  html.summary.emplace_back("images", std::to_string(in.images.size()));
  html.summary.emplace_back("stereo pairs matched", std::to_string(ctx.result.pairs_matched) + " of " +
                                                        std::to_string(in.pairs.size()));
  html.summary.emplace_back("dense points", std::to_string(ctx.result.points));
  if (ctx.result.dem) {
    std::snprintf(b, sizeof b, "%d x %d cells of %.3f m", ctx.result.dem->cols, ctx.result.dem->rows,
                  ctx.result.dem->cell_m);
    html.summary.emplace_back("DEM", b);
  }
  if (ctx.result.dem_near) {
    std::snprintf(b, sizeof b, "dem_near.tif: %d x %d cells of %.3f m within %.0f m", ctx.result.dem_near->cols,
                  ctx.result.dem_near->rows, ctx.result.dem_near->cell_m, options.near_range_m);
    html.summary.emplace_back("DEM near the rover", b);
  }
  if (ctx.result.dem_rmse_m) {
    std::snprintf(b, sizeof b, "%.4f m", *ctx.result.dem_rmse_m);
    html.summary.emplace_back("DEM RMSE against truth", b);
  }
  if (ctx.result.ortho_seam_px >= 0) {
    std::snprintf(b, sizeof b, "%.2f px (median over seam cells)", ctx.result.ortho_seam_px);
    html.summary.emplace_back("ortho seam disagreement", b);
  }
  try {
    cli::writeFileAtomic(out_dir + "/report.html", reportHtml(html));
    ctx.result.files.push_back(out_dir + "/report.html");
  } catch (const std::exception& e) {
    ctx.writeFailed(e);
  }
  return ctx.result;
}

}  // namespace areomap::products
