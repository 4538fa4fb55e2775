#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "ground/cli/Parallel.hpp"
#include "ground/dataset/Traverse.hpp"
#include "ground/sim/TraverseSim.hpp"
#include "ground/traverse/CrossSiteTies.hpp"
#include "ground/traverse/TraverseMatching.hpp"
#include "ground/traverse/TruthCheck.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;
using namespace areomap::traverse;

namespace {

constexpr double kPi = 3.14159265358979323846;

// Three tiny sites 7-9 m apart, rendered once per process. The tiny camera (256 x 192 px, 60 degrees: 4
// mrad a pixel, 3-4 cm on the ground between the sites) is the coarsest that the cross-site matcher is
// tested on; the navcam figures are in BENCHMARKS.md "Multi-site traverse". Its top row looks 6.6
// degrees below the horizon, 13 m out on level ground from its 1.5 m mast, so the fine terrain reaches 14 m
// beyond the outermost site (the preset's 20 m rendered ground no image sees); beyond it the coarse grid
// goes on.
// The tiny camera cannot see a 25-30 m leg at all (its views meet only within ~26 m); that reach is
// measured on navcam and imp traverses (BENCHMARKS.md).
const std::string& tinyTraverseDir() {
  static const std::string dir = [] {
    sim::TraverseSimConfig c = sim::traversePreset("tiny");
    c.seed = 7;
    c.traverse.sites = 3;
    c.traverse.leg_min_m = 7.0;
    c.traverse.leg_max_m = 9.0;
    c.terrain_margin_m = 14.0;
    const std::string d = test::scratchDir("cross-site-ties") + "/traverse";
    (void)sim::writeTraverseDataset(c, d, sim::TraverseSimOptions{});
    return d;
  }();
  return dir;
}

struct Fixture {
  Traverse traverse;
  TraverseTruth truth;
  std::vector<SiteProducts> sites;
};

// The traverse with each site's truth as its products (DEM averaged to 5 cm).
const Fixture& fixture() {
  static const Fixture f = [] {
    Fixture x;
    x.traverse = readTraverse(tinyTraverseDir());
    x.truth = *readTraverseTruth(tinyTraverseDir(), x.traverse);
    for (const TraverseSite& s : x.traverse.sites) x.sites.push_back(loadSiteTruth(s, 0.05));
    return x;
  }();
  return f;
}

// The ties of sites i and j with the tool's parameters (the registration's window from the odometry).
CrossTieResult tiesOf(int i, int j) {
  const Fixture& f = fixture();
  CrossTieParams params;
  params.registration = searchWindowOf(f.traverse, i, j);
  return findCrossSiteTies(f.sites[i], f.sites[j],
                           relativePose(f.traverse.sites[i].apriori, f.traverse.sites[j].apriori), params);
}

// areomap-cross-ties on the first two sites (truth products) on one thread, run once per process.
const std::string& toolOutputDir() {
  static const std::string dir = [] {
    const std::string out = test::scratchDir("cross-site-ties-tool-ok");
    const int status = test::runTool("areomap-cross-ties", tinyTraverseDir() +
                                                               " --truth-products --threads 1 --sites "
                                                               "site01,site02 --out " +
                                                               out);
    return status == 0 ? out : std::string();
  }();
  return dir;
}

// The ties of the neighbours (k-1, k), found once per process on three threads (the tool's, compared in
// SameInputSameTies, on one).
const CrossTieResult& neighbourTies(int k) {
  static const std::vector<CrossTieResult> results = [] {
    std::vector<CrossTieResult> r;
    cli::setThreads(3);
    for (int j = 1; j < 3; ++j) r.push_back(tiesOf(j - 1, j));
    cli::setThreads(0);
    return r;
  }();
  return results[k - 1];
}

// A smooth random texture (blurred noise), 8-bit range, as float.
cv::Mat texture(int size, uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> noise(0.0f, 1.0f);
  cv::Mat m(size, size, CV_32F);
  for (int r = 0; r < size; ++r) {
    for (int c = 0; c < size; ++c) m.at<float>(r, c) = noise(rng);
  }
  cv::GaussianBlur(m, m, cv::Size(0, 0), 1.5);
  cv::normalize(m, m, 20, 235, cv::NORM_MINMAX);
  return m;
}

std::vector<cv::Mat> pyramidOf(const cv::Mat& image) {
  std::vector<cv::Mat> p{image};
  for (int l = 1; l < kPyramidLevels; ++l) {
    cv::Mat down;
    cv::pyrDown(p.back(), down);
    p.push_back(down);
  }
  return p;
}

}  // namespace

