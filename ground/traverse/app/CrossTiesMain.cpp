// areomap-cross-ties TRAVERSE --products DIR --out DIR: cross-site tie points between neighbouring sites of
// a traverse, from each site's ground products.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>

#include <nlohmann/json.hpp>

#include "ground/cli/AtomicFile.hpp"
#include "ground/cli/Cli.hpp"
#include "ground/dataset/Traverse.hpp"
#include "ground/traverse/CrossSiteTies.hpp"
#include "ground/traverse/TraverseMatching.hpp"

namespace {

using namespace areomap;
using namespace areomap::traverse;

constexpr const char* kUsage =
    "usage: areomap-cross-ties TRAVERSE --products DIR --out DIR [--sites ID,...] [--all-pairs] "
    "[--truth-products] [--threads N]\n"
    "\n"
    "Cross-site tie points between the sites of a traverse (docs/cross-site-ties.md): for each pair "
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
    "  --threads N        threads for the matching (default: every core; the ties are the same for any N)\n"
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
    "                     at the edge; for comparison). All five: the matcher before its reach was extended\n"
    "  --every-ray        cast every template sample's ray onto the DEM (else the casts of a lattice are\n"
    "                     interpolated where they agree within 0.05 grid step; for comparison)\n"
    "\n"
    "A pair of sites whose DEMs do not overlap, or match ambiguously, is reported with its status and no\n"
    "ties; that is not an error. Exit: 0 ok, 2 usage error, 1 bad input (the message names the file and\n"
    "the field).\n";

}  // namespace

int main(int argc, char** argv) {
  return cli::runTool("areomap-cross-ties", argc, argv, kUsage, [](cli::Args& args) {
    cli::threadsOption(args);
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
    if (args.flag("--every-ray")) params.patch.warp_tolerance_steps = 0.0;
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
    std::filesystem::create_directories(out);
    const SiteLoader load = [&](int k) {
      const TraverseSite& s = traverse.sites[k];
      cli::info("loading " + s.id);
      return std::make_shared<const SiteProducts>(
          truth_products ? loadSiteTruth(s, truth_cell) : loadSiteProducts(s, *products + "/" + s.id));
    };
    const TraverseMatching matching = matchTraverse(traverse, sitePairs(traverse, chosen, all_pairs), load,
                                                    params, truth, [&](const SitePairMatch& m) {
                                                      std::printf("%s\n", pairMatchLine(traverse, m).c_str());
                                                      std::fflush(stdout);
                                                    });
    // A site whose products cannot be read is an input error here (areomap-traverse goes on without it).
    for (const SitePairMatch& m : matching.pairs) {
      if (!m.error.empty()) throw std::runtime_error(m.error);
    }
    writeCrossSiteTies(out + "/cross_ties.csv", crossSiteObservations(matching.ties));
    cli::writeFileAtomic(
        out + "/cross_ties.json",
        matchingJson(traverse, truth_products ? std::string("truth") : *products, matching).dump(2) + "\n");
    return 0;
  });
}
