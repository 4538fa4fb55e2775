// The multi-site adjustment's verdicts (ground/traverse/CrossSiteAdjustment.hpp) on the geometry of a
// 3-site tiny traverse (no images; the sites' true models stand for their adjusted ones, the cross-site
// ties are the truth's with 0.3 px noise): a site that ties reach only through sites not linked to the
// first one is named; every site's datum sigma comes from its own pointing corrections (SiteDatum.hpp).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "firmware_core/base/Capacities.hpp"
#include "ground/dataset/Dataset.hpp"
#include "ground/io/CameraFile.hpp"
#include "ground/sim/TraverseSim.hpp"
#include "ground/traverse/CrossSiteAdjustment.hpp"
#include "ground/traverse/SiteDatum.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;
using namespace areomap::traverse;

namespace {

const std::string& threeSites() {
  static const std::string dir = [] {
    sim::TraverseSimConfig c = sim::traversePreset("tiny");
    c.seed = 5;
    c.traverse.sites = 3;
    c.traverse.leg_min_m = 7.0;
    c.traverse.leg_max_m = 9.0;
    sim::TraverseSimOptions options;
    options.images = false;
    const std::string d = test::scratchDir("cross-site-adjustment") + "/traverse";
    (void)sim::writeTraverseDataset(c, d, options);
    return d;
  }();
  return dir;
}

// Each site's true models standing for its adjusted ones.
std::vector<SiteCameras> trueModels(const Traverse& t) {
  std::vector<SiteCameras> cameras;
  for (const TraverseSite& s : t.sites) cameras.push_back(readSiteCameras(s, s.dir + "/truth/models"));
  return cameras;
}

bool hasNote(const CrossSiteAdjustment& a, const std::string& text) {
  for (const std::string& n : a.poses.notes) {
    if (n.find(text) != std::string::npos) return true;
  }
  return false;
}

}  // namespace

TEST_GROUP(CrossSiteAdjustment){};

TEST(CrossSiteAdjustment, SitesThatNoTieLinksToTheFirstAreNamed) {
  const Traverse t = readTraverse(threeSites());
  const TraverseTruth truth = *readTraverseTruth(threeSites(), t);
  const std::vector<CrossSiteTie> all = truthCrossSiteTies(t, 0.3, 1);
  // Every tie between the first two sites left out: sites 02 and 03 are tied to each other only.
  std::set<int64_t> with_first;
  for (const CrossSiteTie& o : all) {
    if (o.site == t.sites[0].id) with_first.insert(o.point);
  }
  std::vector<CrossSiteTie> later;
  for (const CrossSiteTie& o : all) {
    if (with_first.count(o.point) == 0) later.push_back(o);
  }
  CHECK(!with_first.empty() && later.size() > 100u);

  const CrossSiteAdjustment linked = adjustSitePoses(t, trueModels(t), all, 0.3);
  const CrossSiteAdjustment apart = adjustSitePoses(t, trueModels(t), later, 0.3);
  for (int k = 1; k < 3; ++k) {
    const double e_linked = (linked.poses.sites[k].pose.position_m - truth.poses[k].position_m).norm();
    const double e_apart = (apart.poses.sites[k].pose.position_m - truth.poses[k].position_m).norm();
    const double e_apriori = (t.sites[k].apriori.position_m - truth.poses[k].position_m).norm();
    std::printf("\n  %s: a priori %.3f m, every tie %.3f m, without the first leg's ties %.3f m",
                t.sites[k].id.c_str(), e_apriori, e_linked, e_apart);
    CHECK(linked.poses.sites[k].source == PoseSource::kCrossSiteTies);
    CHECK(apart.poses.sites[k].source == PoseSource::kCrossSiteTies);
    CHECK(e_linked < 0.05);
    const std::string note = "Site " + t.sites[k].id + " is tied only to sites that no tie links to site01";
    CHECK_FALSE(hasNote(linked, note));
    CHECK_TEXT(hasNote(apart, note), note.c_str());
  }
  std::printf("\n");
}