TEST_GROUP(WarpedPatchMatcher){};

TEST(WarpedPatchMatcher, FindsAPointUnderAKnownAffineMapAtScalesOneToThree) {
  // Image J is image I under a known affine map (rotation, anisotropic scale, shear) and a shift; the
  // matcher starts from a prediction 3 px off and must land on the true point, whichever image is finer.
  const cv::Mat i_image = texture(400, 3);
  const std::vector<cv::Mat> pi = pyramidOf(i_image);
  int checked = 0;
  for (double scale : {1.0, 0.5, 0.35, 2.0}) {
    Eigen::Matrix2d a;
    const double th = 0.3;
    a << std::cos(th), -std::sin(th), std::sin(th), std::cos(th);
    a = scale * a * (Eigen::Matrix2d() << 1.0, 0.15, 0.0, 0.8).finished();
    const Eigen::Vector2d centre_i(200.3, 199.6), centre_j(150.7, 160.2);
    // J(x) = I(centre_i + a^-1 (x - centre_j)): warpAffine with the inverse map.
    const Eigen::Matrix2d inv = a.inverse();
    const Eigen::Vector2d off = centre_i - inv * centre_j;
    cv::Mat m = (cv::Mat_<double>(2, 3) << inv(0, 0), inv(0, 1), off.x(), inv(1, 0), inv(1, 1), off.y());
    cv::Mat j_image;
    // Anti-aliased when J is coarser: blur I first by the scale.
    cv::Mat src = i_image.clone();
    if (scale < 1.0) cv::GaussianBlur(src, src, cv::Size(0, 0), 0.5 / scale);
    cv::warpAffine(src, j_image, m, cv::Size(300, 300), cv::INTER_CUBIC | cv::WARP_INVERSE_MAP);
    const std::vector<cv::Mat> pj = pyramidOf(j_image);
    for (const Eigen::Vector2d& d :
         {Eigen::Vector2d(12.0, -7.0), Eigen::Vector2d(-20.0, 15.0), Eigen::Vector2d(4.0, 25.0)}) {
      const Eigen::Vector2d qi = centre_i + d;
      const Eigen::Vector2d truth_j = centre_j + a * d;
      const PatchMatch r =
          matchWarpedPatch(pi, qi, pj, truth_j + Eigen::Vector2d(2.0, -2.2), a, PatchParams{});
      CHECK_TEXT(r.result == PatchResult::kOk, ("scale " + std::to_string(scale)).c_str());
      const double tolerance = 0.15 * std::max(1.0, scale);
      CHECK_TEXT(
          (r.j_px - truth_j).norm() < tolerance,
          ("scale " + std::to_string(scale) + ": " + std::to_string((r.j_px - truth_j).norm())).c_str());
      CHECK(r.ncc > 0.9);
      ++checked;
    }
  }
  CHECK_EQUAL(12, checked);
}

TEST(WarpedPatchMatcher, RejectsAnotherPlaceAndARepeatedPattern) {
  const cv::Mat i_image = texture(300, 5), other = texture(300, 6);
  const PatchMatch r =
      matchWarpedPatch(pyramidOf(i_image), Eigen::Vector2d(150, 150), pyramidOf(other),
                       Eigen::Vector2d(150, 150), Eigen::Matrix2d::Identity(), PatchParams{});
  CHECK(r.result == PatchResult::kLowNcc);
  // Vertical stripes of period 4 px: every 4th shift matches as well as the best.
  cv::Mat stripes(100, 100, CV_32F);
  for (int y = 0; y < 100; ++y) {
    for (int x = 0; x < 100; ++x)
      stripes.at<float>(y, x) = static_cast<float>(128 + 80 * std::sin(2 * kPi * x / 4.0 + 0.01 * y));
  }
  const PatchMatch s = matchWarpedPatch(pyramidOf(stripes), Eigen::Vector2d(50, 50), pyramidOf(stripes),
                                        Eigen::Vector2d(50, 50), Eigen::Matrix2d::Identity(), PatchParams{});
  CHECK(s.result == PatchResult::kAmbiguous);
}

