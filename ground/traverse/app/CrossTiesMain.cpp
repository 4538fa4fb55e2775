// areomap-cross-ties TRAVERSE --products DIR --out DIR: cross-site tie points between neighbouring sites of
// a traverse (issue 21), from each site's ground products.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iterator>
#include <map>
#include <memory>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "ground/cli/AtomicFile.hpp"
#include "ground/cli/Cli.hpp"
#include "ground/dataset/Traverse.hpp"
#include "ground/traverse/CrossSiteTies.hpp"
#include "ground/traverse/TruthCheck.hpp"

namespace {

using json = nlohmann::json;
using namespace areomap;
using namespace areomap::traverse;

constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;

constexpr const char* kUsage =
    "usage: areomap-cross-ties TRAVERSE --products DIR --out DIR [--sites ID,...] [--all-pairs] "
    "[--truth-products]\n"
    "\n"
    "Cross-site tie points between the sites of a traverse (README \"Multi-site traverse\"): for each pair "
    "of\n"
    "neighbouring sites (driving order), their DEMs are registered to refine the a-priori relative pose\n"
    "(traverse.json; searched over 3 odometry sigmas), then Förstner points of the later site's images are "
    "cast onto its DEM, predicted into\n"
    "the earlier site's images and matched by NCC on DEM-warped patches (second-peak ratio, least-squares\n"
    "sub-pixel, back-match), and checked by a bundle of the relative pose and the points with trimming.\n"
    "\n"
    "  --products DIR     each site's areomap-ground products in DIR/<site id>/ (models/<stem>.cahvor,\n"
    "                     dem.tif, dem_sigma.tif when present)\n"
    "  --out DIR          writes DIR/cross_ties.csv (point,site,image,sample_px,line_px; point ids unique\n"
    "                     over all pairs) and DIR/cross_ties.json (per site pair: status, DEM registration,\n"
    "                     the ties' relative pose, counts and, on a synthetic traverse, errors against "
    "truth)\n"
    "  --all-pairs        every pair of sites, not only neighbours (pairs without overlap get status\n"
    "                     no_overlap)\n"
    "  --truth-products   use each site's truth (truth/models, truth/dem.tif averaged to --truth-cell-m,\n"
    "                     default 0.05) instead of --products: the matcher alone, for checking\n"
    "  --sites ID,ID,...  only these sites (pairs of neighbours among them, in driving order)\n"
    "  --ncc X            NCC threshold (default 0.75); --radius-px R search radius (default 6)\n"
    "  --plane-warp       warp patches by the DEM's local plane only (the matcher before the per-sample\n"
    "                     DEM warp; for comparison)\n"
    "  --translation-lsm  least-squares sub-pixel step with a translation only (no affine correction of\n"
    "                     the warp; for comparison)\n"
    "  --fixed-radius     search radii of 16 px (first pass) and 4 px (second) instead of those derived\n"
    "                     from the pose's covariance and the DEM sigma (for comparison)\n"
    "  --isotropic        the finer image low-passed by its pyramid level of the mean scale only (for\n"
    "                     comparison)\n"
    "  --no-edge-clip     refuse a point whose search window leaves the image (else the search is clipped\n"
    "                     at the edge; for comparison). All five: the matcher before issue 21's reach work\n"
    "\n"
    "A pair of sites whose DEMs do not overlap, or match ambiguously, is reported with its status and no\n"
    "ties; that is not an error. Exit: 0 ok, 2 usage error, 1 bad input (the message names the file and\n"
    "the field).\n";

json poseJson(const RelativePose& p) {
  return json{{"position_m", {p.translation_m.x(), p.translation_m.y(), p.translation_m.z()}},
              {"heading_deg", p.heading_rad * kRadToDeg}};
}

json countsJson(const CrossTieCounts& c) {
  return json{{"interest_points", c.interest_points},
              {"on_both_dems", c.on_both_dems},
              {"outside_image", c.outside_image},
              {"beyond_range", c.beyond_range},
              {"grazing", c.grazing},
              {"occluded", c.occluded},
              {"scale_gate", c.scale_gate},
              {"too_uncertain", c.too_uncertain},
              {"predicted", c.predicted},
              {"patch_outside", c.patch_outside},
              {"low_ncc", c.low_ncc},
              {"ambiguous", c.ambiguous},
              {"edge_peak", c.edge_peak},
              {"lsm_diverged", c.lsm_diverged},
              {"back_failed", c.back_failed},
              {"matched", c.matched},
              {"back_matched", c.back_matched},
              {"ties_before_check", c.ties_before_check},
              {"rejected_observations", c.rejected_observations},
              {"rejected_ties", c.rejected_ties},
              {"off_dem_ties", c.off_dem_ties}};
}

}  // namespace

