// The multi-site adjustment's verdicts (ground/traverse/CrossSiteAdjustment.hpp) on the geometry of a
// 3-site tiny traverse (no images; the sites' true models stand for their adjusted ones, the cross-site
// ties are the truth's with 0.3 px noise): a site that ties reach only through sites not linked to the
// first one is named; every site's datum sigma comes from its own pointing corrections (SiteDatum.hpp).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <set>
#include <string>
#include <vector>

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

std::vector<std::string> trueModels(const Traverse& t) {
  std::vector<std::string> dirs;
  for (const TraverseSite& s : t.sites) dirs.push_back(s.dir + "/truth/models");
  return dirs;
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
    const SiteDatum d = siteDatum(s, s.dir + "/truth/models");
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
  const SiteDatum none = siteDatum(s, s.dir + "/models");
  CHECK(none.known);
  CHECK(none.sigma_rad.norm() < 1e-9);
}
