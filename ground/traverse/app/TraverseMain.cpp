// areomap-traverse DATASET --out DIR: one map and the rover's positions over a multi-site traverse. See
// kUsage.
#include <cstdio>
#include <string>

#include "ground/cli/Cli.hpp"
#include "ground/dataset/Traverse.hpp"
#include "ground/traverse/TraverseRun.hpp"

namespace {

constexpr const char* kUsage =
    "usage: areomap-traverse DATASET --out DIR [--cross-ties FILE | --truth-cross-ties [--noise-px S] |\n"
    "                        --no-cross-ties] [--no-products] [--reuse-sites] [--cell-m C] [--quiet]\n"
    "                        [--threads N]\n"
    "\n"
    "Maps a multi-site traverse: DATASET/traverse.json names the sites in driving order "
    "(docs/traverse.md),\n"
    "each a single-site dataset in its own site frame. Every site is mapped alone by the "
    "ground\n"
    "pass (as areomap-ground --dataset) into DIR/sites/<id>/; cross-site tie points are matched between\n"
    "neighbouring sites (as areomap-cross-ties: DEM registration, NCC on DEM-warped patches; "
    "DIR/cross_ties.csv\n"
    "and cross_ties.json; across a traversing stop, \"kind\": \"stop\", also back to the last panorama\n"
    "site); the sites are placed in the traverse frame (the first site's) by the multi-site adjustment of\n"
    "those ties and the odometry (firmware_core/adjust/SitePoseAdjuster.hpp); and DIR gets poses.csv (site,\n"
    "x, y, z, heading, their sigmas, the pose's source, distance\n"
    "driven), the merged dem.tif, dem_sigma.tif and ortho.tif (traverse frame; each cell from the nearest "
    "site\n"
    "that has data there) and report.json (traverse.sites, stops, distance_m, position_error_m / _pct and\n"
    "position_error_apriori_pct against DATASET/truth/traverse.json when it exists, cross_site_ties, "
    "per-site\n"
    "figures; method1_px / method2_m / method3_px as the mean of the sites').\n"
    "\n"
    "  --out DIR        output folder (created)\n"
    "  --no-products    adjustment only: no dense matching, DEM, ortho, merged map or cross-site matching\n"
    "  --cell-m C       merged map cell (default: the coarsest site dem.tif cell)\n"
    "  --cross-ties FILE  cross-site tie points from a file instead of the matcher, CSV\n"
    "                   point,site,image,sample_px,line_px (measured pixels; e.g. areomap-cross-ties')\n"
    "  --no-cross-ties  no cross-site ties: the poses are the odometry's (chained, with its sigmas)\n"
    "  --truth-cross-ties  cross-site ties from a synthetic traverse's truth (each site's check points\n"
    "                   projected into the previous site's true models) with --noise-px S (default 0.3)\n"
    "  --reuse-sites    a site whose DIR/sites/<id> holds a finished pass (report.json, models/) is not\n"
    "                   mapped again (e.g. to adjust the traverse again with other cross-site ties)\n"
    "  --quiet          no progress lines\n"
    "  --threads N      threads of the passes' parallel work (pairs, rows, cells; default: every core);\n"
    "                   the products are the same bytes for any N\n"
    "\n"
    "A site whose pass fails (a bad dataset, an unsolvable network) is reported in report.json and skipped;\n"
    "the others are still mapped. Exit: 0 ok, 2 usage error, 1 other error (the message names the file and\n"
    "field), also 1 when a product could not be written.\n";

}  // namespace

int main(int argc, char** argv) {
  using namespace areomap;
  return cli::runTool("areomap-traverse", argc, argv, kUsage, [](cli::Args& args) {
    traverse::TraverseRunOptions o;
    o.out_dir = args.required("--out");
    o.products = !args.flag("--no-products");
    o.cell_m = args.number("--cell-m", -1.0);
    o.progress = !args.flag("--quiet");
    cli::threadsOption(args);
    o.reuse_sites = args.flag("--reuse-sites");
    o.cross_ties_csv = args.option("--cross-ties", "");
    o.truth_cross_ties = args.flag("--truth-cross-ties");
    o.truth_noise_px = args.number("--noise-px", 0.3);
    o.match_cross_ties = !args.flag("--no-cross-ties");
    if (int(o.truth_cross_ties) + int(!o.cross_ties_csv.empty()) + int(!o.match_cross_ties) > 1)
      throw cli::UsageError("give at most one of --cross-ties FILE, --truth-cross-ties and --no-cross-ties");
    const std::string dataset = args.positional(0, "DATASET");
    const Traverse t = readTraverse(dataset);
    checkTraverseSites(t);
    const traverse::TraverseResult r = traverse::runTraverse(t, o);
    int mapped = 0;
    for (const traverse::SiteOutcome& s : r.sites) mapped += s.ok ? 1 : 0;
    std::printf("traverse: %d of %zu sites mapped, %zu files in %s\n", mapped, r.sites.size(), r.files.size(),
                o.out_dir.c_str());
    for (const std::string& e : r.write_errors)
      std::fprintf(stderr, "areomap-traverse: error: not written: %s\n", e.c_str());
    return r.write_errors.empty() ? 0 : 1;
  });
}
