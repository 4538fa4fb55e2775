// The multi-site constrained adjustment of a traverse (level 1): the rover stops at site after
// site and takes a panorama at each, adjusted alone by FastAdjuster; here every site is a rigid body that
// carries its cameras (their EO in the site frame fixed: the gimbal and stereo-base constraints of §3.2 hold
// within it by construction) and only the sites' poses and the cross-site tie points are unknown.
//
// Frames, the pose update and the rows are defined in SitePoseRows.hpp: the traverse frame is site 0's
// frame; a site's pose is traverse_from_site (p, Q); a camera in the traverse frame is C = p + Q C_s,
// M = M_s Q^T.
//
// Unknowns: per free site [dp, dtheta] (6), per cross-site point its position (3, traverse frame).
// Observations:
//   (a) ideal-pixel observations of cross-site points by cameras of the sites, sigma_px each (§3.1, Eq. 1);
//   (b) an odometry leg from every site to the next (its measured relative pose, 6 sigmas) — weighted
//       observations, so a site no point ties is placed by odometry alone;
//   (c) the datum: site 0 is held at its given pose (it defines the traverse frame; a hard hold, the limit
//       of a prior with zero sigma), and so are the sites before the sliding window.
// Solve: Levenberg-Marquardt whose step eliminates every point by its 3x3 block (Di, Xu, Li §3.3, as the
// fast adjuster does) onto the reduced system over the free sites' poses (PoseSystem.hpp: dense 6x6
// blocks, block Cholesky), then back-substitutes the points.
// Robust rejection as FastAdjuster: after a converged solve, per point the worst observation whose whitened
// residual norm exceeds max(reject_k x 1.4826 MAD, reject_floor_sigma) is rejected and the network solved
// again, at most kMaxRejectionRounds times. Before them a first solve under the Huber loss (huber_sigma,
// iteratively reweighted rows) keeps gross errors from dragging points and poses, which would otherwise
// make good rays of a point look worst (10 % gross errors of 10-50 px over 29 synthetic traverses: false
// rejections 10.2 -> 6.7 per traverse of ~2000 observations, worst pose error 5.4 -> 3.5 sigma).
// Sliding window: options.window_sites = K > 0 solves the last K sites (never site 0), the earlier ones
// held where they are (the points they share with the window and the leg into it still tie the window to
// them; points that only held sites see are constants and left out of the solve, its cost and sigma0). Each
// robust solve first re-admits every observation of a point that a free site sees and judges it again: a
// rejection made by an earlier window, with the sites it had then, is not kept for good (without this the
// rover's window of 4 ended with 5.6x as many good observations rejected as the whole traverse's solve).
// Warm start: adjust() starts from the current poses and points; a site added later starts at the previous
// site's current pose composed with its odometry leg, and points not yet placed are intersected from the
// rays of one site (its relative EO is exact; a solved site preferred) at the start of adjust(). A site
// added after a solved one is then resected on the points its solved neighbours placed (6 unknowns, the
// points fixed, its odometry leg in) before the Levenberg-Marquardt iterations, which then start near the
// solution (a cold start from the odometry chain has no solved site and is not resected).
// Precision: the covariance of each free site's pose (6x6, [dp, dtheta] in the traverse frame) is the
// diagonal block of S^-1, S the undamped reduced system at the solution (points eliminated, their
// uncertainty carried), scaled by max(1, sigma0)^2: sigma0 < 1 from the redundancy of a few ties is no
// evidence that the a-priori sigmas (pixels, odometry) were pessimistic, and a noise-free solve keeps the
// odometry's precision. Held sites have zero covariance (the datum); with a window the covariance is
// conditional on the held sites (their own uncertainty is not carried: on the rover it is the precision
// relative to the last held site, the ground's whole-traverse solve gives the absolute one). A free site that
// no usable cross-site observation ties to another site gets SiteLink::kNoOverlap: its pose comes from
// odometry alone, and its sigma says so.
//
// Bad input (non-finite values, bad indices, a second ray of a point in one camera, sigmas <= 0, full
// capacity) is refused with a Status and counted per status (inputErrors), never a crash.
//
// Memory: all fixed arrays sized by a TraverseCapacity (Capacities.hpp): the rover's SitePoseAdjuster
// (kMaxSites sites, 2.7 MiB, sizeof printed by its test; allocate it once, static) and the ground's
// GroundSitePoseAdjuster (kMaxGroundSites sites, the whole traverse). adjust() makes no heap allocation;
// every loop is bounded.
#pragma once

