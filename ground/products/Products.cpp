#include "ground/products/Products.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <optional>
#include <stdexcept>

#include "ground/cli/AtomicFile.hpp"
#include "ground/cli/Cli.hpp"
#include "ground/cli/Parallel.hpp"
#include "ground/dem/SiteDem.hpp"
#include "ground/products/CameraHeightError.hpp"
#include "ground/dense/DenseMatcher.hpp"
#include "ground/products/ProductStages.hpp"
#include "ground/raster/RasterFiles.hpp"

namespace areomap::products {

void Context::warn(const std::string& text) {
  cli::warn(text);
  result.warnings.push_back(text);
}

const DemGrid* Context::truthDem() {
  if (in.truth_dem) return &*in.truth_dem;
  if (!truth_dem_read && !in.truth_dem_path.empty()) truth_dem_read = readDemGeoTiff(in.truth_dem_path);
  return truth_dem_read ? &*truth_dem_read : nullptr;
}

void Context::writeFailed(const std::exception& e) {
  warn(e.what());
  result.write_errors.push_back(e.what());
}

void writePng(Context& ctx, const std::string& path, const cv::Mat& image) {
  try {
    raster::writePng(path, image);
    ctx.result.files.push_back(path);
  } catch (const std::exception& e) {
    ctx.writeFailed(e);
  }
}

std::string unusableReason(const ProductImage& im) {
  if (im.grey.empty()) return "image " + im.stem + ": missing; its products are skipped";
  if (im.grey.type() != CV_8U) return "image " + im.stem + ": not 8-bit grey; skipped";
  const char* field = "";
  if (validateModel(im.model, field) != Status::kOk)
    return "model " + im.stem + ": invalid component " + field + "; skipped";
  if (im.model.width > 0 && (im.model.width != im.grey.cols || im.model.height != im.grey.rows)) {
    return "model " + im.stem + ": size " + std::to_string(im.model.width) + "x" +
           std::to_string(im.model.height) + " is inconsistent with the image (" +
           std::to_string(im.grey.cols) + "x" + std::to_string(im.grey.rows) + "); skipped";
  }
  return "";
}

// An image is usable when it is present and its model describes an image of its size.
bool usable(Context& ctx, const ProductImage& im) {
  const std::string reason = unusableReason(im);
  if (reason.empty()) return true;
  if (ctx.warned.insert(im.stem).second) ctx.warn(reason);
  return false;
}

CameraModel sized(const ProductImage& im) {
  CameraModel m = im.model;
  m.width = im.grey.cols;
  m.height = im.grey.rows;
  return m;
}

namespace {

// RMS of the DEM's differences from the true DEM over the cells present in both; none when there are none.
std::optional<double> rmseAgainst(const DemGrid& g, const DemGrid& truth) {
  double s2 = 0;
  long long n = 0;
  for (int r = 0; r < g.rows; ++r) {
    for (int c = 0; c < g.cols; ++c) {
      const float v = g.at(c, r);
      if (v == g.nodata) continue;
      double t = 0;
      if (!ortho::demElevation(truth, g.northOfRow(r), g.eastOfCol(c), t)) continue;
      s2 += (v - t) * (v - t);
      ++n;
    }
  }
  if (n == 0) return std::nullopt;
  return std::sqrt(s2 / n);
}

void writeOrthoTif(const std::string& path, const ortho::OrthoResult& o, const dem::DemMetadata& meta) {
  cli::writeViaTemporary(path, [&](const std::string& tmp) {
    const cv::Mat img = o.image.isContinuous() ? o.image : o.image.clone();
    const raster::Geometry g{o.grid.cols, o.grid.rows, o.grid.east0_m, o.grid.north0_m, o.grid.cell_m};
    raster::writeGeoTiff(tmp, g, img.data, 0);
    raster::tagSiteRaster(tmp, meta, "grey value (8-bit), 0 = no data");
    raster::verifyRaster(tmp, o.grid.cols, o.grid.rows, false, img.data);
  });
}

// The ortho's grey values as a grid of ortho.tif's georeferencing (what reading ortho.tif gives).
DemGrid orthoGrid(const ortho::OrthoResult& o) {
  DemGrid g = o.grid;
  g.nodata = 0.0f;
  g.values.resize(static_cast<std::size_t>(g.cols) * g.rows);
  for (int r = 0; r < g.rows; ++r) {
    for (int c = 0; c < g.cols; ++c) g.at(c, r) = o.image.at<uint8_t>(r, c);
  }
  return g;
}

// Of what each pair's cameras see at 2-5 m and 5-10 m, how much the DEM covers; the ground under empty
// cells from the plane of the DEM's cells within twice the outer range of the panorama's centre. Counted
// off the run's thread (coverageCounts), said and recorded on it (recordCoverage).
struct PairCoverage {
  int id = 0;
  CoverageCount near, far;
};

std::vector<PairCoverage> coverageCounts(const ProductInputs& in, const DemGrid& dem, const DemGrid& sigma) {
  constexpr double kNear = 2.0, kMid = 5.0, kFar = 10.0;
  constexpr double kSampleM = 0.1;  // a lattice of 10 cm: a band's figure in a small part of the DEM's time
  std::vector<PairCoverage> out;
  GroundPlane plane;
  if (!groundPlane(dem, in.gimbal_site_m, 2.0 * kFar, plane)) return out;
  for (const ProductPair& p : in.pairs) {
    if (p.left < 0 || p.right < 0) continue;
    const ProductImage& l = in.images[p.left];
    const ProductImage& r = in.images[p.right];
    if (l.grey.empty() || r.grey.empty()) continue;
    out.push_back({p.id, demCoverage(dem, &sigma, sized(l), sized(r), plane, kNear, kMid, kSampleM),
                   demCoverage(dem, &sigma, sized(l), sized(r), plane, kMid, kFar, kSampleM)});
  }
  return out;
}

void recordCoverage(Context& ctx, const std::vector<PairCoverage>& counts) {
  for (const PairCoverage& c : counts) {
    ctx.result.coverage.push_back({c.id, c.near.seen, c.near.filled, c.far.seen, c.far.filled});
    auto figure = [](const CoverageCount& n) {
      char f[48];
      if (n.seen == 0) return std::string("none seen");
      std::snprintf(f, sizeof f, "%.1f %%", 100 * n.fraction());
      return std::string(f);
    };
    cli::info("pair " + std::to_string(c.id) + ": the DEM covers " + figure(c.near) + " (2-5 m) and " +
              figure(c.far) + " (5-10 m) of what both cameras see");
  }
}

// Step 2: the DEMs (ground/dem SiteDem) from the cloud's DEM points; the cloud is freed. Their rasters are
// written by finishProducts.
std::optional<dem::SiteDem> demStage(Context& ctx, Cloud& cloud) {
  const double t0 = cli::nowSeconds();
  std::optional<dem::SiteDem> made;
  if (!cloud.empty()) {
    // The DEM needs only the DEM points: taken over (no copy), and the rest of the cloud freed.
    std::vector<PlyExtra>().swap(cloud.extra);
    dem::SiteDemOptions so;
    so.gimbal_site_m = ctx.in.gimbal_site_m;
    so.cell_m = ctx.options.cell_m;
    so.near_cell_m = ctx.options.near_cell_m;
    so.near_range_m = ctx.options.near_range_m;
    so.max_range_m = ctx.options.max_range_m;
    so.seam_m = ctx.options.seam_m;
    so.correlation_px = dense::kMatchErrorCorrelationPx;
    for (const ProductImage& im : ctx.in.images) {
      if (usable(ctx, im)) so.cameras.push_back(sized(im));
    }
    const std::optional<dem::SharedHeightError> cameras = cameraHeightError(ctx.in);
    if (cameras) so.shared_error = &*cameras;
    made = dem::makeSiteDem(std::move(cloud.dem), so);
    const dem::SiteDem& dems = *made;
    for (const std::string& w : dems.warnings) ctx.result.warnings.push_back(w);
    ctx.result.dem_points = dems.points_binned;
    if (dems.dem) {
      ctx.result.dem = dems.dem->elevation;
      ctx.result.dem_sigma = dems.dem->sigma;
      ctx.result.dem_seen = dems.dem_seen.classes;
    }
    if (dems.near) ctx.result.dem_near = dems.near->elevation;
  }
  ctx.result.seconds.emplace_back("dem", cli::nowSeconds() - t0);
  return made;
}

// The orthoimage's sources: every image, empty where it is not usable (warned here, on the run's thread).
std::vector<ortho::OrthoSource> orthoSources(Context& ctx) {
  std::vector<ortho::OrthoSource> sources;
  for (const ProductImage& im : ctx.in.images) {
    ortho::OrthoSource s;
    if (usable(ctx, im)) {
      s.grey = im.grey;
      s.model = sized(im);
    }
    sources.push_back(s);
  }
  return sources;
}

// The ortho as made (or what its making threw), recorded and written: ortho.tif (absent when the making
// failed).
void recordOrtho(Context& ctx, const std::optional<ortho::OrthoResult>& made, const std::exception_ptr& error) {
  try {
    if (error) std::rethrow_exception(error);
    const ortho::OrthoResult& orth = *made;  // the preview and the report show it even when ortho.tif cannot be written
    ctx.result.ortho = orthoGrid(orth);
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
    writeOrthoTif(ctx.out_dir + "/ortho.tif", orth, ctx.meta);
    ctx.result.files.push_back(ctx.out_dir + "/ortho.tif");
  } catch (const cli::InputError& e) {
    ctx.writeFailed(e);
  } catch (const std::exception& e) {
    ctx.warn(std::string("ortho.tif not made: ") + e.what());
  }
}

// A DEM's three rasters, written (or what the writing threw).
std::exception_ptr writeDem(const Context& ctx, const dem::KrigingResult& kr, const char* stem,
                            const dem::DemSeen& seen) {
  try {
    dem::writeDemProducts(ctx.out_dir, kr, ctx.meta, stem, &seen);
  } catch (...) {
    return std::current_exception();
  }
  return nullptr;
}

// Recorded as the run's files, or as its write error (the DEM is still used for the ortho and the
// previews); any other failure goes on up.
void recordDemWrite(Context& ctx, const std::exception_ptr& error, const char* stem) {
  try {
    if (error) std::rethrow_exception(error);
    for (const char* suffix : {".tif", "_sigma.tif", "_seen.tif"})
      ctx.result.files.push_back(ctx.out_dir + "/" + stem + suffix);
  } catch (const cli::InputError& e) {
    ctx.writeFailed(e);
  }
}

// Step 3: the DEMs' rasters written, the DEM's coverage and RMSE, and the orthoimage on the DEM grid:
// independent of one another, so made side by side (the rasters' compression, the coverage and the RMSE
// beside the ortho's rows), then said, recorded and written in the order of a serial run. Returns the
// ortho (none when there is no DEM or its making failed).
std::optional<ortho::OrthoResult> finishProducts(Context& ctx, const std::optional<dem::SiteDem>& dems) {
  const double t0 = cli::nowSeconds();
  const dem::KrigingResult* kr = dems && dems->dem ? &*dems->dem : nullptr;
  const dem::KrigingResult* near = dems && dems->near ? &*dems->near : nullptr;
  const DemGrid* truth = nullptr;  // read beside the ortho's making (task 1), for the RMSE
  std::vector<ortho::OrthoSource> sources;
  if (ctx.result.dem) sources = orthoSources(ctx);
  std::exception_ptr dem_error, near_error, ortho_error;
  std::vector<PairCoverage> coverage;
  std::optional<double> rmse;
  std::optional<ortho::OrthoResult> made;
  cli::parallelFor(3, 0, [&](std::size_t task) {
    if (task == 0 && ctx.result.dem) {
      try {
        ortho::OrthoOptions oo;
        if (ctx.result.dem_sigma) oo.dem_sigma = &*ctx.result.dem_sigma;
        made = ortho::makeOrthoimage(*ctx.result.dem, sources, oo);
      } catch (...) {
        ortho_error = std::current_exception();
      }
    }
    if (task == 1 && kr != nullptr) {
      coverage = coverageCounts(ctx.in, kr->elevation, kr->sigma);
      truth = ctx.truthDem();
      if (truth != nullptr) rmse = rmseAgainst(kr->elevation, *truth);
    }
    if (task == 2 && kr != nullptr) {
      dem_error = writeDem(ctx, *kr, "dem", dems->dem_seen);
      if (near != nullptr) near_error = writeDem(ctx, *near, "dem_near", dems->near_seen);
    }
  });
  if (kr != nullptr) {
    recordCoverage(ctx, coverage);
    recordDemWrite(ctx, dem_error, "dem");
    if (truth != nullptr) ctx.result.dem_rmse_m = rmse;
    if (near != nullptr) recordDemWrite(ctx, near_error, "dem_near");
  }
  if (ctx.result.dem) recordOrtho(ctx, made, ortho_error);
  ctx.result.seconds.emplace_back("ortho", cli::nowSeconds() - t0);
  return made;
}

// What the true cameras see against the DEM and the ortho (TruthSeen.hpp), with the true models and DEM.
void truthSeenStage(Context& ctx, const ortho::OrthoResult* orth) {
  const ProductInputs& in = ctx.in;
  const DemGrid* truth_dem = ctx.result.dem ? ctx.truthDem() : nullptr;
  if (truth_dem == nullptr || in.truth_models.size() != in.images.size()) return;
  std::vector<cv::Mat> images;
  std::vector<CameraModel> models, adjusted;
  for (std::size_t k = 0; k < in.images.size(); ++k) {
    images.push_back(in.images[k].grey);
    adjusted.push_back(in.images[k].model);
    models.push_back(in.truth_models[k]);
    models.back().width = in.images[k].grey.cols;
    models.back().height = in.images[k].grey.rows;
  }
  const cv::Mat* ortho_image = orth != nullptr && orth->grid.cols == ctx.result.dem->cols ? &orth->image : nullptr;
  const SeenTruth t = seenAgainstTruth(*ctx.result.dem, ortho_image, *truth_dem, images, models,
                                       truthFrame(adjusted, models, in.gimbal_site_m), ctx.options.max_range_m,
                                       &ctx.result.dem_seen);
  ctx.result.seen_truth = t;
  const auto pc = [](const std::optional<double>& f) { return f ? 100.0 * *f : -1.0; };
  char b[320];
  std::snprintf(b, sizeof b,
                "truth: of %lld cells the true cameras do not see %.1f %% empty (%lld hold points); of %lld they "
                "see %.1f %% filled, the ortho agreeing with truth's on %.1f %% (-1: none)",
                t.cells_unseen, pc(t.unseen_empty), t.unseen_measured, t.cells_seen, pc(t.seen_filled),
                pc(t.ortho_agreement));
  cli::info(b);
}

}  // namespace

ProductsResult makeProducts(const ProductInputs& in, const ProductOptions& options,
                            const std::string& out_dir, const ground::AdjustReport* adjustment) {
  std::error_code ec;
  std::filesystem::create_directories(out_dir, ec);
  if (ec || !std::filesystem::is_directory(out_dir))
    throw cli::InputError(out_dir, "out", "cannot create the folder");
  Context ctx{in, options, out_dir, ProductsResult{}, {}, {}, {}};
  Cloud cloud = denseCloud(ctx);
  const std::optional<ortho::OrthoResult> orth = finishProducts(ctx, demStage(ctx, cloud));
  truthSeenStage(ctx, orth ? &*orth : nullptr);
  ctx.truth_dem_read.reset();
  previewsAndReport(ctx, orth ? &*orth : nullptr, adjustment);
  return ctx.result;
}

void mergeIntoReport(const ProductsResult& products, ground::AdjustReport& report) {
  for (const auto& stage : products.seconds) report.seconds.push_back(stage);
  for (const std::string& w : products.warnings) report.warnings.push_back(w);
  report.dense_pairs = products.dense_pairs;
  report.dem_coverage = products.coverage;
  if (report.truth) {
    report.truth->dem_rmse_m = products.dem_rmse_m;
    if (products.seen_truth) {
      report.truth->dem_unseen_empty = products.seen_truth->unseen_empty;
      report.truth->dem_seen_filled = products.seen_truth->seen_filled;
      report.truth->ortho_agreement = products.seen_truth->ortho_agreement;
    }
  }
}

}  // namespace areomap::products
