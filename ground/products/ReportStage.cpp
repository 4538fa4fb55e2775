#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <map>
#include <set>

#include "ground/cli/AtomicFile.hpp"
#include "ground/cli/Cli.hpp"
#include "ground/cli/Parallel.hpp"
#include "ground/dense/Triangulation.hpp"
#include "ground/products/Previews.hpp"
#include "ground/products/ProductStages.hpp"
#include "ground/products/ReportHtml.hpp"
#include "ground/raster/RasterFiles.hpp"

namespace areomap::products {

namespace {

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
      if (t.image < 0 || t.image >= static_cast<int>(ok.size()) || !ok[t.image] ||
          !seen.insert(t.image).second)
        continue;
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

// The previews (dem.png and ortho.png as item 0, each image's tie overlay as item 1 + its index) made and
// encoded in parallel, recorded in item order (files, write errors, the report's figures), so that the
// files and the report are those of a serial run; with item 0 the images' usable models and flags (`models`,
// `ok`, warned in a serial run's order).
void previews(Context& ctx, const ortho::OrthoResult* ortho, HtmlInputs& html, std::vector<CameraModel>& models,
              std::vector<bool>& ok) {
  struct Preview {
    cv::Mat dem, ortho, overlay;
    std::exception_ptr dem_error, ortho_error, overlay_error;
    std::size_t ties = 0;
  };
  const auto encode = [](const std::string& path, const cv::Mat& image) -> std::exception_ptr {
    try {
      raster::writePng(path, image);
    } catch (const std::exception&) {
      return std::current_exception();
    }
    return nullptr;
  };
  const auto record = [&ctx](const std::string& path, const std::exception_ptr& error) {
    try {
      if (error) std::rethrow_exception(error);
      ctx.result.files.push_back(path);
    } catch (const std::exception& e) {
      ctx.writeFailed(e);
    }
  };
  const std::string dem_png = ctx.out_dir + "/dem.png", ortho_png = ctx.out_dir + "/ortho.png";
  const auto overlay_png = [&ctx](const ProductImage& im) { return ctx.out_dir + "/overlays/" + im.stem + ".png"; };
  const auto drawn = [](const ProductImage& im) { return !im.grey.empty() && im.grey.type() == CV_8U; };
  if (ctx.options.write_overlays && std::any_of(ctx.in.images.begin(), ctx.in.images.end(), drawn)) {
    std::error_code ec;
    std::filesystem::create_directories(ctx.out_dir + "/overlays", ec);
  }
  const auto make = [&](std::size_t item) {
    Preview p;
    if (item == 0) {
      if (ctx.result.dem) {
        p.dem = demPreview(*ctx.result.dem);
        p.dem_error = encode(dem_png, p.dem);
      }
      if (ortho != nullptr) {
        p.ortho = orthoPreview(ortho->image, ortho->valid, ortho->grid.cell_m);
        p.ortho_error = encode(ortho_png, p.ortho);
      }
      return p;
    }
    const std::size_t i = item - 1;
    const ProductImage& im = ctx.in.images[i];
    if (!drawn(im)) return p;
    std::vector<Vec2> px;
    std::vector<bool> inter;
    for (const ProductTie& t : ctx.in.ties) {
      if (t.image != static_cast<int>(i)) continue;
      px.push_back(t.pixel_px);
      inter.push_back(t.inter);
    }
    p.ties = px.size();
    p.overlay = tieOverlay(im.grey, px, inter);
    if (ctx.options.write_overlays) p.overlay_error = encode(overlay_png(im), p.overlay);
    return p;
  };
  const auto use = [&](std::size_t item, Preview p) {
    if (item == 0) {
      if (ctx.result.dem) {
        record(dem_png, p.dem_error);
        char caption[96];
        std::snprintf(caption, sizeof caption, "DEM (colour relief, hillshade from the north-west), cell %.3f m",
                      ctx.result.dem->cell_m);
        html.products.push_back({caption, p.dem});
      }
      if (ortho != nullptr) {
        record(ortho_png, p.ortho_error);
        html.products.push_back({"Orthoimage", p.ortho});
      }
      for (const ProductImage& im : ctx.in.images) {
        ok.push_back(usable(ctx, im));
        models.push_back(ok.back() ? sized(im) : im.model);
      }
      return;
    }
    const ProductImage& im = ctx.in.images[item - 1];
    if (!drawn(im)) return;
    if (ctx.options.write_overlays) record(overlay_png(im), p.overlay_error);
    html.overlays.push_back({im.stem + " (" + std::to_string(p.ties) + " tie points)", p.overlay});
  };
  cli::orderedFor(1 + ctx.in.images.size(), 0, make, use);
}

}  // namespace

void previewsAndReport(Context& ctx, const ortho::OrthoResult* ortho,
                       const ground::AdjustReport* adjustment) {
  const double t0 = cli::nowSeconds();
  HtmlInputs html;
  html.site = ctx.in.site;
  std::vector<CameraModel> models;
  std::vector<bool> ok;
  previews(ctx, ortho, html, models, ok);
  const std::vector<double> residuals = tieResiduals(ctx.in, models, ok);
  std::map<int, std::pair<double, int>> per_image;  // sum of squares, count
  for (std::size_t i = 0; i < ctx.in.ties.size(); ++i) {
    const double v = residuals[i];
    if (v < 0) continue;
    html.residuals_px.push_back(v);
    auto& acc = per_image[ctx.in.ties[i].image];
    acc.first += v * v;
    acc.second += 1;
  }
  ctx.result.residuals_px = html.residuals_px;
  for (const auto& kv : per_image) {
    if (kv.first < 0 || kv.first >= static_cast<int>(ctx.in.images.size())) continue;
    html.image_rms_px.emplace_back(ctx.in.images[kv.first].stem,
                                   std::sqrt(kv.second.first / kv.second.second));
  }
  ctx.result.seconds.emplace_back("previews", cli::nowSeconds() - t0);

  // report.html shows the adjustment's report with the products' part merged in, as report.json will.
  ground::AdjustReport merged = adjustment != nullptr ? *adjustment : ground::AdjustReport{};
  mergeIntoReport(ctx.result, merged);
  html.report = &merged;
  html.warnings = merged.warnings;
  char b[128];
  html.summary.emplace_back("site", ctx.in.site);
  html.summary.emplace_back("images", std::to_string(ctx.in.images.size()));
  html.summary.emplace_back("stereo pairs matched", std::to_string(ctx.result.pairs_matched) + " of " +
                                                        std::to_string(ctx.in.pairs.size()));
  html.summary.emplace_back("dense points", std::to_string(ctx.result.points));
  if (ctx.result.dem) {
    std::snprintf(b, sizeof b, "%d x %d cells of %.3f m", ctx.result.dem->cols, ctx.result.dem->rows,
                  ctx.result.dem->cell_m);
    html.summary.emplace_back("DEM", b);
  }
  if (ctx.result.dem_near) {
    std::snprintf(b, sizeof b, "dem_near.tif: %d x %d cells of %.3f m within %.0f m",
                  ctx.result.dem_near->cols, ctx.result.dem_near->rows, ctx.result.dem_near->cell_m,
                  ctx.options.near_range_m);
    html.summary.emplace_back("DEM near the rover", b);
  }
  if (ctx.result.dem_rmse_m) {
    std::snprintf(b, sizeof b, "%.4f m", *ctx.result.dem_rmse_m);
    html.summary.emplace_back("DEM RMSE against truth", b);
  }
  long seen = 0, filled = 0;
  ground::demCoverageTotal(ctx.result.coverage, seen, filled);
  if (seen > 0) {
    std::snprintf(b, sizeof b, "%.1f %% of the cells both cameras of a pair see at 2-10 m",
                  100.0 * static_cast<double>(filled) / static_cast<double>(seen));
    html.summary.emplace_back("DEM coverage", b);
  }
  if (ctx.result.ortho_seam_px >= 0) {
    std::snprintf(b, sizeof b, "%.2f px (median over seam cells)", ctx.result.ortho_seam_px);
    html.summary.emplace_back("ortho seam disagreement", b);
  }
  try {
    cli::writeFileAtomic(ctx.out_dir + "/report.html", reportHtml(html));
    ctx.result.files.push_back(ctx.out_dir + "/report.html");
  } catch (const std::exception& e) {
    ctx.writeFailed(e);
  }
}

}  // namespace areomap::products