#include <cstdint>

#include "firmware_core/adjust/PoseSystem.hpp"
#include "firmware_core/adjust/SitePoseRows.hpp"
#include "firmware_core/base/Capacities.hpp"
#include "firmware_core/base/EigenTypes.hpp"
#include "firmware_core/base/Status.hpp"

namespace areomap {

// How a site stands after adjust(): held (site 0, the datum, or before the window), tied to another site
// by usable cross-site observations, or free but placed by odometry alone.
enum class SiteLink : uint8_t { kHeld = 0, kTied = 1, kNoOverlap = 2 };
const char* siteLinkName(SiteLink link);

struct SiteState {
  TraverseFromSite pose;           // current (adjusted) traverse_from_site
  TraverseFromSite apriori;        // where it started (odometry chain)
  LegMeasurement leg;              // from the previous site (unused for site 0)
  Mat6 covariance = Mat6::Zero();  // [dp (m), dtheta (rad)], traverse frame; zero when held
  Vec6 sigma = Vec6::Zero();       // square roots of its diagonal
  SiteLink link = SiteLink::kHeld;
  int32_t tie_observations = 0;  // usable observations of points that another site sees too
  bool solved = false;           // adjusted by an earlier adjust() (its points are placed by it first)
};

struct CrossSitePoint {
  Vec3 xyz_m = Vec3::Zero();  // traverse frame
  int32_t obs[kMaxObsPerCrossSitePoint] = {};
  int32_t obs_count = 0;
  bool placed = false;     // has a position (given, or intersected at the start of adjust())
  int32_t placed_by = -1;  // the site whose rays placed it (-1: given, or all rays)
  bool solvable = false;   // >= 2 rays not rejected, and placed
  bool in_window = false;  // a free site sees it: part of the last solve (else a constant, left out)
};

struct CrossSiteObservation {
  int32_t point = -1;
  int32_t camera = -1;
  Vec2 ideal_px = Vec2::Zero();
  double sigma_px = 0.3;
  bool rejected = false;
};

struct SitePoseOptions {
  int32_t window_sites = 0;  // 0: every site after site 0 is free; K > 0: the last K sites
  int32_t max_iterations = kMaxSitePoseIterations;
  double relative_cost_tolerance = 1e-10;
  // Largest site step (|dp| + nominal_range_m |dtheta|, metres at the nominal range) of a converged solve.
  double step_tolerance_m = 1e-7;
  double nominal_range_m = 10.0;
  bool robust = true;
  // Robust: a first solve under the Huber loss with this threshold (whitened residual norm; 0: none)
  // before the rejection rounds.
  double huber_sigma = 3.0;
  double reject_k = 5.0;
  double reject_floor_sigma = 4.5;
  bool covariance = true;
};

struct SitePoseResult {
  Status status = Status::kOk;
  bool converged = false;
  int32_t iterations = 0;        // linearisations of the final solve
  int32_t iterations_total = 0;  // over the Huber solve and all rejection rounds
  int32_t resected_sites = 0;    // warm start: new sites first resected on their solved neighbours' points
  int32_t resection_iterations = 0;  // their 6x6 Gauss-Newton steps (points fixed), over all of them
  int32_t rejection_rounds = 0;
  int32_t rejected_observations = 0;  // in this call
  int32_t first_free_site = 0;
  int32_t free_sites = 0;
  int32_t no_overlap_sites = 0;
  int32_t active_observations = 0;
  int32_t solvable_points = 0;        // in the solve
  int32_t unsolvable_points = 0;      // fewer than 2 rays, or not placeable
  int32_t points_outside_window = 0;  // seen by held sites only: left out of the solve
  int32_t redundancy = 0;
  double initial_cost = 0.0;
  double cost = 0.0;    // sum of whitened squares (image rows + odometry rows)
  double sigma0 = 0.0;  // sqrt(cost / redundancy)
  double rms_px = 0.0;  // RMS of the image residuals per coordinate
  Status covariance_status = Status::kOk;
};

// The capacities of one traverse adjuster, from its number of sites (Capacities.hpp gives the reasons of
// the per-site figures).
template <int32_t kSitesT>
struct TraverseCapacity {
  static constexpr int32_t kSites = kSitesT;
  static constexpr int32_t kCameras = kSitesT * kMaxCamerasPerSite;
  static constexpr int32_t kPoints = kSitesT * kMaxCrossSitePointsPerSite;
  static constexpr int32_t kObservations = kPoints * kMeanObsPerCrossSitePoint;
};

// The adjuster for a capacity; the rover's (SitePoseAdjuster) and the ground's (GroundSitePoseAdjuster)
// are instantiated in SitePoseAdjuster.cpp, SitePosePoints.cpp and SitePoseSolve.cpp.
template <typename Capacity>
class BasicSitePoseAdjuster {
 public:
  static constexpr int32_t kSites = Capacity::kSites;
  // Empties the traverse and the input-error counts.
  void clear();