TEST_GROUP(CrossSiteTies){};

TEST(CrossSiteTies, DemRegistrationRecoversTheTrueRelativePose) {
  // The registration the neighbours' ties were found under (registerDems with the tool's window,
  // searchWindowOf: at least the default one, the relative tilt solved), made once for them; the levelled
  // registration of the default parameters is refused in ARefusedDemRegistrationSaysWhyInTheDataFigures and
  // checked on synthetic DEMs in DemRegistrationTest.
  const Fixture& f = fixture();
  for (int k = 1; k < 3; ++k) {
    const RelativePose apriori = relativePose(f.traverse.sites[k - 1].apriori, f.traverse.sites[k].apriori);
    const RelativePose truth = relativePose(f.truth.poses[k - 1], f.truth.poses[k]);
    const DemRegistration& g = neighbourTies(k).registration;
    CHECK(g.method == "dem");
    const double xy = (g.a_from_b.translation_m - truth.translation_m).head<2>().norm();
    const double z = std::fabs(g.a_from_b.translation_m.z() - truth.translation_m.z());
    const double heading_deg = std::fabs(g.a_from_b.heading_rad - truth.heading_rad) * 180.0 / kPi;
    const double before_xy = (apriori.translation_m - truth.translation_m).head<2>().norm();
    const double before_deg = std::fabs(apriori.heading_rad - truth.heading_rad) * 180.0 / kPi;
    std::printf(
        "\n%s-%s: a priori off by %.3f m, %.3f deg; registered %.4f m xy, %.4f m z, %.4f deg "
        "(sigma %.4f m, %.4f deg; rms %.3f m over %d samples, cost ratio %.2f)\n",
        f.sites[k - 1].id.c_str(), f.sites[k].id.c_str(), before_xy, before_deg, xy, z, heading_deg,
        g.sigma[0], g.sigma[3] * 180.0 / kPi, g.rms_m, g.used_cells, g.cost_ratio);
    CHECK(g.status == RegistrationStatus::kOk);
    CHECK(xy < 0.04);
    CHECK(z < 0.02);
    CHECK(heading_deg < 0.1);
  }
}

namespace {

// A site's DEM with smooth random errors of `rms_m` (about 0.4 m across, as a product's come in patches)
// and a dem_sigma layer of `sigma_m`.
SiteProducts withDemErrors(const SiteProducts& site, double rms_m, double sigma_m, uint32_t seed) {
  SiteProducts out = site;
  DemGrid& dem = out.dem;
  cv::Mat noise(dem.rows, dem.cols, CV_32F);
  std::mt19937 rng(seed);
  std::normal_distribution<float> unit(0.0f, 1.0f);
  for (int r = 0; r < dem.rows; ++r) {
    for (int c = 0; c < dem.cols; ++c) noise.at<float>(r, c) = unit(rng);
  }
  cv::GaussianBlur(noise, noise, cv::Size(0, 0), 0.2 / dem.cell_m);
  cv::Scalar mean, sd;
  cv::meanStdDev(noise, mean, sd);
  DemGrid sigma = dem;
  for (int r = 0; r < dem.rows; ++r) {
    for (int c = 0; c < dem.cols; ++c) {
      if (dem.at(c, r) == dem.nodata) continue;
      dem.at(c, r) += static_cast<float>(rms_m * noise.at<float>(r, c) / sd[0]);
      sigma.at(c, r) = static_cast<float>(sigma_m);
    }
  }
  out.dem_sigma = sigma;
  return out;
}

}  // namespace

