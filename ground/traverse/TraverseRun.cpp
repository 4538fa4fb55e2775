#include "ground/traverse/TraverseRun.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <memory>
#include <optional>
#include <sstream>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "ground/cli/AtomicFile.hpp"
#include "ground/cli/Cli.hpp"
#include "ground/dataset/Dataset.hpp"
#include "ground/dataset/DemRaster.hpp"
#include "ground/io/CameraFile.hpp"
#include "ground/pass/GroundPass.hpp"
#include "ground/raster/RasterFiles.hpp"
#include "ground/traverse/CrossSiteAdjustment.hpp"
#include "ground/traverse/SiteManifest.hpp"
#include "ground/traverse/SitePassFiles.hpp"
#include "ground/traverse/TraverseMatching.hpp"
#include "ground/traverse/TraverseMosaic.hpp"

namespace areomap::traverse {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

// Empties (or makes) a site's folder before its pass: what a killed or failed pass left there must not mix
// with the new pass's files. Something there that is not a folder is not this tool's to remove.
void prepareSiteFolder(const std::string& dir) {
  std::error_code ec;
  if (fs::exists(dir, ec) && !fs::is_directory(dir, ec))
    throw cli::InputError(dir, "--out", "the site's output is there but is not a folder");
  if (fs::is_directory(dir, ec)) {
    for (const fs::directory_entry& e : fs::directory_iterator(dir, ec)) {
      if (!ec) fs::remove_all(e.path(), ec);
      if (ec) throw cli::InputError(dir, "--out", "cannot empty the site's folder: " + ec.message());
    }
  }
  fs::create_directories(dir, ec);
  if (ec) throw cli::InputError(dir, "--out", "cannot create the site's folder: " + ec.message());
}

// A site's earlier pass taken as it is (--reuse-sites: report.json and models/ there; --resume: a complete
// manifest of a mapped site); nullopt: it is mapped again.
std::optional<SiteOutcome> earlierPass(const TraverseSite& site, const std::string& out_dir,
                                       const TraverseRunOptions& o) {
  std::string why;
  if (o.resume) {
    std::optional<SiteOutcome> s;
    try {
      s = recordedSite(site, out_dir, &why);
    } catch (const std::exception& e) {
      why = e.what();
    }
    if (s && s->ok) {
      if (o.progress) cli::info("site " + site.id + ": its pass is complete (--resume)");
      return s;
    }
    if (o.progress) cli::info("site " + site.id + ": mapped again (" + (s ? "it was not mapped" : why) + ")");
    return std::nullopt;
  }
  if (!o.reuse_sites || !hasFinishedPass(out_dir)) return std::nullopt;
  try {
    std::shared_ptr<const ground::SitePass> pass = loadSitePass(site, out_dir);
    if (pass) {
      if (o.progress) cli::info("site " + site.id + ": its pass is there (--reuse-sites)");
      return siteOutcome(site.id, std::move(pass));
    }
  } catch (const std::exception& e) {
    cli::warn("site " + site.id + ": its pass cannot be reused (" + e.what() + "); it is mapped again");
  }
  return std::nullopt;
}

void writePoses(const SitePoseSolution& poses, const std::string& path) {
  std::ostringstream csv;
  csv << "site,x_m,y_m,z_m,heading_deg,sigma_x_m,sigma_y_m,sigma_z_m,sigma_heading_deg,source,distance_m\n";
  char b[400];
  for (const SitePoseEstimate& e : poses.sites) {
    const Eigen::Vector4d sd = e.covariance.diagonal().cwiseMax(0.0).cwiseSqrt();
    std::snprintf(b, sizeof b, "%s,%.4f,%.4f,%.4f,%.5f,%.4f,%.4f,%.4f,%.5f,%s,%.3f\n", e.id.c_str(),
                  e.pose.position_m.x(), e.pose.position_m.y(), e.pose.position_m.z(),
                  e.pose.heading_rad * 180.0 / M_PI, sd(0), sd(1), sd(2), sd(3) * 180.0 / M_PI,
                  poseSourceName(e.source), e.distance_m);
    csv << b;
  }
  cli::writeFileAtomic(path, csv.str());
}

// Every mapped site's adjusted models (its pass's, site frame) in the traverse frame:
// OUT/models/<id>/<stem>.cahvor.
void writeTraverseModels(const std::vector<SiteOutcome>& sites, const SitePoseSolution& poses,
                         const std::string& out_dir, TraverseResult& result) {
  for (std::size_t k = 0; k < sites.size(); ++k) {
    if (!sites[k].ok || !sites[k].pass) continue;
    const ground::SitePass& pass = *sites[k].pass;
    const std::string to = out_dir + "/models/" + sites[k].id;
    fs::create_directories(to);
    for (std::size_t i = 0; i < pass.stems.size(); ++i) {
      const std::string path = to + "/" + pass.stems[i] + ".cahvor";
      try {
        io::writeCameraModelFile(path, toTraverseFrame(pass.adjusted[i], poses.sites[k].pose));
      } catch (const std::exception& e) {
        result.write_errors.push_back(path + ": " + e.what());
      }
    }
  }
}

raster::Geometry geometryOf(const DemGrid& g) {
  return {g.cols, g.rows, g.east0_m, g.north0_m, g.cell_m};
}

// The merged dem.tif, dem_sigma.tif and ortho.tif from the sites that have them.
void writeMergedMap(const Traverse& traverse, const TraverseTruthInput& truth,
                    const std::vector<SiteOutcome>& sites, const SitePoseSolution& poses,
                    const TraverseRunOptions& o, TraverseResult& result) {
  std::vector<MosaicInput> dem_in, sigma_in, ortho_in;
  double cell = o.cell_m;
  for (std::size_t k = 0; k < sites.size(); ++k) {
    if (!sites[k].ok || !sites[k].pass || !sites[k].pass->dem) continue;
    const ground::SitePass& pass = *sites[k].pass;
    if (o.cell_m <= 0.0) cell = std::max(cell, pass.dem->cell_m);
    const SitePoseEstimate& p = poses.sites[k];
    dem_in.push_back({p.pose, &*pass.dem, 0.0});
    // The pose's vertical sigma is common to all of the site's cells.
    if (pass.dem_sigma && pass.dem_sigma->cols > 0)
      sigma_in.push_back({p.pose, &*pass.dem_sigma, p.covariance(2, 2)});
    if (pass.ortho && pass.ortho->cols > 0) ortho_in.push_back({p.pose, &*pass.ortho, 0.0});
  }
  if (dem_in.empty()) {
    result.warnings.push_back("No site has a dem.tif: no merged map.");
    return;
  }
  const DemGrid grid = traverseGrid(dem_in, cell);
  raster::SiteTags tags;
  tags.site = traverse.name;
  const auto write_float = [&](const std::string& name, const Mosaic& m, const std::string& values) {
    const std::string path = o.out_dir + "/" + name;
    try {
      cli::writeViaTemporary(path, [&](const std::string& tmp) {
        raster::writeGeoTiff(tmp, geometryOf(m.grid), m.grid.values.data(), m.grid.nodata);
        raster::tagSiteRaster(tmp, tags, values);
      });
      result.files.push_back(path);
    } catch (const std::exception& e) {
      result.write_errors.push_back(path + ": " + e.what());
    }
  };
  if (o.progress)
    cli::info("merged map: " + std::to_string(grid.cols) + " x " + std::to_string(grid.rows) + " cells");
  const Mosaic merged = mosaic(dem_in, grid, MosaicKind::kElevation);
  write_float("dem.tif", merged, "elevation up (-Z) in the traverse frame, metres; nearest site");
  if (truth.poses && !truth.dem_path.empty()) {
    std::vector<Eigen::Vector3d> centres;
    for (const SitePose& p : truth.poses->poses) centres.push_back(p.position_m);
    const RasterDifference d =
        differenceNear(merged.grid, readDemGeoTiff(truth.dem_path), centres, kTruthDemRadiusM);
    result.truth_dem_rms_m = d.rms_m;
    result.truth_dem_cells = d.cells;
  }
  if (!sigma_in.empty())
    write_float("dem_sigma.tif", mosaic(sigma_in, grid, MosaicKind::kSigma),
                "standard deviation of dem.tif, metres, with the site pose's vertical sigma");
  if (!ortho_in.empty()) {
    const Mosaic m = mosaic(ortho_in, grid, MosaicKind::kGrey);
    std::vector<uint8_t> grey(m.grid.values.size(), 0);
    for (std::size_t i = 0; i < grey.size(); ++i) {
      const float v = m.grid.values[i];
      grey[i] = v == m.grid.nodata ? 0 : static_cast<uint8_t>(std::clamp(v, 1.0f, 255.0f));
    }
    const std::string path = o.out_dir + "/ortho.tif";
    try {
      cli::writeViaTemporary(path, [&](const std::string& tmp) {
        raster::writeGeoTiff(tmp, geometryOf(m.grid), grey.data(), 0);
        raster::tagSiteRaster(tmp, tags, "grey value (8-bit), 0 = no data; nearest site");
      });
      result.files.push_back(path);
    } catch (const std::exception& e) {
      result.write_errors.push_back(path + ": " + e.what());
    }
  }
}

// A warning for the console and for report.json.
void warnTraverse(TraverseResult& result, const std::string& text) {
  cli::warn(text);
  result.warnings.push_back(text);
}

// Cross-site ties matched between every pair of neighbouring sites that were mapped (their passes);
// cross_ties.json says what each pair gave.
std::vector<CrossSiteTie> matchSites(const Traverse& traverse, const TraverseTruthInput& truth,
                                     const TraverseRunOptions& o, TraverseResult& result) {
  std::vector<int> all;
  for (int k = 0; k < static_cast<int>(traverse.sites.size()); ++k) all.push_back(k);
  const SiteLoader load = [&](int k) -> std::shared_ptr<const SiteProducts> {
    if (!result.sites[k].ok || !result.sites[k].pass) return nullptr;
    return std::make_shared<const SiteProducts>(siteProducts(traverse.sites[k], *result.sites[k].pass));
  };
  if (o.progress) cli::info("cross-site tie points between neighbouring sites");
  const std::vector<TraverseSite> truth_sites = truthSitesOf(traverse, truth.folder);
  const TraverseMatching matching = matchTraverse(
      traverse, sitePairs(traverse, all, false), load, CrossTieParams{}, truth.poses,
      [&](const SitePairMatch& m) {
        if (o.progress) cli::info(pairMatchLine(traverse, m));
      },
      &truth_sites);
  const std::string json_path = o.out_dir + "/cross_ties.json";
  try {
    cli::writeFileAtomic(json_path, matchingJson(traverse, o.out_dir + "/sites", matching).dump(2) + "\n");
    result.files.push_back(json_path);
  } catch (const std::exception& e) {
    result.write_errors.push_back(json_path + ": " + e.what());
  }
  for (const SitePairMatch& m : matching.pairs) {
    SitePairOutcome p;
    p.site_a = traverse.sites[m.a].id;
    p.site_b = traverse.sites[m.b].id;
    p.status = pairStatusName(m);
    p.message = m.error.empty() ? m.result.message : m.error;
    p.ties = static_cast<int32_t>(m.result.ties.size());
    p.observations = m.result.observationCount();
    p.search_cut = windowCut(m.params.registration);
    // Said on the console as well as in report.json: a pair that gave no ties leaves the poses across it to
    // the odometry, and a window that cuts the odometry's 3 sigmas may miss the true pose.
    const std::string pair = p.site_a + "-" + p.site_b;
    if (!p.search_cut.empty()) warnTraverse(result, pair + ": " + p.search_cut);
    if (p.status != "ok")
      warnTraverse(result, pair + " untied (" + p.status + ", " + std::to_string(p.ties) + " ties): " +
                               p.message + "; the poses across it rest on the odometry, with its sigmas");
    result.site_pairs.push_back(p);
  }
  return crossSiteObservations(matching.ties);
}

json poseJson(const SitePoseEstimate& e) {
  const Eigen::Vector4d sd = e.covariance.diagonal().cwiseMax(0.0).cwiseSqrt();
  return {{"id", e.id},
          {"position_m", {e.pose.position_m.x(), e.pose.position_m.y(), e.pose.position_m.z()}},
          {"heading_deg", e.pose.heading_rad * 180.0 / M_PI},
          {"sigma_m", {sd(0), sd(1), sd(2)}},
          {"sigma_heading_deg", sd(3) * 180.0 / M_PI},
          {"tilt_deg", {e.tilt_rad.x() * 180.0 / M_PI, e.tilt_rad.y() * 180.0 / M_PI}},
          {"sigma_tilt_deg", {e.tilt_sigma_rad.x() * 180.0 / M_PI, e.tilt_sigma_rad.y() * 180.0 / M_PI}},
          {"source", poseSourceName(e.source)},
          {"distance_m", e.distance_m}};
}

void writeReport(const Traverse& traverse, const std::optional<TraverseTruth>& truth, const TraverseResult& r,
                 const TraverseRunOptions& o) {
  json sites = json::array();
  double m1 = 0, m2 = 0, m3 = 0;
  int mapped = 0;
  for (std::size_t k = 0; k < r.sites.size(); ++k) {
    const SiteOutcome& s = r.sites[k];
    json j = poseJson(r.poses.sites[k]);
    j["kind"] = siteKindName(traverse.sites[k].kind);
    j["mapped"] = s.ok;
    if (!s.ok) j["error"] = s.error;
    j["method1_px"] = s.method1_px;
    j["method2_m"] = s.method2_m;
    j["method3_px"] = s.method3_px;
    if (k < r.datum.size() && r.datum[k].known) {
      const Vec3 mrad = 1e3 * r.datum[k].sigma_rad;
      j["datum_sigma_mrad"] = {mrad.x(), mrad.y(), mrad.z()};
    }
    if (s.truth_eo_px >= 0) j["truth_eo_px"] = s.truth_eo_px;
    sites.push_back(j);
    if (s.ok && s.method1_px >= 0) {
      m1 += s.method1_px;
      m2 += s.method2_m;
      m3 += s.method3_px;
      ++mapped;
    }
  }
  const auto stops = std::count_if(traverse.sites.begin(), traverse.sites.end(),
                                   [](const TraverseSite& s) { return s.kind == SiteKind::kStop; });
  json t = {{"sites", static_cast<int>(traverse.sites.size())},
            {"stops", stops},
            {"distance_m", traverse.distanceDrivenM()},
            {"cross_site_ties", r.cross_site_ties},
            {"cross_site_ties_source", r.cross_ties_source},
            {"cross_site_ties_rejected", r.cross_site_ties_rejected},
            {"cross_site_method1_px", r.cross_method1_px >= 0 ? json(r.cross_method1_px) : json(nullptr)},
            {"cross_site_sigma0", r.cross_sigma0},
            {"site", sites}};
  if (r.cross_ties_source == "matched") {
    json pairs = json::array();
    for (const SitePairOutcome& p : r.site_pairs) {
      json pj = {{"site_a", p.site_a},
                 {"site_b", p.site_b},
                 {"status", p.status},
                 {"ties", p.ties},
                 {"observations", p.observations}};
      if (!p.message.empty()) pj["message"] = p.message;
      if (!p.search_cut.empty()) pj["search_cut"] = p.search_cut;
      pairs.push_back(pj);
    }
    t["site_pairs"] = pairs;
  }
  std::vector<SitePose> apriori, estimated;
  std::vector<double> distance;
  for (std::size_t k = 0; k < traverse.sites.size(); ++k) {
    apriori.push_back(traverse.sites[k].apriori);
    estimated.push_back(r.poses.sites[k].pose);
    distance.push_back(r.poses.sites[k].distance_m);
  }
  if (truth) {
    const PositionErrors after = positionErrors(estimated, distance, *truth);
    const PositionErrors before = positionErrors(apriori, distance, *truth);
    t["position_error_m"] = after.rms_m;
    t["position_error_pct"] = after.rms_pct;
    t["position_error_apriori_m"] = before.rms_m;
    t["position_error_apriori_pct"] = before.rms_pct;
    if (stops > 0) {  // the same figures over the panorama sites alone
      std::vector<bool> panorama_site;
      for (const TraverseSite& s : traverse.sites) panorama_site.push_back(s.kind == SiteKind::kPanorama);
      const PositionErrors panorama = positionErrors(estimated, distance, *truth, panorama_site);
      t["position_error_panorama_sites_m"] = panorama.rms_m;
      t["position_error_panorama_sites_pct"] = panorama.rms_pct;
    }
  } else {
    t["position_error_m"] = nullptr;
    t["position_error_pct"] = nullptr;
    t["position_error_apriori_pct"] = nullptr;
  }
  json truth_json = json::object();
  if (r.truth_dem_cells >= 0) {
    truth_json["dem_rmse_m"] = r.truth_dem_rms_m;
    truth_json["dem_cells"] = r.truth_dem_cells;
    truth_json["dem_radius_m"] = kTruthDemRadiusM;
  }
  json report = {{"traverse", t},
                 {"truth", truth_json},
                 {"method1_px", mapped > 0 ? json(m1 / mapped) : json(nullptr)},
                 {"method2_m", mapped > 0 ? json(m2 / mapped) : json(nullptr)},
                 {"method3_px", mapped > 0 ? json(m3 / mapped) : json(nullptr)},
                 {"figures",
                  "traverse.position_error_m: RMS over the sites (traversing stops included) of |p - "
                  "p_true|; _pct: RMS over the sites after the first of that error / distance driven to the "
                  "site x 100; position_error_panorama_sites_*: the same over the panorama sites alone; "
                  "method1..3: "
                  "mean over the mapped sites of each site's own (report.json of sites/<id>)"},
                 {"notes", r.poses.notes},
                 {"warnings", r.warnings}};
  if (r.stream) {
    json rejected = json::object();
    for (const auto& [cause, count] : r.stream->rejected) rejected[cause] = count;
    report["stream"] = {{"sites_announced", r.stream->sites_announced},
                        {"site_duplicates", r.stream->site_duplicates},
                        {"rejected", rejected}};
  }
  if (r.rover) {
    const auto figure = [](double v) { return v >= 0.0 ? json(v) : json(nullptr); };
    report["rover_poses"] = {{"sites", r.rover->sites},
                             {"missing", r.rover->missing},
                             {"vs_ground_m", r.rover->vs_ground_m},
                             {"vs_ground_rms_m", r.rover->vs_ground_rms_m},
                             {"position_error_m", figure(r.rover->error_m)},
                             {"position_error_pct", figure(r.rover->error_pct)},
                             {"ground_position_error_m", figure(r.rover->ground_error_m)},
                             {"ground_position_error_pct", figure(r.rover->ground_error_pct)},
                             {"figures",
                              "the rover's poses (rover_poses.csv, AREOMAP_SITE_POSE) over the sites it "
                              "published: vs_ground_m per site |p_rover - p_ground|; position_error_*: as "
                              "traverse.position_error_*, the rover's and the ground's over those sites"}};
  }
  cli::writeFileAtomic(o.out_dir + "/report.json", report.dump(1) + "\n");
}

}  // namespace