  // Site 0, the datum, at `datum` (the traverse frame is its frame: normally the identity pose).
  [[nodiscard]] Status addFirstSite(const TraverseFromSite& datum, int32_t& site);
  // The next site, tied to the previous one by `leg`; it starts at `apriori` when given, else at the previous
  // site's current pose composed with the leg (the warm start).
  [[nodiscard]] Status addSite(const LegMeasurement& leg, const TraverseFromSite* apriori, int32_t& site);
  // A camera of `site` with its EO in the site frame.
  [[nodiscard]] Status addCamera(int32_t site, const InteriorOrientation& io, const Vec3& centre_in_site_m,
                                 const Mat3& m_site, int32_t& camera);
  // A cross-site point, at `xyz_m` (traverse frame) when given, else intersected at the next adjust().
  [[nodiscard]] Status addPoint(const Vec3* xyz_m, int32_t& point);
  [[nodiscard]] Status addObservation(int32_t point, int32_t camera, const Vec2& ideal_px, double sigma_px);

  // Adjusts the free sites and the points from their current state (see the top).
  [[nodiscard]] Status adjust(const SitePoseOptions& options, SitePoseResult& result);

  // Every site back to its a-priori pose, points unplaced, rejection flags cleared.
  void resetToApriori();

  int32_t siteCount() const { return site_count_; }
  int32_t cameraCount() const { return camera_count_; }
  int32_t pointCount() const { return point_count_; }
  int32_t observationCount() const { return observation_count_; }
  const SiteState& site(int32_t k) const { return sites_[k]; }
  const SiteCamera& camera(int32_t c) const { return cameras_[c]; }
  const CrossSitePoint& point(int32_t p) const { return points_[p]; }
  const CrossSiteObservation& observation(int32_t o) const { return observations_[o]; }
  // Refused inputs so far, per status and in all.
  int32_t inputErrors(Status status) const { return input_errors_[static_cast<int32_t>(status)]; }
  int32_t inputErrorTotal() const;

  // The whitened error of observation o at the current state (kBehindCamera when its point is not in
  // front), for reports (method 1) and tests.
  [[nodiscard]] Status observationError(int32_t o, Vec2& error) const;
  // Total cost at the current state (image rows of usable observations + odometry legs into the free
  // sites of the last solve's window), with the image RMS.
  double cost(double* rms_px = nullptr, int32_t* active = nullptr) const;