TEST(CrossSiteTies, ARefusedDemRegistrationSaysWhyInTheDataFigures) {
  // Two DEMs whose errors (12 cm RMS, their dem_sigma layers saying 4 cm) outweigh the relief they share
  // (a few cm over a metre on this terrain), as the tiny camera's own products at 7-16 m: the registration
  // is refused and its message gives the figures: how far apart the DEMs are against their dem_sigma
  // layers, and the relief's signal between the best pose and a second minimum against that noise.
  const Fixture& f = fixture();
  const SiteProducts a = withDemErrors(f.sites[0], 0.12, 0.04, 1);
  const SiteProducts b = withDemErrors(f.sites[1], 0.12, 0.04, 2);
  const RelativePose apriori = relativePose(f.traverse.sites[0].apriori, f.traverse.sites[1].apriori);
  RegistrationParams params;  // a narrower window than the tools' (2 m, 5 deg), to keep the test short
  params.search_m = 1.0;
  params.search_deg = 3.0;
  const DemRegistration g = registerDems(a, b, apriori, params);
  std::printf("\n%s: %s\n", registrationStatusName(g.status), g.message.c_str());
  CHECK(g.status != RegistrationStatus::kOk);
  CHECK(g.message.find("too noisy for the relief they share") != std::string::npos);
  CHECK(g.relief_signal_m > 0.0 && g.relief_signal_m < g.coarse_rms_m);
  if (g.difference_rms_m > 0.0) CHECK(g.difference_rms_m > 2.0 * g.dem_sigma_rms_m);
}

// (In the group CrossSiteTies, whose process renders the traverse and loads its truth once for every test.)
// A registration the images do not confirm: sites 1 and 2's registration moved 0.3 m and 1.5 deg off the
// truth with a 2 cm sigma, as a DEM registration ends where the DEMs' errors are as large as the relief they
// share. Under it the first pass finds too few ties; among the poses the DEMs cannot tell from their best
// (the truth products' DEMs: the grid pose nearest the truth) the images confirm one, and the ties place
// site 2 at the truth. Without the hypotheses the pair ends too_few_ties at the wrong pose.
TEST(CrossSiteTies, AWrongButConfidentRegistrationGivesWayToThePoseTheImagesConfirm) {
  const Fixture& f = fixture();
  CrossTieParams params;
  params.registration = searchWindowOf(f.traverse, 0, 1);
  const RelativePose apriori = relativePose(f.traverse.sites[0].apriori, f.traverse.sites[1].apriori);
  const RelativePose truth = relativePose(f.truth.poses[0], f.truth.poses[1]);
  DemRegistration wrong;
  wrong.status = RegistrationStatus::kOk;
  wrong.apriori = apriori;
  wrong.a_from_b = shiftedPose(truth, 0.3, -0.25, 1.5 * kPi / 180.0);
  PoseVector variance;
  variance << 4e-4, 4e-4, 4e-4, std::pow(0.05 * kPi / 180.0, 2), 0.0, 0.0;
  wrong.covariance = variance.asDiagonal();
  wrong.sigma = wrong.covariance.diagonal().cwiseSqrt();
  const CrossTieResult r = tiesUnderRegistration(f.sites[0], f.sites[1], wrong, params);
  const double xy = (r.a_from_b.translation_m - truth.translation_m).head<2>().norm();
  const double heading_deg = std::fabs(r.a_from_b.heading_rad - truth.heading_rad) * 180.0 / kPi;
  std::printf("\n%s, %zu ties, %s registration off the truth by %.3f m, %.3f deg: %s\n",
              crossTieStatusName(r.status), r.ties.size(), r.registration.method.c_str(), xy, heading_deg,
              r.registration.message.c_str());
  CHECK(r.status == CrossTieStatus::kOk);
  CHECK(r.registration.method != "dem");
  CHECK(xy < 0.04);
  CHECK(heading_deg < 0.1);
}

