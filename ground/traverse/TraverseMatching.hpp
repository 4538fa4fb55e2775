// The cross-site matching of a whole traverse, shared by areomap-cross-ties and
// areomap-traverse: which pairs of sites are matched (neighbours in driving order, or every pair), each
// pair's DEM search window from the odometry between them, findCrossSiteTies on each pair with point ids
// unique over the traverse, the truth check on a synthetic traverse, and cross_ties.json.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "ground/dataset/Traverse.hpp"
#include "ground/traverse/CrossSiteTies.hpp"
#include "ground/traverse/TruthCheck.hpp"

namespace areomap::traverse {

// The pairs (i, j), i < j, of the sites `chosen` (indices into traverse.sites, in driving order): each
// site with the one before it and, across traversing stops, with every one back to the last panorama site
// (a stop ties the sites around it, and the sites on either side of a stop are matched too); or with every
// one before it when all_pairs.
std::vector<std::pair<int, int>> sitePairs(const Traverse& traverse, const std::vector<int>& chosen,
                                           bool all_pairs);

struct SitePairMatch {
  int a = -1, b = -1;  // site indices, a < b
  CrossTieParams params;
  CrossTieResult result;
  std::string error;                // not matched: a site's products could not be loaded (result empty)
  std::optional<TruthCheck> truth;  // a synthetic traverse's truth
};

// A pair's status for the reports: crossTieStatusName, or "not_matched" (a site's products could not be
// loaded, or its matching failed).
const char* pairStatusName(const SitePairMatch& m);

// Site k's products, or nullptr when the site has none (its pass failed); may throw cli::InputError.
using SiteLoader = std::function<std::shared_ptr<const SiteProducts>(int)>;

struct TraverseMatching {
  std::vector<SitePairMatch> pairs;
  std::vector<CrossTie> ties;  // all pairs', point ids unique
};

// Matches every pair in order. A site is loaded once and released when no later pair needs it.
// on_pair (optional) sees each pair when it is done (progress). With `truth`, each pair is checked against
// the truth/ of its sites' folders: traverse.sites', or truth_sites' (one per traverse site, in its order)
// where the sites' folders hold no truth (a stream's sites, whose truth is in the dataset packed).
TraverseMatching matchTraverse(const Traverse& traverse, const std::vector<std::pair<int, int>>& pairs,
                               const SiteLoader& load, const CrossTieParams& base,
                               const std::optional<TraverseTruth>& truth,
                               const std::function<void(const SitePairMatch&)>& on_pair = {},
                               const std::vector<TraverseSite>* truth_sites = nullptr);

// The folders whose truth/ checks each site of `traverse` (one per site, in its order): the site of the same
// id in `folder` (the dataset a stream's sites were packed from) where it has one, else the site itself.
std::vector<TraverseSite> truthSitesOf(const Traverse& traverse, const std::optional<Traverse>& folder);

// One line per pair for the terminal: status, ties, observations, rms (and the truth figures).
std::string pairMatchLine(const Traverse& traverse, const SitePairMatch& m);

// cross_ties.json: {"traverse", "products", "pairs": [per pair: sites, status, message, the DEM
// registration, the ties' relative pose and sigmas, counts, truth]}.
nlohmann::json matchingJson(const Traverse& traverse, const std::string& products,
                            const TraverseMatching& matching);

}  // namespace areomap::traverse
