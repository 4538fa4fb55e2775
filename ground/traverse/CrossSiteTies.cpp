// Cross-site tie points between two sites (CrossSiteTies.hpp): the registration, the two passes of
// matching and checking (CrossTieSteps.hpp) and the result's status.
#include "ground/traverse/CrossSiteTies.hpp"

#include <string>

#include "ground/traverse/CrossSiteAdjustment.hpp"
#include "ground/traverse/CrossTieSteps.hpp"

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

// The two passes of matching and checking under out.registration (none when it was refused) and the
// result's status.
void matchRegistered(const SiteProducts& a, const SiteProducts& b, const CrossTieParams& params,
                     int64_t first_point, CrossTieResult& out) {
  out.a_from_b = out.registration.a_from_b;
  if (out.registration.status != RegistrationStatus::kOk) {
    out.status = out.registration.status == RegistrationStatus::kNoOverlap
                     ? CrossTieStatus::kNoOverlap
                     : CrossTieStatus::kRegistrationFailed;
    out.message = out.registration.message;
    return;
  }
  // A first pass under the registered pose (every first_pass_stride-th interest point, a wide search: the
  // registration's error is 10-30 cm on ground-pass DEMs, ten pixels and more at navcam scale), a second
  // one, every point, under the pose of the first pass's ties with a narrow search.
  const RelativePose registered = out.registration.a_from_b;
  CrossTieParams wide = params;
  wide.patch.radius_px = params.second_pass ? params.first_radius_px : params.patch.radius_px;
  const SourcePoints points = sourcePoints(b, params);
  matchTies(a, b, points, registered, out.registration.covariance, wide, first_point,
            params.second_pass ? params.first_pass_stride : 1, out);
  out.counts.ties_before_check = static_cast<int>(out.ties.size());
  checkTies(a, b, registered, params, out);
  out.first_pass_ties = static_cast<int>(out.ties.size());
  out.first_pass_counts = out.counts;
  if (params.second_pass && static_cast<int>(out.ties.size()) >= params.min_ties) {
    const RelativePose first = out.a_from_b;
    const Eigen::Matrix4d first_cov = out.a_from_b_covariance;
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

}  // namespace

CrossTieResult findCrossSiteTies(const SiteProducts& a, const SiteProducts& b, const RelativePose& apriori,
                                 const CrossTieParams& params, int64_t first_point) {
  CrossTieResult out;
  out.site_a = a.id;
  out.site_b = b.id;
  out.registration = registerDems(a, b, apriori, params.registration);
  matchRegistered(a, b, params, first_point, out);
  // A DEM registration the images do not confirm (too few ties under it: the DEMs' errors, not their relief,
  // placed it) is replaced by the orthoimages' where they register.
  if (out.status == CrossTieStatus::kTooFewTies && out.registration.method == "dem") {
    const std::string why = "sites " + a.id + " and " + b.id + ": the DEM registration gave " +
                            std::to_string(out.ties.size()) + " ties";
    DemRegistration ortho = registerOrthosInstead(a, b, out.registration, why, params.registration);
    if (ortho.status == RegistrationStatus::kOk) {
      CrossTieResult again;
      again.site_a = a.id;
      again.site_b = b.id;
      again.registration = std::move(ortho);
      matchRegistered(a, b, params, first_point, again);
      if (again.ties.size() > out.ties.size()) out = std::move(again);
    }
  }
  return out;
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
