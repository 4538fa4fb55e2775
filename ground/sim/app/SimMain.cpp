// areomap-sim: synthetic Mars panoramas with known truth.
#include <algorithm>
#include <cstdio>
#include <optional>
#include <sstream>
#include <string>

#include "ground/cli/Cli.hpp"
#include "ground/sim/SimGeometry.hpp"
#include "ground/sim/SimWriter.hpp"
#include "ground/sim/Terrain.hpp"
#include "ground/sim/TraverseSim.hpp"

namespace {

const char* const kUsage = R"(areomap-sim: synthetic Mars panoramas with known truth

Usage: areomap-sim --preset navcam|imp|fido|tiny --out DIR [options]
       areomap-sim --preset traverse [--camera navcam|imp|fido|tiny] [--sites N] --out DIR [options]

Writes DIR/panorama.json, DIR/images/<stem>.png (8-bit), DIR/models/<stem>.cahvor (a-priori models,
pointing off by a pan/tilt error of the mast head per pair) and the truth: DIR/truth/models/<stem>.cahvor,
DIR/truth/dem.tif (GeoTIFF, site frame, elevation up), DIR/truth/points.csv (point,x_m,y_m,z_m),
DIR/truth/observations.csv (point,image,sample_px,line_px) and DIR/truth/sim.json (the configuration).
The same seed gives the same files, whatever the number of threads.

Presets: navcam  MER Navcam-like, 1024x1024, 45 deg, 20 cm base, one 360-deg tier of 18 pairs
         imp     Pathfinder IMP-like, 256x256, 14.4 deg, 15 cm base, 2 tiers x 32 pairs + 1 single image
         fido    FIDO-like mast: navcam cameras, tilt axis 10 cm ahead of the pan axis, 2 tiers x 12
                 pairs; panorama.json gives the stereo base only (adjust it with --fido)
         tiny    8 small pairs (256x192, 60 deg), made in seconds, for tests
         traverse  a multi-site traverse over one continuous terrain: a panorama of the --camera preset
                 at each of --sites sites 10-30 m apart along a winding path (below)

Options (each overrides the preset):
  --seed N                   random seed (default 1)
  --pairs N                  total stereo pairs (spread over the 360-degree tiers; fewer than a full
                             circle make an arc at the preset's pan step)
  --pointing-error-px MIN MAX  a-priori pointing error per pair at the image centre (default 3 15)
  --size W H                 image size in pixels
  --fov-deg F                horizontal field of view
  --distortion RHO1 RHO2     CAHVOR radial terms R = (0, RHO1, RHO2)
  --sol N                    sol number of the panorama (default 1)
  --base-m B                 stereo base
  --mast-m H                 gimbal height above the ground
  --toe-in-deg T             toe-in of each camera
  --tilt-axis-forward-m D    FIDO-like mast: the tilt axis D metres ahead of the pan axis (0..0.5)
  --tilts T1,T2,...          tilt of each 360-degree tier (degrees, up positive)
  --pan-step-deg S           pan step between pairs of every tier
  --extent-m E               half width of the terrain square around the rover
  --cell-m C                 terrain grid cell
  --relief-m R               RMS of the multi-octave relief
  --rock-k K                 Golombek rock abundance k (cumulative fractional area)
  --supersample S            S x S rays per pixel (1..4)
  --noise-dn N               sensor noise sigma in DN
  --blur-px S                Gaussian blur (sigma S pixels) of each rendered image before the sensor
                             noise (default 0 = none)
  --jpeg-quality Q           JPEG round trip at quality Q before saving (0 = none)
  --sun-az-deg A --sun-el-deg E   sun direction
  --no-shadows               no cast shadows
  --check-points N           wanted true check points seen by two or more images
  --range-m MIN MAX          range of the check points from the rover
  --threads N                worker threads (default: all cores)
  --no-images                geometry and truth only (no rendering)

Traverse (--preset traverse; docs/traverse.md): writes DIR/traverse.json (the sites in driving
order, their a-priori poses in the traverse frame = the first site's frame, the odometry of each leg and
its sigmas), DIR/sites/<id>/ (one complete dataset per site, as the --camera preset writes it, in that
site's own frame: every single-site tool runs on it), DIR/truth/traverse.json (the true poses) and
DIR/truth/dem.tif (the terrain in the traverse frame, 10 cm). The options above set each site's panorama;
--extent-m is the fine terrain's margin beyond the outermost site (default 30 m, 20 m for tiny).
  --camera P                 the panorama of every site: navcam (default), imp, fido or tiny
  --sites N                  number of sites (default 5, 1..99)
  --leg-min-m A --leg-max-m B  distance between consecutive sites (default 10 and 30)
  --max-turn-deg T           heading change before each leg, uniform in +-T (default 40)
  --odometry-drift-pct P     odometry sigma per horizontal axis, % of the leg's distance (default 5)
  --vertical-drift-pct P     odometry sigma vertically, % of the leg's distance (default 1)
  --heading-drift-deg D      odometry heading sigma per leg (default 2); the a-priori poses chain the
                             odometry, so their errors grow as a random walk
  --stop-spacing-m D         traversing stops (default 0: none): on each leg the rover stops at least
                             every D m (the leg in equal parts) and takes a few stereo pairs looking
                             forward (a 90-degree sector, each tier's tilt and pan step); a stop is a
                             site "stopNN-M" (kind "stop") of its own, tying the sites around it
  --max-slope-deg S          sloped ground (default 0: the level world of before, byte for byte): the
                             terrain gets swells (60 m wavelength) whose slopes reach S degrees (0..35),
                             steepest at a site of the path; each rover stands tilted on the plane of
                             its wheels, the mast above that tilted base, the cameras following; the
                             true roll and pitch go to truth/traverse.json
  --tilt-sigma-deg T         sloped ground only: the rover's IMU roll and pitch error, Gaussian per site
                             (default 0.2); the a-priori models are levelled by the erroneous attitude,
                             which traverse.json gives per site with T as its sigma
  --help                     this text

Exit codes: 0 done, 2 usage error or impossible plan, 1 other error (e.g. an unwritable folder).
)";

std::vector<double> parseList(const std::string& option, const std::string& text) {
  std::vector<double> values;
  std::stringstream s(text);
  std::string item;
  while (std::getline(s, item, ',')) {
    try {
      std::size_t used = 0;
      values.push_back(std::stod(item, &used));
      if (used != item.size()) throw std::invalid_argument(item);
    } catch (const std::exception&) {
      throw areomap::cli::UsageError(option + ": expected numbers separated by commas, got '" + text + "'");
    }
  }
  if (values.empty()) throw areomap::cli::UsageError(option + ": empty list");
  return values;
}

int integerOption(areomap::cli::Args& args, const std::string& name, int fallback) {
  const int64_t v = args.integer(name, fallback);
  if (v < -1000000000LL || v > 1000000000LL) throw areomap::cli::UsageError(name + ": out of range");
  return static_cast<int>(v);
}

// --preset traverse: the whole layout, a progress line per site.
int simulateTraverse(const areomap::sim::TraverseSimConfig& config, const std::string& out, bool images) {
  using namespace areomap;
  const double t0 = cli::nowSeconds();
  cli::info("preset traverse (" + config.site.preset + " panoramas), " +
            std::to_string(config.traverse.sites) + " sites, seed " + std::to_string(config.seed));
  sim::TraverseSimOptions options;
  options.images = images;
  double site_start = t0;
  options.on_stage = [&](const std::string& text) {
    if (text.rfind("warning: ", 0) == 0) {
      cli::warn(text.substr(9));
    } else {
      cli::info(text);
    }
    site_start = cli::nowSeconds();
  };
  options.on_image = [&](const std::string& site, int done, int total) {
    if (done != total) return;
    char line[160];
    std::snprintf(line, sizeof(line), "%s: %d images rendered in %.1f s", site.c_str(), total,
                  cli::nowSeconds() - site_start);
    cli::info(line);
  };
  const sim::TraversePlan plan = sim::writeTraverseDataset(config, out, options);
  char line[200];
  const auto stops = std::count(plan.kinds.begin(), plan.kinds.end(), SiteKind::kStop);
  std::snprintf(line, sizeof(line), "wrote %s: %zu sites (%td traversing stops), %.1f m driven, in %.1f s",
                out.c_str(), plan.truth.size(), stops, plan.distanceM(), cli::nowSeconds() - t0);
  cli::info(line);
  return 0;
}

// The traverse preset's options (--sites ... --tilt-sigma-deg); the slope options refused without it.
void traverseOptions(areomap::cli::Args& args, bool traverse, areomap::sim::TraverseSimConfig& tc) {
  using namespace areomap;
  if (traverse) {
    tc.traverse.sites = integerOption(args, "--sites", tc.traverse.sites);
    tc.traverse.leg_min_m = args.number("--leg-min-m", tc.traverse.leg_min_m);
    tc.traverse.leg_max_m = args.number("--leg-max-m", tc.traverse.leg_max_m);
    tc.traverse.max_turn_deg = args.number("--max-turn-deg", tc.traverse.max_turn_deg);
    tc.traverse.drift_fraction =
        args.number("--odometry-drift-pct", 100.0 * tc.traverse.drift_fraction) / 100.0;
    tc.traverse.vertical_drift_fraction =
        args.number("--vertical-drift-pct", 100.0 * tc.traverse.vertical_drift_fraction) / 100.0;
    tc.traverse.heading_drift_deg = args.number("--heading-drift-deg", tc.traverse.heading_drift_deg);
    tc.traverse.stop_spacing_m = args.number("--stop-spacing-m", tc.traverse.stop_spacing_m);
    tc.terrain_margin_m = args.number("--extent-m", tc.terrain_margin_m);
    tc.traverse.max_slope_deg = args.number("--max-slope-deg", tc.traverse.max_slope_deg);
    if (const auto tilt_sigma = args.numbers("--tilt-sigma-deg", 1)) {
      if (!(tc.traverse.max_slope_deg > 0.0))
        throw cli::UsageError("--tilt-sigma-deg: only on sloped ground (--max-slope-deg above 0)");
      tc.traverse.tilt_sigma_deg = tilt_sigma->front();
    }
  } else {
    for (const char* option : {"--max-slope-deg", "--tilt-sigma-deg"}) {
      if (args.option(option)) throw cli::UsageError(std::string(option) + ": only with --preset traverse");
    }
  }
}

// One site: the terrain, the geometry, the dataset written.
int simulateSite(const areomap::sim::SimConfig& c, const std::string& out, bool images) {
  using namespace areomap;
  const double t0 = cli::nowSeconds();
  cli::info("preset " + c.preset + ", seed " + std::to_string(c.seed) + ": building the terrain");
  const sim::Terrain terrain = sim::Terrain::build(c);
  cli::info("terrain " + std::to_string(terrain.nodes()) + " x " + std::to_string(terrain.nodes()) +
            " nodes, " + std::to_string(terrain.rockCount()) + " rocks, " +
            std::to_string(terrain.craterCount()) + " craters");
  const sim::SimGeometry g = sim::makeGeometry(c, terrain);
  cli::info(std::to_string(g.pairs.size()) + " pairs, " + std::to_string(g.cameras().size()) + " images, " +
            std::to_string(g.points.size()) + " check points, " + std::to_string(g.observations.size()) +
            " observations");
  if (static_cast<int>(g.points.size()) < c.check_points) {
    cli::warn("only " + std::to_string(g.points.size()) + " of " + std::to_string(c.check_points) +
              " check points are seen by two or more images");
  }
  if (const int beyond = sim::camerasSeeingBeyondTerrain(g, terrain); beyond > 0) {
    cli::warn(std::to_string(beyond) +
              " image(s) see ground beyond the terrain grid (rendered flat, not in "
              "truth/dem.tif): raise --extent-m or tilt down");
  }
  sim::WriteOptions options;
  options.images = images;
  cli::Progress progress("rendering", g.cameras().size());
  options.on_image = [&](int, int) { progress.step(); };
  sim::writeSimDataset(g, terrain, out, options);
  progress.done();
  char line[128];
  std::snprintf(line, sizeof(line), "wrote %s in %.1f s", out.c_str(), cli::nowSeconds() - t0);
  cli::info(line);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace areomap;
  return cli::runTool("areomap-sim", argc, argv, kUsage, [](cli::Args& args) {
    const std::string preset = args.required("--preset");
    const bool traverse = preset == "traverse";
    const std::optional<std::string> camera = args.option("--camera");
    if (camera && !traverse) throw cli::UsageError("--camera: only with --preset traverse");
    auto isSitePreset = [](const std::string& name) {
      return name == "navcam" || name == "imp" || name == "fido" || name == "tiny";
    };
    if (!traverse && !isSitePreset(preset)) {
      throw cli::UsageError("--preset: unknown preset '" + preset +
                            "' (navcam, imp, fido, tiny or traverse)");
    }
    if (camera && !isSitePreset(*camera)) {
      throw cli::UsageError("--camera: unknown camera preset '" + *camera + "' (navcam, imp, fido or tiny)");
    }
    sim::TraverseSimConfig tc = sim::traversePreset(traverse ? camera.value_or("navcam") : preset);
    sim::SimConfig& c = tc.site;
    traverseOptions(args, traverse, tc);
    const std::string out = args.required("--out");
    const int64_t seed = args.integer("--seed", 1);
    if (seed < 0) throw cli::UsageError("--seed: must be >= 0");
    c.seed = static_cast<uint64_t>(seed);
    tc.seed = c.seed;
    const std::optional<std::string> pairs = args.option("--pairs");
    if (const auto tilts = args.option("--tilts")) {
      // One 360-degree tier per tilt, each like the preset's tier of the same index (or its last one);
      // the preset's single images are kept.
      const std::vector<double> t = parseList("--tilts", *tilts);
      std::vector<sim::TierPlan> full, single;
      for (const sim::TierPlan& tier : c.tiers) (tier.left_only ? single : full).push_back(tier);
      std::vector<sim::TierPlan> tiers;
      for (std::size_t i = 0; i < t.size(); ++i) {
        sim::TierPlan tier = full.empty() ? sim::TierPlan{} : full[std::min(i, full.size() - 1)];
        tier.tilt_deg = t[i];
        tiers.push_back(tier);
      }
      tiers.insert(tiers.end(), single.begin(), single.end());
      c.tiers = tiers;
    }
    if (pairs) {
      int n = 0;
      try {
        std::size_t used = 0;
        n = std::stoi(*pairs, &used);
        if (used != pairs->size()) throw std::invalid_argument(*pairs);
      } catch (const std::exception&) {
        throw cli::UsageError("--pairs: expected an integer, got '" + *pairs + "'");
      }
      sim::setPairCount(c, n);
    }
    if (const auto e = args.numbers("--pointing-error-px", 2)) {
      c.pointing_min_px = (*e)[0];
      c.pointing_max_px = (*e)[1];
    }
    if (const auto s = args.numbers("--size", 2)) {
      c.width = static_cast<int>((*s)[0]);
      c.height = static_cast<int>((*s)[1]);
    }
    c.hfov_deg = args.number("--fov-deg", c.hfov_deg);
    if (const auto r = args.numbers("--distortion", 2)) {
      c.rho1 = (*r)[0];
      c.rho2 = (*r)[1];
    }
    c.sol = integerOption(args, "--sol", c.sol);
    c.base_m = args.number("--base-m", c.base_m);
    c.mast_m = args.number("--mast-m", c.mast_m);
    c.toe_in_deg = args.number("--toe-in-deg", c.toe_in_deg);
    c.tilt_axis_forward_m = args.number("--tilt-axis-forward-m", c.tilt_axis_forward_m);
    if (const auto step = args.option("--pan-step-deg")) {
      const double s = parseList("--pan-step-deg", *step).front();
      for (sim::TierPlan& tier : c.tiers) {
        if (!tier.left_only) tier.pan_step_deg = s;
      }
    }
    if (!traverse) c.half_extent_m = args.number("--extent-m", c.half_extent_m);
    c.cell_m = args.number("--cell-m", c.cell_m);
    c.relief_m = args.number("--relief-m", c.relief_m);
    c.rock_k = args.number("--rock-k", c.rock_k);
    c.supersample = integerOption(args, "--supersample", c.supersample);
    c.noise_dn = args.number("--noise-dn", c.noise_dn);
    c.blur_px = args.number("--blur-px", c.blur_px);
    c.jpeg_quality = integerOption(args, "--jpeg-quality", c.jpeg_quality);
    c.sun_azimuth_deg = args.number("--sun-az-deg", c.sun_azimuth_deg);
    c.sun_elevation_deg = args.number("--sun-el-deg", c.sun_elevation_deg);
    if (args.flag("--no-shadows")) c.shadows = false;
    c.check_points = integerOption(args, "--check-points", c.check_points);
    if (const auto r = args.numbers("--range-m", 2)) {
      c.min_range_m = (*r)[0];
      c.max_range_m = (*r)[1];
    }
    c.threads = integerOption(args, "--threads", c.threads);
    const bool images = !args.flag("--no-images");
    args.finish();
    sim::validatePlan(c);
    if (traverse) return simulateTraverse(tc, out, images);

    return simulateSite(c, out, images);
  });
}
