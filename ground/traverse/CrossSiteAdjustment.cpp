#include "ground/traverse/CrossSiteAdjustment.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <set>
#include <random>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>

#include "firmware_core/adjust/SitePoseAdjuster.hpp"
#include "firmware_core/camera/CameraConversion.hpp"
#include "ground/cli/AtomicFile.hpp"
#include "ground/cli/Cli.hpp"
#include "ground/dataset/TruthFiles.hpp"
#include "ground/io/CameraFile.hpp"
#include "ground/traverse/DemRegistration.hpp"
#include "ground/traverse/SiteDatum.hpp"

namespace areomap::traverse {

namespace fs = std::filesystem;

std::vector<CrossSiteTie> readCrossSiteTies(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw cli::InputError(path, "", "cannot open");
  std::vector<CrossSiteTie> ties;
  std::string line;
  std::getline(in, line);
  if (line.rfind("point,site,image,sample_px,line_px", 0) != 0)
    throw cli::InputError(path, "header", "expected point,site,image,sample_px,line_px");
  for (int row = 2; std::getline(in, line); ++row) {
    if (line.empty()) continue;
    std::stringstream s(line);
    std::string f[5];
    for (std::string& field : f) std::getline(s, field, ',');
    CrossSiteTie t;
    try {
      t.point = std::stoll(f[0]);
      t.site = f[1];
      t.image = f[2];
      t.pixel_px = Vec2(std::stod(f[3]), std::stod(f[4]));
    } catch (const std::exception&) {
      throw cli::InputError(path, "line " + std::to_string(row),
                            "expected point,site,image,sample_px,line_px");
    }
    if (!t.pixel_px.allFinite() || t.site.empty() || t.image.empty())
      throw cli::InputError(path, "line " + std::to_string(row), "empty or non-finite field");
    ties.push_back(t);
  }
  return ties;
}

void writeCrossSiteTies(const std::string& path, const std::vector<CrossSiteTie>& ties) {
  std::ostringstream out;
  out << "point,site,image,sample_px,line_px\n";
  for (const CrossSiteTie& t : ties)
    out << t.point << ',' << t.site << ',' << t.image << ',' << formatDouble(t.pixel_px.x()) << ','
        << formatDouble(t.pixel_px.y()) << '\n';
  cli::writeFileAtomic(path, out.str());
}

std::vector<CrossSiteTie> truthCrossSiteTies(const Traverse& traverse, double noise_px, uint64_t seed) {
  std::vector<CrossSiteTie> ties;
  const std::optional<TraverseTruth> truth = readTraverseTruth(traverse.root, traverse);
  if (!truth) return ties;
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  const auto noisy = [&](const Vec2& p) {
    return noise_px > 0 ? Vec2(p + noise_px * Vec2(gauss(rng), gauss(rng))) : p;
  };
  for (std::size_t k = 1; k < traverse.sites.size(); ++k) {
    const TraverseSite& here = traverse.sites[k];
    const TraverseSite& before = traverse.sites[k - 1];
    const std::vector<CheckPoint> points = readPointsCsv(here.dir + "/" + kTruthPointsFile);
    std::map<int64_t, std::vector<ImageObservation>> seen_here;
    for (const ImageObservation& o : readObservationsCsv(here.dir + "/truth/observations.csv"))
      seen_here[o.point].push_back(o);
    std::vector<std::pair<std::string, CameraModel>> models;
    for (const fs::directory_entry& f : fs::directory_iterator(before.dir + "/truth/models")) {
      if (f.path().extension() == ".cahvor")
        models.emplace_back(f.path().stem().string(), io::readCameraModelFile(f.path().string()));
    }
    std::sort(models.begin(), models.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    for (const CheckPoint& point : points) {
      const int64_t id = point.point;
      const Vec3& xyz = point.site_m;
      const auto obs = seen_here.find(id);
      if (obs == seen_here.end()) continue;
      const Vec3 there = truth->poses[k - 1].toSite(truth->poses[k].toTraverse(xyz));
      std::vector<CrossSiteTie> in_before;
      const int64_t tie_id = static_cast<int64_t>(k) * 100000000LL + id;
      for (const auto& [stem, model] : models) {
        Vec2 px;
        if (!ok(project(model, there, px)) || px.x() < 0 || px.y() < 0 || px.x() > model.width - 1 ||
            px.y() > model.height - 1)
          continue;
        in_before.push_back({tie_id, before.id, stem, noisy(px)});
      }
      if (in_before.empty()) continue;
      ties.insert(ties.end(), in_before.begin(), in_before.end());
      for (const ImageObservation& o : obs->second)
        ties.push_back({tie_id, here.id, o.image, noisy(Vec2(o.sample_px, o.line_px))});
    }
  }
  return ties;
}

namespace {

constexpr int32_t kGroundPoints = TraverseCapacity<kMaxGroundSites>::kPoints;
constexpr int32_t kGroundObservations = TraverseCapacity<kMaxGroundSites>::kObservations;

TraverseFromSite fromSitePose(const SitePose& p) {
  return {p.position_m, p.rotation()};
}

// The leg between two sites as an observation of their camera sets' relative pose: the odometry, its tilt
// known to the levelling of both frames, and both sites' datum sigmas added (SiteDatum.hpp): each camera set
// is rotated against its own levelled frame by its datum error.
LegMeasurement legOf(const TraverseSite& from_site, const TraverseSite& to_site, const SiteDatum& from,
                     const SiteDatum& to) {
  const OdometryLeg& leg = *to_site.odometry;
  LegMeasurement m;
  m.delta_position_m = leg.delta_m;
  m.delta_rotation = SitePose{Eigen::Vector3d::Zero(), leg.delta_heading_rad}.rotation();
  m.sigma_position_m = leg.sigma_m;
  const auto tilt2 = [](const SiteDatum& d) {
    return 0.5 * (d.sigma_rad.x() * d.sigma_rad.x() + d.sigma_rad.y() * d.sigma_rad.y());
  };
  const double level2 =
      std::max(kLevelSigmaRad * kLevelSigmaRad, from_site.attitude_sigma_rad * from_site.attitude_sigma_rad +
                                                    to_site.attitude_sigma_rad * to_site.attitude_sigma_rad);
  const double tilt = std::sqrt(level2 + tilt2(from) + tilt2(to));
  m.sigma_rotation_rad =
      Vec3(tilt, tilt,
           std::sqrt(leg.sigma_heading_rad * leg.sigma_heading_rad + from.sigma_rad.z() * from.sigma_rad.z() +
                     to.sigma_rad.z() * to.sigma_rad.z()));
  return m;
}

struct CameraRef {
  int32_t index = -1;
  CameraModel model;
  PhotogrammetricCamera camera;
};

// The first site is held, so the adjuster's covariances take its cameras' common rotation as exact. It is
// not: every pose placed through the ties turns with that datum error about the first site (SiteDatum.hpp).
// First order: a rotation dtheta of the frame moves site k by dtheta x p_k and its heading by dtheta_z.
void addDatumUncertainty(const Traverse& traverse, CrossSiteAdjustment& out) {
  const std::size_t n = traverse.sites.size();
  if (!out.datum[0].known) return;
  // The first site's attitude error (its IMU levelled its frame) tilts the traverse frame alike.
  const double attitude2 = traverse.sites[0].attitude_sigma_rad * traverse.sites[0].attitude_sigma_rad;
  const Vec3 var = out.datum[0].sigma_rad.cwiseAbs2() + Vec3(attitude2, attitude2, 0.0);
  for (std::size_t k = 1; k < n; ++k) {
    SitePoseEstimate& e = out.poses.sites[k];
    if (e.source != PoseSource::kCrossSiteTies) continue;
    const Vec3 p = e.pose.position_m - out.poses.sites[0].pose.position_m;
    Mat3 j;  // d(position) / d(theta) = -[p]x
    j << 0.0, p.z(), -p.y(), -p.z(), 0.0, p.x(), p.y(), -p.x(), 0.0;
    e.covariance.topLeftCorner<3, 3>() += j * var.asDiagonal() * j.transpose();
    e.covariance.block<3, 1>(0, 3) += j.col(2) * var.z();
    e.covariance.block<1, 3>(3, 0) += (j.col(2) * var.z()).transpose();
    e.covariance(3, 3) += var.z();
  }
  out.poses.notes.push_back("The poses tied to " + traverse.sites[0].id +
                            " turn with its cameras' common rotation (their datum, "
                            "known to " +
                            std::to_string(1e3 * out.datum[0].sigma_rad.norm()).substr(0, 5) +
                            " mrad from the pass's pointing corrections): their sigmas include it.");
}

// Sites that ties link to the first one, through any chain of sites (union-find over the points' sites):
// a group the ties do not link to it hangs on the odometry of the leg between; each such site gets a note.
void noteUnlinkedSites(const Traverse& traverse, const GroundSitePoseAdjuster& adjuster,
                       CrossSiteAdjustment& out) {
  const std::size_t n = traverse.sites.size();
  std::vector<int32_t> group(n);
  for (std::size_t k = 0; k < n; ++k) group[k] = static_cast<int32_t>(k);
  const auto root = [&](int32_t k) {
    while (group[static_cast<std::size_t>(k)] != k) k = group[static_cast<std::size_t>(k)];
    return k;
  };
  std::map<int32_t, int32_t> first_site_of_point;
  for (int32_t o = 0; o < adjuster.observationCount(); ++o) {
    const CrossSiteObservation& obs = adjuster.observation(o);
    if (obs.rejected || !adjuster.point(obs.point).solvable) continue;
    const int32_t k = adjuster.camera(obs.camera).site;
    const auto [it, added] = first_site_of_point.emplace(obs.point, k);
    if (!added) group[static_cast<std::size_t>(root(k))] = root(it->second);
  }
  for (std::size_t k = 1; k < n; ++k) {
    if (root(static_cast<int32_t>(k)) == root(0) || out.poses.sites[k].source != PoseSource::kCrossSiteTies)
      continue;
    out.poses.notes.push_back("Site " + traverse.sites[k].id +
                              " is tied only to sites that no tie links to " + traverse.sites[0].id +
                              ": its position rests on the odometry of a leg before it.");
  }
}

// Method 1 of the cross-site observations: the mean residual distance (-1 without any).
double crossSiteMethod1Px(const GroundSitePoseAdjuster& adjuster) {
  double sum = 0.0;
  int count = 0;
  for (int32_t o = 0; o < adjuster.observationCount(); ++o) {
    Vec2 error;
    const CrossSiteObservation& obs = adjuster.observation(o);
    if (obs.rejected || !adjuster.point(obs.point).solvable || !ok(adjuster.observationError(o, error)))
      continue;
    sum += (error * obs.sigma_px).norm();
    ++count;
  }
  return count > 0 ? sum / count : -1.0;
}

}  // namespace

TieSelection selectCrossSiteTies(const std::vector<CrossSiteTie>& ties, int32_t max_points,
                                 int32_t max_observations) {
  // Each point's observations, in file order (the first is its source).
  std::vector<int64_t> order;
  std::map<int64_t, std::vector<const CrossSiteTie*>> of_point;
  for (const CrossSiteTie& t : ties) {
    auto [it, added] = of_point.try_emplace(t.point);
    if (added) order.push_back(t.point);
    it->second.push_back(&t);
  }
  // Per point: the source, then the other sites' observations and the source site's in turn, at most
  // kMaxObsPerCrossSitePoint.
  struct Candidate {
    std::vector<const CrossSiteTie*> obs;
    std::string pair;  // the sites it ties, sorted
    std::string cell;  // its source's image and grid cell
  };
  std::map<std::string, std::vector<Candidate>> by_pair;
  std::map<std::string, std::map<std::string, std::vector<std::size_t>>> cells;  // pair -> cell -> candidates
  TieSelection out;
  for (const int64_t id : order) {
    const std::vector<const CrossSiteTie*>& all = of_point[id];
    const std::string& home = all.front()->site;
    std::vector<const CrossSiteTie*> other, same;
    std::set<std::string> sites;
    for (std::size_t k = 0; k < all.size(); ++k) {
      sites.insert(all[k]->site);
      if (k > 0) (all[k]->site == home ? same : other).push_back(all[k]);
    }
    Candidate c;
    c.obs.push_back(all.front());
    for (std::size_t k = 0; c.obs.size() < static_cast<std::size_t>(kMaxObsPerCrossSitePoint) &&
                            (k < other.size() || k < same.size());
         ++k) {
      if (k < other.size()) c.obs.push_back(other[k]);
      if (k < same.size() && c.obs.size() < static_cast<std::size_t>(kMaxObsPerCrossSitePoint))
        c.obs.push_back(same[k]);
    }
    out.observations_left_out += static_cast<int32_t>(all.size() - c.obs.size());
    for (const std::string& site : sites) c.pair += site + " ";
    const Vec2& px = all.front()->pixel_px;
    c.cell = all.front()->image + ":" + std::to_string(static_cast<int>(px.x() / kSelectionCellPx)) + ":" +
             std::to_string(static_cast<int>(px.y() / kSelectionCellPx));
    std::vector<Candidate>& list = by_pair[c.pair];
    cells[c.pair][c.cell].push_back(list.size());
    list.push_back(std::move(c));
  }
  // Every pair of sites gets an equal share of the capacity (what one pair leaves, the others may take),
  // filled round-robin over its source cells so that a thinned pair keeps its spread over the images.
  std::map<std::string, std::vector<std::size_t>> queue;  // per pair, the candidates in round-robin order
  for (auto& [pair, by_cell] : cells) {
    std::vector<std::size_t>& q = queue[pair];
    for (std::size_t round = 0;; ++round) {
      bool any = false;
      for (auto& [cell, list] : by_cell) {
        if (round < list.size()) {
          q.push_back(list[round]);
          any = true;
        }
      }
      if (!any) break;
    }
  }
  std::vector<const Candidate*> kept;
  int32_t points = 0, observations = 0;
  std::map<std::string, std::size_t> next;
  for (bool progress = true; progress;) {
    progress = false;
    const std::size_t pairs_left = std::count_if(
        queue.begin(), queue.end(), [&](const auto& q) { return next[q.first] < q.second.size(); });
    if (pairs_left == 0) break;
    const int32_t share_points =
        std::max<int32_t>(1, (max_points - points) / static_cast<int32_t>(pairs_left));
    const int32_t share_obs =
        std::max<int32_t>(1, (max_observations - observations) / static_cast<int32_t>(pairs_left));
    for (auto& [pair, q] : queue) {
      std::size_t& k = next[pair];
      int32_t p = 0, o = 0;
      while (k < q.size()) {
        const Candidate& c = by_pair[pair][q[k]];
        const int32_t n = static_cast<int32_t>(c.obs.size());
        if (p + 1 > share_points || o + n > share_obs || points + 1 > max_points ||
            observations + n > max_observations)
          break;
        kept.push_back(&c);
        ++p;
        o += n;
        ++points;
        observations += n;
        ++k;
        progress = true;
      }
    }
  }
  for (auto& [pair, q] : queue) {
    for (std::size_t k = next[pair]; k < q.size(); ++k) {
      ++out.points_left_out;
      out.observations_left_out += static_cast<int32_t>(by_pair[pair][q[k]].obs.size());
    }
  }
  for (const Candidate* c : kept) {
    for (const CrossSiteTie* t : c->obs) out.ties.push_back(*t);
  }
  return out;
}

CrossSiteAdjustment adjustSitePoses(const Traverse& traverse, const std::vector<SiteCameras>& site_cameras,
                                    const std::vector<CrossSiteTie>& ties, double sigma_px) {
  CrossSiteAdjustment out;
  const auto adjuster = std::make_unique<GroundSitePoseAdjuster>();  // 17.7 MiB of fixed arrays
  adjuster->clear();
  const SitePoseSolution odometry = odometryPoses(traverse);
  const std::size_t n = traverse.sites.size();
  out.datum.resize(n);
  for (std::size_t k = 0; k < n && k < site_cameras.size(); ++k) out.datum[k] = siteDatum(site_cameras[k]);
  int32_t site = 0;
  if (!ok(adjuster->addFirstSite(fromSitePose(traverse.sites[0].apriori), site)))
    throw std::runtime_error("traverse adjustment: cannot add the first site");
  for (std::size_t k = 1; k < n; ++k) {
    const TraverseFromSite apriori = fromSitePose(traverse.sites[k].apriori);
    const Status s = adjuster->addSite(
        legOf(traverse.sites[k - 1], traverse.sites[k], out.datum[k - 1], out.datum[k]), &apriori, site);
    if (!ok(s))
      throw std::runtime_error(std::string("traverse adjustment: site ") + traverse.sites[k].id + ": " +
                               statusName(s));
  }
  // Cameras: each mapped site's adjusted models, in its own frame.
  std::map<std::pair<std::string, std::string>, CameraRef> cameras;
  for (std::size_t k = 0; k < n && k < site_cameras.size(); ++k) {
    for (const SiteCamera& c : site_cameras[k]) {
      CameraRef ref;
      ref.model = c.adjusted;
      ConversionResidual residual;
      if (!ok(cahvorToPhotogrammetric(ref.model, ref.camera, residual))) continue;
      if (!ok(adjuster->addCamera(static_cast<int32_t>(k), ref.camera.io, ref.camera.eo.centre_m,
                                  ref.camera.m, ref.index)))
        continue;
      cameras[{traverse.sites[k].id, c.stem}] = ref;
    }
  }
  // Points and observations: the ties chosen to fit the adjuster (selectCrossSiteTies).
  const TieSelection chosen = selectCrossSiteTies(ties, kGroundPoints, kGroundObservations);
  out.points_left_out = chosen.points_left_out;
  out.observations_left_out = chosen.observations_left_out;
  std::map<int64_t, int32_t> point_of_id;
  for (const CrossSiteTie& t : chosen.ties) {
    const auto cam = cameras.find({t.site, t.image});
    Vec2 ideal;
    if (cam == cameras.end() || !ok(pixelToIdeal(cam->second.model, cam->second.camera, t.pixel_px, ideal))) {
      ++out.ties_dropped;
      continue;
    }
    auto it = point_of_id.find(t.point);
    if (it == point_of_id.end()) {
      int32_t p = 0;
      if (!ok(adjuster->addPoint(nullptr, p))) {
        ++out.ties_dropped;
        continue;
      }
      it = point_of_id.emplace(t.point, p).first;
    }
    if (!ok(adjuster->addObservation(it->second, cam->second.index, ideal, sigma_px))) ++out.ties_dropped;
  }
  SitePoseOptions options;
  SitePoseResult result;
  const Status s = adjuster->adjust(options, result);
  out.sigma0 = result.sigma0;
  out.converged = ok(s) && result.converged;
  out.ties_used = result.active_observations;
  out.ties_rejected = result.rejected_observations;
  out.poses = odometry;
  out.poses.notes.clear();
  if (!ok(s)) {
    out.poses.notes.push_back(std::string("The cross-site adjustment failed (") + statusName(s) +
                              "): the poses are the odometry's.");
    return out;
  }
  for (std::size_t k = 0; k < n; ++k) {
    const SiteState& st = adjuster->site(static_cast<int32_t>(k));
    SitePoseEstimate& e = out.poses.sites[k];
    e.pose.position_m = st.pose.position_m;
    e.pose.heading_rad = std::atan2(st.pose.rotation(1, 0), st.pose.rotation(0, 0));
    e.tilt_rad = relativePoseOf(st.pose.rotation, st.pose.position_m).tilt_rad;
    e.tilt_sigma_rad = Eigen::Vector2d(st.sigma[3], st.sigma[4]);
    e.covariance.setZero();
    e.covariance.topLeftCorner<3, 3>() = st.covariance.topLeftCorner<3, 3>();
    e.covariance.block<3, 1>(0, 3) = st.covariance.block<3, 1>(0, 5);
    e.covariance.block<1, 3>(3, 0) = st.covariance.block<1, 3>(5, 0);
    e.covariance(3, 3) = st.covariance(5, 5);
    e.source = st.link == SiteLink::kHeld   ? PoseSource::kFirstSite
               : st.link == SiteLink::kTied ? PoseSource::kCrossSiteTies
                                            : PoseSource::kOdometry;
    if (st.link == SiteLink::kNoOverlap)
      out.poses.notes.push_back("Site " + traverse.sites[k].id +
                                " has no cross-site tie to another site: its pose is the odometry's alone.");
  }
  addDatumUncertainty(traverse, out);
  noteUnlinkedSites(traverse, *adjuster, out);
  out.method1_px = crossSiteMethod1Px(*adjuster);
  return out;
}

}  // namespace areomap::traverse
