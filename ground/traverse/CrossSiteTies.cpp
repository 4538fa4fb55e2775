// Cross-site tie points between two sites (CrossSiteTies.hpp): the registration, the two passes of
// matching and checking (CrossTieSteps.hpp) and the result's status.
#include "ground/traverse/CrossSiteTies.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include "ground/traverse/CrossSiteAdjustment.hpp"
#include "ground/traverse/CrossTieSteps.hpp"
#include "ground/traverse/PoseHypotheses.hpp"

namespace areomap::traverse {

const char* crossTieStatusName(CrossTieStatus status) {
  switch (status) {
    case CrossTieStatus::kOk:
      return "ok";
    case CrossTieStatus::kNoOverlap:
      return "no_overlap";
    case CrossTieStatus::kRegistrationFailed:
      return "registration_failed";
    case CrossTieStatus::kTooFewTies:
      return "too_few_ties";
  }
  return "unknown";
}

CrossTieCounts& CrossTieCounts::operator+=(const CrossTieCounts& o) {
  for (int CrossTieCounts::*field : {&CrossTieCounts::interest_points,
                                     &CrossTieCounts::on_both_dems,
                                     &CrossTieCounts::predicted,
                                     &CrossTieCounts::outside_image,
                                     &CrossTieCounts::beyond_range,
                                     &CrossTieCounts::grazing,
                                     &CrossTieCounts::occluded,
                                     &CrossTieCounts::scale_gate,
                                     &CrossTieCounts::coarse_source,
                                     &CrossTieCounts::too_uncertain,
                                     &CrossTieCounts::patch_outside,
                                     &CrossTieCounts::low_ncc,
                                     &CrossTieCounts::ambiguous,
                                     &CrossTieCounts::edge_peak,
                                     &CrossTieCounts::lsm_diverged,
                                     &CrossTieCounts::back_failed,
                                     &CrossTieCounts::matched,
                                     &CrossTieCounts::back_matched,
                                     &CrossTieCounts::ties_before_check,
                                     &CrossTieCounts::rejected_observations,
                                     &CrossTieCounts::rejected_ties,
                                     &CrossTieCounts::off_dem_ties})
    this->*field += o.*field;
  return *this;
}

int CrossTieResult::observationCount() const {
  int n = 0;
  for (const CrossTie& t : ties) n += static_cast<int>(t.observations.size());
  return n;
}

namespace {

// The first pass's matching parameters (its search radius) and the stride of its interest points.
CrossTieParams firstPassParams(const CrossTieParams& params) {
  CrossTieParams wide = params;
  wide.patch.radius_px = params.second_pass ? params.first_radius_px : params.patch.radius_px;
  return wide;
}
int firstPassStride(const CrossTieParams& params) { return params.second_pass ? params.first_pass_stride : 1; }

// The first pass under out.registration (kOk): every first_pass_stride-th interest point, searched over the
// registration's uncertainty (the registration's error is 10-30 cm on ground-pass DEMs, ten pixels and more
// at navcam scale), and the geometric check of what it found.
void firstPass(const SiteProducts& a, const SiteProducts& b, const SourcePoints& points,
               const CrossTieParams& params, int64_t first_point, CrossTieResult& out) {
  out.a_from_b = out.registration.a_from_b;
  const RelativePose registered = out.registration.a_from_b;
  matchTies(a, b, points, registered, out.registration.covariance, firstPassParams(params), first_point,
            firstPassStride(params), out);
  out.counts.ties_before_check = static_cast<int>(out.ties.size());
  checkTies(a, b, registered, params, out);
  out.first_pass_ties = static_cast<int>(out.ties.size());
  out.first_pass_counts = out.counts;
}

// The second pass, every point under the pose of the first pass's ties with a narrow search, and the
// result's status.
void secondPass(const SiteProducts& a, const SiteProducts& b, const SourcePoints& points,
                const CrossTieParams& params, int64_t first_point, CrossTieResult& out) {
  if (params.second_pass && static_cast<int>(out.ties.size()) >= params.min_ties) {
    const RelativePose first = out.a_from_b;
    const PoseMatrix first_cov = out.a_from_b_covariance;
    CrossTieParams narrow = params;
    narrow.patch.radius_px = params.second_radius_px;
    out.counts = CrossTieCounts{};
    out.counts_in_a = CrossTieCounts{};
    matchTies(a, b, points, first, first_cov, narrow, first_point, 1, out);
    out.counts.ties_before_check = static_cast<int>(out.ties.size());
    checkTies(a, b, first, narrow, out);
  }
  if (static_cast<int>(out.ties.size()) < params.min_ties) {
    out.status = CrossTieStatus::kTooFewTies;
    out.message = "sites " + a.id + " and " + b.id + ": " + std::to_string(out.ties.size()) +
                  " cross-site ties (at least " + std::to_string(params.min_ties) + " wanted)";
  } else {
    out.status = CrossTieStatus::kOk;
  }
}

// Both passes under out.registration (none when it was refused) and the result's status.
void matchRegistered(const SiteProducts& a, const SiteProducts& b, const SourcePoints& points,
                     const CrossTieParams& params, int64_t first_point, CrossTieResult& out) {
  out.a_from_b = out.registration.a_from_b;
  if (out.registration.status != RegistrationStatus::kOk) {
    out.status = out.registration.status == RegistrationStatus::kNoOverlap
                     ? CrossTieStatus::kNoOverlap
                     : CrossTieStatus::kRegistrationFailed;
    out.message = out.registration.message;
    return;
  }
  firstPass(a, b, points, params, first_point, out);
  secondPass(a, b, points, params, first_point, out);
}

// Whether the first pass under `r` could find `need` ties, judged from its half: the pass's points of even
// rank alone (every other point of the pass, the same patches). Each of the `need` ties that pass would check
// lies in that half with probability 1/2, independently, so seeing no more than m ties before the check there
// has probability at most P(Binomial(need, 1/2) <= m); below kPreemptRisk the whole pass is not run.
constexpr double kPreemptRisk = 0.01;  // the chance of passing over a hypothesis the full pass would confirm

bool halfCanConfirm(const SiteProducts& a, const SiteProducts& b, const SourcePoints& points,
                    const CrossTieParams& params, int64_t first_point, const DemRegistration& r, int need) {
  // As firstPass: its search radius, every other one of its points.
  CrossTieResult t;
  t.site_a = a.id;
  t.site_b = b.id;
  matchTies(a, b, points, r.a_from_b, r.covariance, firstPassParams(params), first_point,
            2 * firstPassStride(params), t);
  const int seen = static_cast<int>(t.ties.size());
  if (seen >= need) return true;
  // P(X <= seen) for X ~ Binomial(need, 1/2), each term from its logarithm.
  const double log_all = std::lgamma(need + 1.0) - need * std::log(2.0);
  double below = 0.0;
  for (int k = 0; k <= seen; ++k)
    below += std::exp(log_all - std::lgamma(k + 1.0) - std::lgamma(need - k + 1.0));
  return below >= kPreemptRisk;
}

// A registration the images do not confirm (too few ties under it), or none, is a hypothesis among others:
// the orthoimages' registration and every pose the DEMs cannot tell from their best (PoseHypotheses.hpp).
// Each is tried by the first pass (unless its half says the pass cannot confirm it, halfCanConfirm); the one
// whose checked ties are the most, and more than the registration's, goes on to the second pass and replaces
// the result when it ties more.
void confirmByImages(const SiteProducts& a, const SiteProducts& b, const SourcePoints& points,
                     const CrossTieParams& params, int64_t first_point, CrossTieResult& out) {
  const std::string pair = "sites " + a.id + " and " + b.id;
  const std::string why =
      out.registration.status == RegistrationStatus::kOk
          ? pair +
                (out.registration.method == "dem" ? ": the DEM registration gave "
                                                  : ": the orthoimages' registration gave ") +
                std::to_string(out.ties.size()) + " ties"
          : out.registration.message;
  std::vector<DemRegistration> tries;
  if (out.registration.method == "dem") {
    DemRegistration ortho = registerOrthosInstead(a, b, out.registration, why, params.registration);
    if (ortho.status == RegistrationStatus::kOk) tries.push_back(std::move(ortho));
  }
  const PoseHypotheses dem =
      demPoseHypotheses(a, b, out.registration, params.registration, params.search_sigmas);
  for (std::size_t k = 0; k < dem.poses.size(); ++k) {
    DemRegistration h = out.registration;
    h.status = RegistrationStatus::kOk;
    h.method = "dem_hypothesis";
    h.a_from_b = dem.poses[k].a_from_b;
    h.covariance = dem.poses[k].covariance;
    for (int i = 0; i < 6; ++i) h.sigma[i] = std::sqrt(h.covariance(i, i));
    h.message = why + "; " + dem.summary + "; the images confirmed the one " + std::to_string(k + 1) +
                " in the order of fit";
    tries.push_back(std::move(h));
  }
  const int before = out.first_pass_ties;
  CrossTieResult best;
  best.first_pass_ties = -1;
  int passed_over = 0;
  for (DemRegistration& r : tries) {
    // Only a pass that ties at least min_ties, more than the registration's and than the best so far counts.
    const int need = std::max({params.min_ties, before + 1, best.first_pass_ties + 1});
    if (!halfCanConfirm(a, b, points, params, first_point, r, need)) {
      ++passed_over;
      continue;
    }
    CrossTieResult t;
    t.site_a = a.id;
    t.site_b = b.id;
    t.registration = std::move(r);
    firstPass(a, b, points, params, first_point, t);
    if (t.first_pass_ties > best.first_pass_ties) best = std::move(t);
  }
  char buffer[200];
  std::snprintf(buffer, sizeof buffer,
                " (%d first-pass ties of %zu hypotheses' best, against %d; %d passed over by half their pass)",
                std::max(0, best.first_pass_ties), tries.size(), before, passed_over);
  if (best.first_pass_ties >= params.min_ties && best.first_pass_ties > before) {
    secondPass(a, b, points, params, first_point, best);
    best.registration.message += buffer;
    if (best.ties.size() > out.ties.size()) {
      out = std::move(best);
      return;
    }
  }
  // The images confirmed none: the result stays the registration's, and its message says what was tried.
  out.message += "; no other hypothesis of the pose was confirmed by the images" + std::string(buffer);
  if (!dem.summary.empty()) out.message += ": " + dem.summary;
}

}  // namespace

CrossTieResult tiesUnderRegistration(const SiteProducts& a, const SiteProducts& b,
                                     DemRegistration registration, const CrossTieParams& params,
                                     int64_t first_point) {
  CrossTieResult out;
  out.site_a = a.id;
  out.site_b = b.id;
  out.registration = std::move(registration);
  if (out.registration.status == RegistrationStatus::kNoOverlap) {
    out.a_from_b = out.registration.a_from_b;
    out.status = CrossTieStatus::kNoOverlap;
    out.message = out.registration.message;
    return out;
  }
  const SourcePoints points = sourcePoints(b, params);
  matchRegistered(a, b, points, params, first_point, out);
  if (out.status != CrossTieStatus::kOk) confirmByImages(a, b, points, params, first_point, out);
  return out;
}

CrossTieResult findCrossSiteTies(const SiteProducts& a, const SiteProducts& b, const RelativePose& apriori,
                                 const CrossTieParams& params, int64_t first_point) {
  return tiesUnderRegistration(a, b, registerDems(a, b, apriori, params.registration), params, first_point);
}

std::vector<CrossSiteTie> crossSiteObservations(const std::vector<CrossTie>& ties) {
  std::vector<CrossSiteTie> flat;
  for (const CrossTie& t : ties) {
    for (const CrossTieObservation& o : t.observations)
      flat.push_back({o.point, o.site, o.image, o.pixel_px});
  }
  return flat;
}

}  // namespace areomap::traverse