int main(int argc, char** argv) {
  return cli::runTool("areomap-cross-ties", argc, argv, kUsage, [](cli::Args& args) {
    const std::string out = args.required("--out");
    const bool truth_products = args.flag("--truth-products");
    const std::optional<std::string> products = args.option("--products");
    const double truth_cell = args.number("--truth-cell-m", 0.05);
    const bool all_pairs = args.flag("--all-pairs");
    const std::optional<std::string> only = args.option("--sites");
    CrossTieParams params;
    params.patch.min_ncc = args.number("--ncc", params.patch.min_ncc);
    params.patch.radius_px = args.number("--radius-px", params.patch.radius_px);
    params.surface_warp = !args.flag("--plane-warp");
    params.patch.lsm_affine = !args.flag("--translation-lsm");
    params.derived_radius = !args.flag("--fixed-radius");
    params.patch.anisotropic = !args.flag("--isotropic");
    params.patch.clip_at_edge = !args.flag("--no-edge-clip");
    if (args.flag("--isotropic")) params.max_scale_ratio = 6.0;  // the gate that went with it
    const std::string dir = args.positional(0, "TRAVERSE");
    if (!truth_products && !products)
      throw cli::UsageError("--products DIR is required (or --truth-products)");
    if (params.patch.min_ncc <= 0.0 || params.patch.min_ncc >= 1.0)
      throw cli::UsageError("--ncc: between 0 and 1");
    if (params.patch.radius_px < 1.0 || params.patch.radius_px > 50.0)
      throw cli::UsageError("--radius-px: 1 to 50");

    const Traverse traverse = readTraverse(dir);
    checkTraverseSites(traverse);
    const std::optional<TraverseTruth> truth = readTraverseTruth(dir, traverse);
    if (truth_products && !truth) {
      throw cli::InputError(dir + "/" + kTraverseTruthFile, "sites",
                            "--truth-products needs the traverse's truth");
    }
    // The sites taken (all, or those --sites lists), in driving order.
    std::vector<int> chosen;
    if (only) {
      std::string rest = *only + ",";
      for (std::size_t at = rest.find(','); at != std::string::npos; at = rest.find(',')) {
        const std::string id = rest.substr(0, at);
        rest = rest.substr(at + 1);
        if (id.empty()) continue;
        const int k = traverse.indexOf(id);
        if (k < 0) throw cli::UsageError("--sites: no site '" + id + "' in " + dir + "/traverse.json");
        chosen.push_back(k);
      }
      std::sort(chosen.begin(), chosen.end());
      chosen.erase(std::unique(chosen.begin(), chosen.end()), chosen.end());
    } else {
      for (int k = 0; k < static_cast<int>(traverse.sites.size()); ++k) chosen.push_back(k);
    }
    std::vector<std::pair<int, int>> pairs;
    for (std::size_t j = 1; j < chosen.size(); ++j) {
      for (std::size_t i = all_pairs ? 0 : j - 1; i < j; ++i) pairs.emplace_back(chosen[i], chosen[j]);
    }
    std::filesystem::create_directories(out);
    std::map<int, std::shared_ptr<SiteProducts>> loaded;
    auto site = [&](int k) {
      auto it = loaded.find(k);
      if (it != loaded.end()) return it->second;
      const TraverseSite& s = traverse.sites[k];
      cli::info("loading " + s.id);
      auto p = std::make_shared<SiteProducts>(truth_products ? loadSiteTruth(s, truth_cell)
                                                             : loadSiteProducts(s, *products + "/" + s.id));
      return loaded[k] = p;
    };
    json report;
    report["traverse"] = traverse.name;
    report["products"] = truth_products ? std::string("truth") : *products;
    report["pairs"] = json::array();
    std::vector<CrossTie> all;
    int64_t next_point = 0;
    for (const auto& [i, j] : pairs) {
      // Keep the sites this and later pairs need.
      for (auto it = loaded.begin(); it != loaded.end();) {
        it = (!all_pairs && it->first < i) ? loaded.erase(it) : std::next(it);
      }
      const TraverseSite& sa = traverse.sites[i];
      const TraverseSite& sb = traverse.sites[j];
      cli::info("sites " + sa.id + " and " + sb.id);
      const RelativePose apriori = relativePose(sa.apriori, sb.apriori);
      CrossTieParams pair_params = params;
      pair_params.registration = searchWindowOf(traverse, i, j, params.registration);
      const CrossTieResult r = findCrossSiteTies(*site(i), *site(j), apriori, pair_params, next_point);
      json pj;
      pj["site_a"] = sa.id;
      pj["site_b"] = sb.id;
      pj["status"] = crossTieStatusName(r.status);
      if (!r.message.empty()) pj["message"] = r.message;
      const DemRegistration& g = r.registration;
      pj["registration"] = {{"status", registrationStatusName(g.status)},
                            {"apriori", poseJson(g.apriori)},
                            {"a_from_b", poseJson(g.a_from_b)},
                            {"sigma", {g.sigma[0], g.sigma[1], g.sigma[2], g.sigma[3] * kRadToDeg}},
                            {"overlap_samples", g.overlap_cells},
                            {"used_samples", g.used_cells},
                            {"rms_m", g.rms_m},
                            {"correlation_factor", g.correlation_factor},
                            {"cost_ratio", g.cost_ratio}};
      pj["a_from_b"] = poseJson(r.a_from_b);
      pj["a_from_b_sigma"] = {r.a_from_b_sigma[0], r.a_from_b_sigma[1], r.a_from_b_sigma[2],
                              r.a_from_b_sigma[3] * kRadToDeg};
      pj["rms_px"] = r.rms_px;
      pj["search"] = {{"m", pair_params.registration.search_m}, {"deg", pair_params.registration.search_deg}};
      pj["first_pass_ties"] = r.first_pass_ties;
      pj["ties"] = r.ties.size();
      pj["observations"] = r.observationCount();
      pj["counts"] = countsJson(r.counts);
      pj["first_pass_counts"] = countsJson(r.first_pass_counts);
      pj["counts_in_a"] = countsJson(r.counts_in_a);
      std::string line = sa.id + "-" + sb.id + ": " + crossTieStatusName(r.status) + ", " +
                         std::to_string(r.ties.size()) + " ties, " + std::to_string(r.observationCount()) +
                         " observations, rms " + std::to_string(r.rms_px) + " px";
      if (truth) {
        const TruthCheck t = checkAgainstTruth(r, sa, sb, truth->poses[i], truth->poses[j]);
        pj["truth"] = {{"observations", t.errors_px.size()},
                       {"median_px", t.median_px},
                       {"p90_px", t.p90_px},
                       {"cross_observations", t.cross_errors_px.size()},
                       {"cross_median_px", t.cross_median_px},
                       {"cross_p90_px", t.cross_p90_px},
                       {"cross_gross", t.cross_gross},
                       {"gross", t.gross},
                       {"gross_px", t.gross_px},
                       {"no_truth", t.no_truth},
                       {"registration_xy_m", t.registration_xy_m},
                       {"registration_z_m", t.registration_z_m},
                       {"registration_heading_deg", t.registration_heading_deg},
                       {"ties_xy_m", t.ties_xy_m},
                       {"ties_z_m", t.ties_z_m},
                       {"ties_heading_deg", t.ties_heading_deg}};
        char buffer[512];
        std::snprintf(buffer, sizeof buffer,
                      "; truth: registration %.3f m xy, %.3f m z, %.3f deg; ties' pose %.3f m xy, %.3f deg; "
                      "median %.3f px, 90%% %.3f px, %d of %zu > %.0f px; in A's images median %.3f px, 90%% "
                      "%.3f px, %d of %zu > %.0f px",
                      t.registration_xy_m, t.registration_z_m, t.registration_heading_deg, t.ties_xy_m,
                      t.ties_heading_deg, t.median_px, t.p90_px, t.gross, t.errors_px.size(), t.gross_px,
                      t.cross_median_px, t.cross_p90_px, t.cross_gross, t.cross_errors_px.size(), t.gross_px);
        line += buffer;
      }
      std::printf("%s\n", line.c_str());
      std::fflush(stdout);
      report["pairs"].push_back(pj);
      for (const CrossTie& t : r.ties) {
        all.push_back(t);
        next_point = std::max(next_point, t.point + 1);
      }
    }
    writeCrossTiesCsv(out + "/cross_ties.csv", all);
    cli::writeFileAtomic(out + "/cross_ties.json", report.dump(2) + "\n");
    return 0;
  });
}