TraverseTruthInput readTraverseTruthInput(const Traverse& traverse) {
  TraverseTruthInput truth;
  truth.poses = readTraverseTruth(traverse.root, traverse);
  const std::string dem = traverse.root + "/truth/dem.tif";
  if (fs::exists(dem)) truth.dem_path = dem;
  return truth;
}

SiteOutcome siteOutcome(const std::string& id, std::shared_ptr<const ground::SitePass> pass) {
  SiteOutcome s;
  s.id = id;
  s.out_dir = pass->out_dir;
  s.ok = true;
  s.method1_px = pass->report.method1_after.dist;
  s.method2_m = pass->report.method2_after.z;
  s.method3_px = pass->report.method3_after.dist;
  if (pass->report.truth) s.truth_eo_px = pass->report.truth->eo_px;
  s.pass = std::move(pass);
  return s;
}

SiteOutcome mapSite(const Traverse& traverse, std::size_t k, const TraverseRunOptions& o) {
  const TraverseSite& site = traverse.sites.at(k);
  const std::string out_dir = o.out_dir + "/sites/" + site.id;
  if (o.progress)
    cli::info("site " + std::to_string(k + 1) + "/" + std::to_string(traverse.sites.size()) + ": " + site.id);
  if (std::optional<SiteOutcome> earlier = earlierPass(site, out_dir, o)) return std::move(*earlier);
  prepareSiteFolder(out_dir);
  SiteOutcome s;
  s.id = site.id;
  s.out_dir = out_dir;
  try {
    const Dataset dataset = readDataset(site.dir);
    ground::GroundPassOptions options;
    options.out_dir = s.out_dir;
    options.progress = o.progress;
    options.products = o.products;
    s = siteOutcome(site.id, std::make_shared<const ground::SitePass>(
                                 ground::runGroundPass(dataset, options, nullptr, nullptr)));
  } catch (const std::exception& e) {
    s.error = e.what();
    cli::warn("site " + site.id + " not mapped: " + s.error);
  }
  writeSiteManifest(out_dir, site.id, s.ok, s.error);
  return s;
}

