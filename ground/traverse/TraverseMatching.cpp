#include "ground/traverse/TraverseMatching.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <map>

#include <nlohmann/json.hpp>

#include "firmware_core/base/Angles.hpp"

namespace areomap::traverse {

using json = nlohmann::json;

namespace {

json countsJson(const CrossTieCounts& c) {
  return json{{"interest_points", c.interest_points},
              {"on_both_dems", c.on_both_dems},
              {"outside_image", c.outside_image},
              {"beyond_range", c.beyond_range},
              {"grazing", c.grazing},
              {"occluded", c.occluded},
              {"scale_gate", c.scale_gate},
              {"coarse_source", c.coarse_source},
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

json poseJson(const RelativePose& p) {
  return json{{"position_m", {p.translation_m.x(), p.translation_m.y(), p.translation_m.z()}},
              {"heading_deg", p.heading_rad * kRadToDeg},
              {"tilt_deg", {p.tilt_rad.x() * kRadToDeg, p.tilt_rad.y() * kRadToDeg}}};
}

// x, y, z (m), heading and the tilt's two axes (deg).
json sigmaJson(const PoseVector& s) {
  return json::array({s[0], s[1], s[2], s[3] * kRadToDeg, s[4] * kRadToDeg, s[5] * kRadToDeg});
}

}  // namespace

std::vector<std::pair<int, int>> sitePairs(const Traverse& traverse, const std::vector<int>& chosen,
                                           bool all_pairs) {
  std::vector<std::pair<int, int>> pairs;
  for (std::size_t j = 1; j < chosen.size(); ++j) {
    std::size_t first = j - 1;
    if (all_pairs) {
      first = 0;
    } else {
      while (first > 0 && traverse.sites[chosen[first]].kind == SiteKind::kStop) --first;
    }
    for (std::size_t i = first; i < j; ++i) pairs.emplace_back(chosen[i], chosen[j]);
  }
  return pairs;
}

std::vector<TraverseSite> truthSitesOf(const Traverse& traverse, const std::optional<Traverse>& folder) {
  std::vector<TraverseSite> sites = traverse.sites;
  if (!folder) return sites;
  for (TraverseSite& site : sites) {
    for (const TraverseSite& f : folder->sites) {
      if (f.id == site.id) site = f;
    }
  }
  return sites;
}

const char* pairStatusName(const SitePairMatch& m) {
  return m.error.empty() ? crossTieStatusName(m.result.status) : "not_matched";
}

TraverseMatching matchTraverse(const Traverse& traverse, const std::vector<std::pair<int, int>>& pairs,
                               const SiteLoader& load, const CrossTieParams& base,
                               const std::optional<TraverseTruth>& truth,
                               const std::function<void(const SitePairMatch&)>& on_pair,
                               const std::vector<TraverseSite>* truth_sites) {
  const std::vector<TraverseSite>& truth_dirs = truth_sites ? *truth_sites : traverse.sites;
  TraverseMatching out;
  std::map<int, std::shared_ptr<const SiteProducts>> loaded;
  std::map<int, std::string> load_errors;
  auto site = [&](int k) -> std::shared_ptr<const SiteProducts> {
    if (auto it = loaded.find(k); it != loaded.end()) return it->second;
    if (load_errors.count(k) != 0) return nullptr;
    try {
      std::shared_ptr<const SiteProducts> p = load(k);
      if (!p) load_errors[k] = "site " + traverse.sites[k].id + " has no products";
      return loaded[k] = p;
    } catch (const std::exception& e) {
      load_errors[k] = e.what();
      return loaded[k] = nullptr;
    }
  };
  int64_t next_point = 0;
  for (std::size_t n = 0; n < pairs.size(); ++n) {
    const auto [i, j] = pairs[n];
    // Release the sites that no pair from this one on needs.
    for (auto it = loaded.begin(); it != loaded.end();) {
      const bool needed = std::any_of(
          pairs.begin() + static_cast<std::ptrdiff_t>(n), pairs.end(),
          [&](const std::pair<int, int>& p) { return p.first == it->first || p.second == it->first; });
      it = needed ? std::next(it) : loaded.erase(it);
    }
    SitePairMatch m;
    m.a = i;
    m.b = j;
    m.params = base;
    m.params.registration = searchWindowOf(traverse, i, j, base.registration);
    m.result.site_a = traverse.sites[i].id;
    m.result.site_b = traverse.sites[j].id;
    const std::shared_ptr<const SiteProducts> a = site(i), b = a ? site(j) : nullptr;
    if (!a || !b) {
      m.error = load_errors[a ? j : i];
    } else {
      const RelativePose apriori = relativePose(traverse.sites[i].apriori, traverse.sites[j].apriori);
      try {
        m.result = findCrossSiteTies(*a, *b, apriori, m.params, next_point);
      } catch (const std::exception& e) {  // one pair's failure costs that pair only
        m.result = CrossTieResult{};
        m.result.site_a = traverse.sites[i].id;
        m.result.site_b = traverse.sites[j].id;
        m.error = std::string("matching failed: ") + e.what();
      }
    }
    if (m.error.empty() && a && b) {
      if (truth) {
        try {
          m.truth = checkAgainstTruth(m.result, truth_dirs[i], truth_dirs[j], truth->poses[i], truth->poses[j]);
        } catch (const std::exception&) {  // a truth that cannot be read checks nothing
          m.truth.reset();
        }
      }
      // Only a pair that gave enough ties ties its sites: fewer (kTooFewTies) cannot show a wrong tie, and
      // the poses across that leg rest on the odometry, as its warning says.
      for (const CrossTie& t : m.result.ties) {
        if (m.result.status == CrossTieStatus::kOk) out.ties.push_back(t);
        next_point = std::max(next_point, t.point + 1);
      }
    }
    if (on_pair) on_pair(m);
    out.pairs.push_back(std::move(m));
  }
  return out;
}

std::string pairMatchLine(const Traverse& traverse, const SitePairMatch& m) {
  const std::string sites = traverse.sites[m.a].id + "-" + traverse.sites[m.b].id + ": ";
  if (!m.error.empty()) return sites + "not matched: " + m.error;
  const CrossTieResult& r = m.result;
  char buffer[640];
  std::snprintf(buffer, sizeof buffer, "%s, %zu ties, %d observations, rms %.3f px",
                crossTieStatusName(r.status), r.ties.size(), r.observationCount(), r.rms_px);
  std::string line = sites + buffer;
  const DemRegistration& g = r.registration;
  if (g.status == RegistrationStatus::kOk && m.params.registration.tilt_sigma_rad > 0.0) {
    std::snprintf(buffer, sizeof buffer, "; relative tilt %.3f, %.3f deg (sigma %.3f, %.3f; prior %.3f)",
                  g.a_from_b.tilt_rad.x() * kRadToDeg, g.a_from_b.tilt_rad.y() * kRadToDeg,
                  g.sigma[4] * kRadToDeg, g.sigma[5] * kRadToDeg,
                  m.params.registration.tilt_sigma_rad * kRadToDeg);
    line += buffer;
  }
  if (const std::string cut = windowCut(m.params.registration); !cut.empty()) line += "; " + cut;
  if (m.truth) {
    const TruthCheck& t = *m.truth;
    std::snprintf(buffer, sizeof buffer,
                  "; truth: registration %.3f m xy, %.3f m z, %.3f deg, tilt %.3f deg (of %.3f); ties' pose "
                  "%.3f m xy, %.3f deg, tilt %.3f deg; "
                  "median %.3f px, 90%% %.3f px, %d of %zu > %.0f px; in A's images median %.3f px, 90%% "
                  "%.3f px, %d of %zu > %.0f px",
                  t.registration_xy_m, t.registration_z_m, t.registration_heading_deg,
                  t.registration_tilt_deg, t.true_tilt_deg, t.ties_xy_m, t.ties_heading_deg, t.ties_tilt_deg,
                  t.median_px, t.p90_px, t.gross, t.errors_px.size(), t.gross_px, t.cross_median_px,
                  t.cross_p90_px, t.cross_gross, t.cross_errors_px.size(), t.gross_px);
    line += buffer;
  }
  return line;
}

json matchingJson(const Traverse& traverse, const std::string& products, const TraverseMatching& matching) {
  json report;
  report["traverse"] = traverse.name;
  report["products"] = products;
  report["pairs"] = json::array();
  for (const SitePairMatch& m : matching.pairs) {
    const CrossTieResult& r = m.result;
    json pj;
    pj["site_a"] = traverse.sites[m.a].id;
    pj["site_b"] = traverse.sites[m.b].id;
    pj["status"] = pairStatusName(m);
    if (!m.error.empty()) {
      pj["message"] = m.error;
      report["pairs"].push_back(pj);
      continue;
    }
    if (!r.message.empty()) pj["message"] = r.message;
    const DemRegistration& g = r.registration;
    pj["registration"] = {{"status", registrationStatusName(g.status)},
                          {"method", g.method},
                          {"ortho_ncc", g.ortho_ncc},
                          {"message", g.message},
                          {"apriori", poseJson(g.apriori)},
                          {"a_from_b", poseJson(g.a_from_b)},
                          {"sigma", sigmaJson(g.sigma)},
                          {"overlap_samples", g.overlap_cells},
                          {"used_samples", g.used_cells},
                          {"rms_m", g.rms_m},
                          {"correlation_factor", g.correlation_factor},
                          {"cost_ratio", g.cost_ratio},
                          {"difference_rms_m", g.difference_rms_m},
                          {"dem_sigma_rms_m", g.dem_sigma_rms_m},
                          {"coarse_rms_m", g.coarse_rms_m},
                          {"relief_signal_m", g.relief_signal_m},
                          {"second_minimum", {{"m", g.second_offset_m}, {"deg", g.second_offset_deg}}},
                          {"drift", {{"m", g.drift_m}, {"deg", g.drift_deg}}}};
    pj["a_from_b"] = poseJson(r.a_from_b);
    pj["a_from_b_sigma"] = sigmaJson(r.a_from_b_sigma);
    pj["rms_px"] = r.rms_px;
    const RegistrationParams& w = m.params.registration;
    pj["search"] = {{"m", w.search_m},
                    {"deg", w.search_deg},
                    {"three_sigma_m", w.three_sigma_m},
                    {"three_sigma_deg", w.three_sigma_deg},
                    {"tilt_sigma_deg", w.tilt_sigma_rad * kRadToDeg}};
    if (const std::string cut = windowCut(w); !cut.empty()) pj["search"]["cut"] = cut;
    pj["first_pass_ties"] = r.first_pass_ties;
    pj["ties"] = r.ties.size();
    pj["observations"] = r.observationCount();
    pj["counts"] = countsJson(r.counts);
    pj["first_pass_counts"] = countsJson(r.first_pass_counts);
    pj["counts_in_a"] = countsJson(r.counts_in_a);
    if (m.truth) {
      const TruthCheck& t = *m.truth;
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
                     {"ties_heading_deg", t.ties_heading_deg},
                     {"true_tilt_deg", t.true_tilt_deg},
                     {"registration_tilt_deg", t.registration_tilt_deg},
                     {"ties_tilt_deg", t.ties_tilt_deg}};
    }
    report["pairs"].push_back(pj);
  }
  return report;
}

}  // namespace areomap::traverse