TEST(CrossSiteTies, TiesAreWithinAFewTenthsOfAPixelOfTheTruth) {
  const Fixture& f = fixture();
  for (int k = 1; k < 3; ++k) {
    const CrossTieResult& r = neighbourTies(k);
    const TruthCheck t = checkAgainstTruth(r, f.traverse.sites[k - 1], f.traverse.sites[k],
                                           f.truth.poses[k - 1], f.truth.poses[k]);
    const CrossTieCounts& c = r.counts;
    std::printf(
        "\n%s-%s: %s, %zu ties, %d observations (%d interest points, %d on both DEMs, %d searched, %d "
        "matched, %d back-matched, %d ties before the check, %d observations and %d ties rejected); rms "
        "%.3f px; truth: median %.3f px, 90%% %.3f px, %d of %zu > 2 px; ties' pose %.4f m, %.4f deg\n",
        r.site_a.c_str(), r.site_b.c_str(), crossTieStatusName(r.status), r.ties.size(), r.observationCount(),
        c.interest_points, c.on_both_dems, c.predicted, c.matched, c.back_matched, c.ties_before_check,
        c.rejected_observations, c.rejected_ties, r.rms_px, t.median_px, t.p90_px, t.gross,
        t.errors_px.size(), t.ties_xy_m, t.ties_heading_deg);
    CHECK(r.status == CrossTieStatus::kOk);
    // Ties enough for the bundle to place B (checked below); the count itself is not the aim: observations
    // that the source's pixel cannot localise within the check's floor are refused, not counted.
    CHECK(r.ties.size() >= 100u);
    // Where B's views are steeper than A's, a source pixel spans several of A's: those predictions are not
    // searched (a largest stretch beyond what the 1 px floor resolves).
    CHECK(c.coarse_source > 0);
    // On these coarse images (3-4 cm a pixel where the sites overlap) a match may still sit on a
    // neighbouring texture element along the source ray, where neither the back-match nor the geometry can
    // tell (both images of a stereo pair of A move together): ~1-2 % here (6-7 % with the plane warp and a
    // translation-only sub-pixel step, a median of 0.6 px in A's images).
    std::printf("in A's images: median %.3f px, 90%% %.3f px, %d of %zu > 2 px\n", t.cross_median_px,
                t.cross_p90_px, t.cross_gross, t.cross_errors_px.size());
    CHECK(t.median_px <= 0.2);
    CHECK(t.cross_median_px <= 0.3);
    CHECK(t.gross <= 0.03 * static_cast<double>(t.errors_px.size()));
    CHECK(t.cross_gross <= 0.03 * static_cast<double>(t.cross_errors_px.size()));
    // The bundle of the ties places site B to about a cm and a few hundredths of a degree.
    CHECK(t.ties_xy_m < 0.02);
    CHECK(std::fabs(t.ties_heading_deg) < 0.05);
    // Every tie has the source in B and at least one image of A.
    for (const CrossTie& tie : r.ties) {
      int in_a = 0, sources = 0;
      for (const CrossTieObservation& o : tie.observations) {
        in_a += o.site == r.site_a;
        sources += o.source && o.site == r.site_b;
      }
      CHECK(in_a >= 1);
      CHECK_EQUAL(1, sources);
    }
  }
}

TEST(CrossSiteTies, ASitePairWithoutOverlapGetsTheStatus) {
  const Fixture& f = fixture();
  RelativePose far = relativePose(f.traverse.sites[0].apriori, f.traverse.sites[1].apriori);
  far.translation_m.x() += 300.0;
  const CrossTieResult r = findCrossSiteTies(f.sites[0], f.sites[1], far);
  CHECK(r.status == CrossTieStatus::kNoOverlap);
  CHECK(r.ties.empty());
  CHECK(r.message.find("site01") != std::string::npos);
  CHECK(r.message.find("a-priori") != std::string::npos);
}

TEST(CrossSiteTies, SameInputSameTies) {
  // The tool, in another process and on one thread, writes exactly the ties found here on three (the CSV's
  // numbers round-trip).
  const CrossTieResult& a = neighbourTies(1);
  CHECK(!toolOutputDir().empty());
  std::ifstream csv(toolOutputDir() + "/cross_ties.csv");
  std::string line;
  std::getline(csv, line);
  std::size_t rows = 0;
  for (const CrossTie& t : a.ties) {
    for (const CrossTieObservation& o : t.observations) {
      CHECK(static_cast<bool>(std::getline(csv, line)));
      std::istringstream fields(line);
      std::string point, site, image, x, y;
      std::getline(fields, point, ',');
      std::getline(fields, site, ',');
      std::getline(fields, image, ',');
      std::getline(fields, x, ',');
      std::getline(fields, y, ',');
      CHECK_EQUAL(t.point, std::stoll(point));
      STRCMP_EQUAL(o.site.c_str(), site.c_str());
      STRCMP_EQUAL(o.image.c_str(), image.c_str());
      CHECK(o.pixel_px.x() == std::stod(x));
      CHECK(o.pixel_px.y() == std::stod(y));
      ++rows;
    }
  }
  CHECK(rows > 0);
  CHECK(!std::getline(csv, line));
}