std::optional<SiteOutcome> recordedSite(const TraverseSite& site, const std::string& out_dir,
                                        std::string* why) {
  const SiteRecord record = checkSiteManifest(out_dir, site.id);
  if (!record.complete) {
    if (why) *why = record.why_not;
    return std::nullopt;
  }
  if (!record.mapped) {
    SiteOutcome s;
    s.id = site.id;
    s.out_dir = out_dir;
    s.error = record.error;
    return s;
  }
  std::shared_ptr<const ground::SitePass> pass = loadSitePass(site, out_dir);
  if (!pass) {
    if (why) *why = "report.json cannot be read";
    return std::nullopt;
  }
  return siteOutcome(site.id, std::move(pass));
}

TraverseResult runTraverse(const Traverse& traverse, const TraverseRunOptions& o) {
  std::error_code ec;
  fs::create_directories(o.out_dir + "/sites", ec);
  if (ec) throw cli::InputError(o.out_dir, "--out", "cannot create the folder: " + ec.message());
  std::vector<SiteOutcome> sites;
  for (std::size_t k = 0; k < traverse.sites.size(); ++k) sites.push_back(mapSite(traverse, k, o));
  return finishTraverse(traverse, std::move(sites), o, readTraverseTruthInput(traverse));
}

TraverseResult joinTraverse(const Traverse& traverse, const TraverseRunOptions& o) {
  std::vector<SiteOutcome> sites;
  std::string missing;
  for (const TraverseSite& site : traverse.sites) {
    const std::string out_dir = o.out_dir + "/sites/" + site.id;
    std::string why;
    std::optional<SiteOutcome> s = recordedSite(site, out_dir, &why);
    if (s) {
      sites.push_back(std::move(*s));
    } else {
      missing += (missing.empty() ? "" : "; ") + site.id + ": " + why;
    }
  }
  if (!missing.empty())
    throw cli::InputError(
        o.out_dir + "/sites", kSiteManifestName,
        "sites without a complete pass (map them with --site ID, or run with --resume): " + missing);
  return finishTraverse(traverse, std::move(sites), o, readTraverseTruthInput(traverse));
}