 private:
  Status refuse(Status status);
  // observationError with the Jacobians over the observing site's pose and the point.
  [[nodiscard]] Status observationRows(const CrossSiteObservation& o, Vec2& error, Mat2x6* d_pose,
                                       Mat2x3* d_point) const;
  bool usable(const CrossSiteObservation& o) const;
  static bool inSolve(const CrossSitePoint& pt) { return pt.solvable && pt.in_window; }
  bool freeSite(int32_t site) const { return site >= first_free_ && site > 0; }
  bool legActive(int32_t site) const { return site > 0 && (freeSite(site) || freeSite(site - 1)); }
  // Points: place the unplaced ones, mark solvability.
  void preparePoints();
  [[nodiscard]] bool placePoint(int32_t p);
  int32_t raysInFront(const CrossSitePoint& pt, const Vec3& xyz) const;
  // Whether a site's pose is better than odometry: the datum, solved by an earlier adjust(), or resected.
  bool goodPose(int32_t site) const { return site == 0 || sites_[site].solved || resected_[site]; }
  // Warm start: every new site that follows a solved one, in order, is resected (its 6 pose unknowns by
  // Gauss-Newton with the points fixed and its odometry leg) on the points placed by well-posed sites, and
  // the points it placed itself are placed again from its new pose.
  void resectNewSites(SitePoseResult& result);
  [[nodiscard]] bool resect(int32_t site, int32_t& iterations);
  // One solve from the current state.
  [[nodiscard]] Status solve(const SitePoseOptions& options, SitePoseResult& result);
  // Scales an observation's rows for the Huber loss of the current solve (no-op under least squares).
  void weightRows(Vec2& error, Mat2x6& d_pose, Mat2x3& d_point) const;
  // Builds the damped reduced system at the current state (points eliminated with damping `damping`).
  void assemble(double damping);
  // The points' steps from the last assembly and the sites' step; then applies both.
  double applyStep(const SitePoseOptions& options);
  int32_t rejectOutliers(const SitePoseOptions& options);
  // Every observation of a point that a free site sees is judged again by this solve's rejection: an
  // earlier window rejected it with the sites it had then.
  void readmitWindowObservations();
  void linkStatus(SitePoseResult& result);
  [[nodiscard]] Status precision(SitePoseResult& result, bool covariance);

  SiteState sites_[Capacity::kSites];
  SiteCamera cameras_[Capacity::kCameras];
  CrossSitePoint points_[Capacity::kPoints];
  CrossSiteObservation observations_[Capacity::kObservations];
  int32_t site_count_ = 0;
  int32_t camera_count_ = 0;
  int32_t point_count_ = 0;
  int32_t observation_count_ = 0;
  int32_t first_free_ = 1;
  double huber_ = 0.0;  // Huber threshold of the current solve (0: least squares)
  bool resected_[Capacity::kSites] = {};
  int32_t input_errors_[static_cast<int32_t>(Status::kCount)] = {};

  // Solve scratch: the reduced system, each point's damped inverse block and right-hand side from the
  // last assembly, the steps, and the state before a step (restored when it does not lower the cost).
  PoseSystem<Capacity::kSites> system_;
  Mat3 point_inverse_[Capacity::kPoints];
  Vec3 point_rhs_[Capacity::kPoints];
  bool point_eliminated_[Capacity::kPoints] = {};
  Vec3 point_step_[Capacity::kPoints];
  Vec6 site_step_[Capacity::kSites];
  TraverseFromSite saved_pose_[Capacity::kSites];
  Vec3 saved_xyz_[Capacity::kPoints];
  double scratch_[2 * Capacity::kObservations];
};

// The rover's: kMaxSites sites (~2.7 MiB, a static object).
using SitePoseAdjuster = BasicSitePoseAdjuster<TraverseCapacity<kMaxSites>>;
// The ground's: a whole traverse of up to kMaxGroundSites sites (17.7 MiB: allocate it on the heap).
using GroundSitePoseAdjuster = BasicSitePoseAdjuster<TraverseCapacity<kMaxGroundSites>>;
extern template class BasicSitePoseAdjuster<TraverseCapacity<kMaxSites>>;
extern template class BasicSitePoseAdjuster<TraverseCapacity<kMaxGroundSites>>;

}  // namespace areomap