TEST(CrossSiteTies, TheToolWritesTiesAndRejectsBadInput) {
  const std::string out = test::scratchDir("cross-site-ties-tool");
  CHECK(!toolOutputDir().empty());
  std::ifstream csv(toolOutputDir() + "/cross_ties.csv");
  std::string header;
  std::getline(csv, header);
  STRCMP_EQUAL("point,site,image,sample_px,line_px", header.c_str());
  int lines = 0;
  for (std::string line; std::getline(csv, line);) ++lines;
  CHECK(lines >= 200);
  CHECK(test::fileExists(toolOutputDir() + "/cross_ties.json"));
  // No products for the sites: an input error naming the file.
  CHECK_EQUAL(1, test::runTool("areomap-cross-ties",
                               tinyTraverseDir() + " --products " + out + "/none --out " + out + "/bad"));
  CHECK_EQUAL(2, test::runTool("areomap-cross-ties", tinyTraverseDir() + " --out " + out + "/bad"));
  CHECK_EQUAL(2, test::runTool("areomap-cross-ties",
                               tinyTraverseDir() + " --truth-products --ncc 2 --out " + out + "/bad"));
  CHECK_EQUAL(1, test::runTool("areomap-cross-ties", out + "/nosuch --truth-products --out " + out + "/bad"));
}

TEST_GROUP(TraverseMatching){};

TEST(TraverseMatching, NeighboursArePairedAndAcrossStopsBackToThePanoramaSite) {
  Traverse t;
  const SiteKind P = SiteKind::kPanorama, S = SiteKind::kStop;
  for (SiteKind kind : {P, P, S, S, P, S, P}) {
    TraverseSite site;
    site.kind = kind;
    t.sites.push_back(site);
  }
  const std::vector<int> all = {0, 1, 2, 3, 4, 5, 6};
  using Pairs = std::vector<std::pair<int, int>>;
  const Pairs expected = {{0, 1}, {1, 2}, {1, 3}, {2, 3}, {1, 4}, {2, 4}, {3, 4}, {4, 5}, {4, 6}, {5, 6}};
  CHECK(expected == sitePairs(t, all, false));
  CHECK_EQUAL(21u, sitePairs(t, all, true).size());
  // A chosen subset keeps the rule among the chosen sites.
  CHECK((Pairs{{1, 3}, {1, 6}, {3, 6}} == sitePairs(t, {1, 3, 6}, false)));
  // Without stops: each site with the one before it.
  for (TraverseSite& site : t.sites) site.kind = P;
  CHECK((Pairs{{0, 1}, {1, 2}, {2, 3}, {3, 4}, {4, 5}, {5, 6}} == sitePairs(t, all, false)));
}

// A stream's sites (OUT/sites/<id>/stream: no truth/) are checked against the truth of the dataset's sites of
// the same ids; a site the dataset lacks keeps its own folder, and without a dataset every site does.
TEST(TraverseMatching, AStreamsSitesAreCheckedAgainstTheDatasetsTruth) {
  Traverse stream, dataset;
  for (const char* id : {"site02", "site03", "site09"}) {
    TraverseSite site;
    site.id = id;
    site.dir = std::string("out/sites/") + id + "/stream";
    stream.sites.push_back(site);
  }
  for (const char* id : {"site01", "site02", "site03"}) {
    TraverseSite site;
    site.id = id;
    site.dir = std::string("ds/sites/") + id;
    dataset.sites.push_back(site);
  }
  const std::vector<TraverseSite> sites = truthSitesOf(stream, dataset);
  CHECK_EQUAL(3u, sites.size());
  CHECK_EQUAL(std::string("ds/sites/site02"), sites[0].dir);
  CHECK_EQUAL(std::string("ds/sites/site03"), sites[1].dir);
  CHECK_EQUAL(std::string("out/sites/site09/stream"), sites[2].dir);
  CHECK_EQUAL(std::string("out/sites/site02/stream"), truthSitesOf(stream, std::nullopt)[0].dir);
}