TraverseResult finishTraverse(const Traverse& traverse, std::vector<SiteOutcome> sites,
                              const TraverseRunOptions& o, const TraverseTruthInput& truth,
                              const std::vector<std::string>& warnings,
                              const std::optional<TraverseStreamFigures>& stream) {
  if (sites.size() != traverse.sites.size())
    throw std::logic_error("finishTraverse: one outcome per traverse site is needed");
  TraverseResult result;
  result.stream = stream;
  result.warnings = warnings;
  std::error_code ec;
  fs::create_directories(o.out_dir, ec);
  if (ec) throw cli::InputError(o.out_dir, "--out", "cannot create the folder: " + ec.message());
  result.sites = std::move(sites);
  for (const SiteOutcome& s : result.sites) {
    if (!s.ok) result.warnings.push_back("site " + s.id + " not mapped: " + s.error);
  }
  result.poses = odometryPoses(traverse);
  std::vector<CrossSiteTie> ties;
  if (!o.cross_ties_csv.empty()) {
    ties = readCrossSiteTies(o.cross_ties_csv);
    result.cross_ties_source = "file";
  } else if (o.truth_cross_ties) {
    ties = truthCrossSiteTies(truth.folder ? *truth.folder : traverse, o.truth_noise_px, 1);
    result.cross_ties_source = "truth";
  } else if (o.match_cross_ties && !o.products) {
    result.warnings.push_back(
        "no cross-site matching without the sites' products (--no-products): the poses are the odometry's.");
  } else if (o.match_cross_ties && traverse.sites.size() > 1) {
    ties = matchSites(traverse, truth, o, result);
    result.cross_ties_source = "matched";
    if (ties.empty())
      result.warnings.push_back(
          "no pair of neighbouring sites gave cross-site tie points: the poses are the "
          "odometry's (cross_ties.json says why per pair).");
  }
  if (!ties.empty()) {
    std::vector<SiteCameras> cameras;
    for (const SiteOutcome& s : result.sites)
      cameras.push_back(s.ok && s.pass ? siteCameras(*s.pass) : SiteCameras{});
    if (o.progress)
      cli::info("multi-site adjustment: " + std::to_string(ties.size()) + " cross-site observations");
    const CrossSiteAdjustment a = adjustSitePoses(traverse, cameras, ties, o.cross_sigma_px);
    result.poses = a.poses;
    result.cross_site_ties = a.ties_used;
    result.cross_site_ties_rejected = a.ties_rejected;
    result.cross_method1_px = a.method1_px;
    result.cross_sigma0 = a.sigma0;
    result.datum = a.datum;
    if (a.ties_dropped > 0)
      result.warnings.push_back(
          std::to_string(a.ties_dropped) +
          " cross-site observations name an unknown site or image, or could not be mapped; "
          "left out.");
    if (a.observations_left_out > 0)
      result.poses.notes.push_back("The adjustment took at most " + std::to_string(kMaxObsPerCrossSitePoint) +
                                   " observations of a cross-site point and fit the ties to its capacity: " +
                                   std::to_string(a.points_left_out) + " points and " +
                                   std::to_string(a.observations_left_out) +
                                   " observations left out (CrossSiteAdjustment.hpp selectCrossSiteTies).");
    writeCrossSiteTies(o.out_dir + "/cross_ties.csv", ties);
    result.files.push_back(o.out_dir + "/cross_ties.csv");
  }
  writePoses(result.poses, o.out_dir + "/poses.csv");
  if (stream && stream->rover_poses) {
    writePoses(*stream->rover_poses, o.out_dir + "/rover_poses.csv");
    result.files.push_back(o.out_dir + "/rover_poses.csv");
    result.rover = compareRoverPoses(result.poses, *stream->rover_poses, truth.poses);
  }
  writeTraverseModels(result.sites, result.poses, o.out_dir, result);
  result.files.push_back(o.out_dir + "/poses.csv");
  if (o.products) writeMergedMap(traverse, truth, result.sites, result.poses, o, result);
  writeReport(traverse, truth.poses, result, o);
  result.files.push_back(o.out_dir + "/report.json");
  return result;
}

}  // namespace areomap::traverse