TEST(CrossSiteAdjustment, TheDatumSigmaComesFromTheSitesOwnPointingCorrections) {
  // The true models stand for the adjusted ones, so a site's corrections are its a-priori pointing errors:
  // their scatter against an independent figure, the RMS angle between the a-priori and true camera axes
  // (A vectors) of the left images, which sees two of the three rotation axes of each pointing error.
  const Traverse t = readTraverse(threeSites());
  for (const TraverseSite& s : t.sites) {
    const SiteDatum d = siteDatum(readSiteCameras(s, s.dir + "/truth/models"));
    const Dataset dataset = readDataset(s.dir);
    double sum2 = 0.0;
    for (const Pair& p : dataset.pairs) {
      const CameraModel apriori = io::readCameraModelFile(p.left.model_path);
      const CameraModel truth = io::readCameraModelFile(s.dir + "/truth/models/" + p.left.stem + ".cahvor");
      const double c = std::clamp(apriori.a.normalized().dot(truth.a.normalized()), -1.0, 1.0);
      sum2 += std::pow(std::acos(c), 2);
    }
    const double axes_rms = std::sqrt(sum2 / static_cast<double>(dataset.pairs.size()));
    // Two axes of a 3-axis scatter: |scatter| ~ axes_rms * sqrt(3/2) when the axes are alike.
    const double scatter = d.scatter_rad.norm();
    std::printf(
        "\n  %s: %d pairs, pointing scatter %.2f mrad (A-vector RMS %.2f mrad), datum sigma %.2f mrad",
        s.id.c_str(), d.pairs, 1e3 * scatter, 1e3 * axes_rms, 1e3 * d.sigma_rad.norm());
    CHECK(d.known);
    CHECK_EQUAL(static_cast<int>(dataset.pairs.size()), d.pairs);
    CHECK(scatter > 0.5 * axes_rms && scatter < 2.5 * axes_rms);
    DOUBLES_EQUAL(scatter / std::sqrt(static_cast<double>(d.pairs)), d.sigma_rad.norm(), 1e-12);
  }
  std::printf("\n");
  // Models that are the a-priori ones: no correction, no datum error.
  const TraverseSite& s = t.sites[0];
  const SiteDatum none = siteDatum(readSiteCameras(s, s.dir + "/models"));
  CHECK(none.known);
  CHECK(none.sigma_rad.norm() < 1e-9);
}

TEST(CrossSiteAdjustment, TiesAreFittedToTheAdjusterPairByPairAndKeepTheirSpread) {
  // Three pairs of sites: 400, 400 and 40 points of 10 observations each (source in B, 4 more in B, 5 in
  // A), the sources on a 20 x 20 grid of 64 px cells. Room for 300 points and 2000 observations.
  std::vector<CrossSiteTie> ties;
  const int counts[3] = {400, 400, 40};
  int64_t id = 0;
  for (int pair = 0; pair < 3; ++pair) {
    const std::string a = "site0" + std::to_string(pair + 1), b = "site0" + std::to_string(pair + 2);
    for (int i = 0; i < counts[pair]; ++i, ++id) {
      const Vec2 px(32.0 + 64.0 * (i % 20), 32.0 + 64.0 * ((i / 20) % 20));
      ties.push_back({id, b, "src", px});
      for (int k = 0; k < 4; ++k) ties.push_back({id, b, "b" + std::to_string(k), px});
      for (int k = 0; k < 5; ++k) ties.push_back({id, a, "a" + std::to_string(k), px});
    }
  }
  const TieSelection s = selectCrossSiteTies(ties, 300, 2000);
  std::map<int64_t, std::vector<const CrossSiteTie*>> kept;
  for (const CrossSiteTie& t : s.ties) kept[t.point].push_back(&t);
  int per_pair[3] = {};
  std::set<std::pair<int, int>> cells[3];
  int observations = 0;
  for (const auto& [point, obs] : kept) {
    const int pair = point < 400 ? 0 : point < 800 ? 1 : 2;
    ++per_pair[pair];
    observations += static_cast<int>(obs.size());
    CHECK_EQUAL(kMaxObsPerCrossSitePoint, static_cast<int>(obs.size()));
    CHECK_EQUAL(std::string("src"), obs.front()->image);  // the source first
    int in_a = 0;
    for (const CrossSiteTie* t : obs) in_a += t->image[0] == 'a' ? 1 : 0;
    CHECK(in_a >= 3);  // both sites kept
    cells[pair].insert({static_cast<int>(obs.front()->pixel_px.x() / kSelectionCellPx),
                        static_cast<int>(obs.front()->pixel_px.y() / kSelectionCellPx)});
  }
  std::printf("\n  kept %d / %d / %d points (%d observations); %d points and %d observations left out\n",
              per_pair[0], per_pair[1], per_pair[2], observations, s.points_left_out,
              s.observations_left_out);
  CHECK(static_cast<int>(kept.size()) <= 300 && observations <= 2000);
  CHECK_EQUAL(40, per_pair[2]);                                           // the small pair whole
  CHECK(per_pair[0] >= 100 && std::abs(per_pair[0] - per_pair[1]) <= 1);  // the rest shared equally
  CHECK_EQUAL(per_pair[0], static_cast<int>(cells[0].size()));            // one point a cell before a second
  CHECK_EQUAL(840 - static_cast<int>(kept.size()), s.points_left_out);
  CHECK_EQUAL(8400 - observations, s.observations_left_out);
}
