// areomap-traverse's work: every site of a traverse mapped alone by the ground pass (tie points,
// fast + integrated adjustment, products with the DEM sigma of its cameras: ground/pass, a SitePass value
// per site that every later step works on),
// each site placed in the traverse frame (SitePoses.hpp), and one map over the whole traverse: the
// sites' DEM, DEM sigma and orthoimage merged by the nearest-site rule (TraverseMosaic.hpp), poses.csv
// and report.json. A site whose pass fails keeps the others going: its status says why, and the map
// is made of the rest.
//
// Two callers share it: areomap-traverse (runTraverse: every site's pass from its dataset folder, then
// finishTraverse) and areomap-ground --traverse (each site's pass made from the LCM stream as it arrives,
// then finishTraverse on the traverse the stream's site announcements describe).
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "ground/dataset/Traverse.hpp"
#include "ground/pass/GroundPass.hpp"
#include "ground/traverse/RoverPoses.hpp"
#include "ground/traverse/SiteDatum.hpp"
#include "ground/traverse/SitePoses.hpp"

namespace areomap::traverse {

struct TraverseRunOptions {
  std::string out_dir;
  bool products = true;  // per-site dense matching, DEM and ortho, and the merged map
  double cell_m = -1.0;  // merged map cell (-1: the coarsest of the sites' dem.tif cells)
  bool progress = true;
  // A site whose OUT/sites/<id> already holds a finished pass (report.json and models/) is not mapped again.
  bool reuse_sites = false;
  // A site whose OUT/sites/<id> holds a complete pass of a mapped site (its manifest.json and every file
  // it names, checksums included: SiteManifest.hpp) is not mapped again; any other site is.
  bool resume = false;
  // Cross-site tie points: matched between neighbouring sites' products (TraverseMatching.hpp; the
  // default, needs `products`), from a file (point,site,image,sample_px,line_px), or from the truth of a
  // synthetic traverse (CrossSiteAdjustment.hpp truthCrossSiteTies) with this noise; none: the poses are
  // the odometry's.
  bool match_cross_ties = true;
  std::string cross_ties_csv;
  bool truth_cross_ties = false;
  double truth_noise_px = 0.3;
  double cross_sigma_px = 0.3;  // a-priori sigma of a cross-site observation
};

struct SiteOutcome {
  std::string id;
  std::string out_dir;       // OUT/sites/<id>
  bool ok = false;           // the site's pass ran
  std::string error;         // why not
  double method1_px = -1.0;  // the site's own figures (report.json method1_px.after.dist, ...), -1: none
  double method2_m = -1.0;
  double method3_px = -1.0;
  double truth_eo_px = -1.0;  // the site's EO against its truth (synthetic sites), -1: none
  std::shared_ptr<const ground::SitePass> pass;  // the site's pass (null: not mapped)
};

// One pair of sites the matcher tried (report.json traverse.site_pairs).
struct SitePairOutcome {
  std::string site_a, site_b;
  std::string status;      // crossTieStatusName, or "not_matched" (a site without products)
  std::string message;     // why not ok
  std::string search_cut;  // the DEM registration's window cut the odometry's 3 sigmas (windowCut)
  int32_t ties = 0;
  int32_t observations = 0;
};

// The camera stream's figures of a traverse received over LCM (areomap-ground --traverse): report.json
// `stream`.
struct TraverseStreamFigures {
  int32_t sites_announced = 0;              // site announcements accepted
  int32_t site_duplicates = 0;              // announcements whose sequence was seen before (dropped)
  std::map<std::string, int32_t> rejected;  // cause -> count (site announcements and unannounced pairs)
  // The rover's own poses (AREOMAP_SITE_POSE), traverse order, the sites it published (written as
  // rover_poses.csv, compared in report.json rover_poses).
  std::optional<SitePoseSolution> rover_poses;
};

struct TraverseResult {
  std::vector<SiteOutcome> sites;
  SitePoseSolution poses;
  std::string cross_ties_source = "none";   // "matched", "file", "truth" or "none"
  std::vector<SitePairOutcome> site_pairs;  // when matched
  int32_t cross_site_ties = 0;              // observations in the multi-site adjustment
  int32_t cross_site_ties_rejected = 0;
  double cross_method1_px = -1.0;  // mean residual of the cross-site observations
  double cross_sigma0 = 0.0;
  // Per site, when the multi-site adjustment ran: how well its cameras' common rotation is known
  // (SiteDatum.hpp; report.json site[].datum_sigma_mrad).
  std::vector<SiteDatum> datum;
  std::vector<std::string> files;     // written (paths)
  std::vector<std::string> warnings;  // also in report.json
  std::vector<std::string> write_errors;
  std::optional<TraverseStreamFigures> stream;
  std::optional<RoverPoseComparison> rover;  // when the stream carried the rover's poses
  // The merged dem.tif against DATASET/truth/dem.tif within kTruthDemRadiusM of a site's true position
  // (cells < 0: no truth).
  double truth_dem_rms_m = -1.0;
  long long truth_dem_cells = -1;
};

inline constexpr double kTruthDemRadiusM = 10.0;  // the merged DEM is judged within 10 m of any site

// What a traverse's truth gives the report: the true poses (truth/traverse.json, in the traverse's site
// order) and the terrain (truth/dem.tif; "" when absent).
struct TraverseTruthInput {
  std::optional<TraverseTruth> poses;
  std::string dem_path;
  // The traverse folder whose sites' truth/ makes truth cross-site ties (--truth-cross-ties); unset: the
  // traverse mapped itself.
  std::optional<Traverse> folder;
};
// From traverse.root (a synthetic traverse's truth/), nothing when absent.
TraverseTruthInput readTraverseTruthInput(const Traverse& traverse);

// Runs everything into options.out_dir, site after site. Throws cli::InputError for an out_dir that cannot
// be made, and when a site's folder or manifest cannot be written (mapSite).
TraverseResult runTraverse(const Traverse& traverse, const TraverseRunOptions& options);

// Site k (0-based) mapped alone into OUT/sites/<id> (emptied first), ending with its manifest.json
// (SiteManifest.hpp): areomap-traverse --site, and each site of runTraverse. A pass that fails for its
// data is an outcome (ok false, `error`, also in the manifest); a site folder or manifest that cannot be
// written throws cli::InputError (the run cannot go on as if the site were done). With options.resume or
// reuse_sites an earlier pass is taken instead when it qualifies.
SiteOutcome mapSite(const Traverse& traverse, std::size_t k, const TraverseRunOptions& options);

// What a site's manifest records: its pass rebuilt from its files (SitePassFiles.hpp) when it was mapped,
// or the error that kept it from being mapped. nullopt when the manifest is missing or does not match the
// files (the reason in `why`).
std::optional<SiteOutcome> recordedSite(const TraverseSite& site, const std::string& out_dir, std::string* why);

// The cross-site step alone, on the passes the sites' manifests record (areomap-traverse --join, the job
// that follows the sites' jobs). Throws cli::InputError naming every site without a complete pass.
TraverseResult joinTraverse(const Traverse& traverse, const TraverseRunOptions& options);

// A mapped site's outcome: its pass and the pass's figures (report.json's method 1-3 and truth EO).
SiteOutcome siteOutcome(const std::string& id, std::shared_ptr<const ground::SitePass> pass);

// The traverse steps once every site's pass is done (`sites`, one per traverse site, in order): poses
// (odometry, or the multi-site adjustment with cross-site ties), poses.csv, the sites' models in the
// traverse frame, the merged dem/dem_sigma/ortho, report.json (with `stream` when given). `warnings` go
// into report.json before the steps' own.
TraverseResult finishTraverse(const Traverse& traverse, std::vector<SiteOutcome> sites,
                              const TraverseRunOptions& options, const TraverseTruthInput& truth,
                              const std::vector<std::string>& warnings = {},
                              const std::optional<TraverseStreamFigures>& stream = std::nullopt);

}  // namespace areomap::traverse
