// Real Mars stereo pairs end to end, checked by independent consistency (no truth exists for them):
// areomap-dataset on ../shared/data/m2020-navcam-stereo-pairs (the raw-image service's records as served:
// 1288x968 tiles with the principal point at their corner, a 1280x960 full frame, fisheye-linearity
// CAHVORE, one position with two pointings that do not overlap, the others one pair alone), then
// areomap-ground --dataset on every rover position it makes. For each position:
//  - the written models (adjusted, or the a-priori ones the hold-out check kept) explain SIFT matches of
//    the original images (found without areomap's matcher) no worse than the a-priori models do;
//  - rectification keeps the whole overlap of each pair without blowing the image up;
//  - the tie points, triangulated here from their observations through the adjusted models (a least-squares
//    intersection of this file's own, not the pass's), reproject with an RMS of at most 0.3 px; the same
//    figure through the a-priori models is printed beside it;
//  - the DEM agrees with those independently triangulated tie points (and with the SIFT matches
//    triangulated through the adjusted models): median |dz| <= 2 cm at 2-5 m and <= 5 cm at 5-10 m from the
//    cameras (horizontal range);
//  - the DEM covers >= 90 % of the cells that both cameras of a pair see at 2-10 m (a cell is seen when its
//    centre, on the plane fitted to the triangulated ties, projects into both images and no filled DEM cell
//    between it and either camera rises above the ray by more than twice its sigma);
//  - mapped back into the rover's own frame with the record's attitude and xyz, the terrain 2-4 m in front
//    of the rover lies within 0.3 m of the rover frame's ground level (z = 0: the rover stands on what it
//    sees; a check of the frames, of the attitude's convention and of the site-frame transform).
// Skipped (SKIP line, pass) when ../shared/data is absent.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "firmware_core/camera/CameraModel.hpp"
#include "ground/dataset/Dataset.hpp"
#include "ground/dataset/DemRaster.hpp"
#include "ground/io/CameraFile.hpp"
#include "ground/products/DemCoverage.hpp"
#include "tests/ground/pass/PassChecks.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

namespace {

using areomap::CameraModel;
using areomap::Vec2;
using areomap::Vec3;
using json = nlohmann::json;

struct Observation {
  std::string stem;
  Vec2 pixel;
};

struct Position {
  std::string name;
  std::string dataset;   // the dataset folder areomap-dataset wrote
  std::string products;  // areomap-ground --dataset's output folder
  int ground_rc = -1;
  std::map<std::string, CameraModel> apriori;   // stem -> a-priori model (site frame)
  std::map<std::string, CameraModel> adjusted;  // stem -> adjusted model
  std::vector<std::pair<std::string, std::string>> pairs;  // left stem, right stem
  std::map<std::string, std::string> image_path;           // stem -> the dataset's image
  std::vector<bool> pair_adjusted;                         // report.json adjustment_check
  std::vector<Vec3> sift_points;  // SIFT matches triangulated through the adjusted models
  std::map<long long, std::vector<Observation>> ties;      // the adjustment's tie points
  Eigen::Matrix3d rover_to_site = Eigen::Matrix3d::Identity();
  Vec3 rover_in_site = Vec3::Zero();
  bool has_rover_pose = false;
};

json readJson(const std::string& path) {
  std::ifstream in(path);
  return json::parse(in, nullptr, false);
}

// "(a,b,c,...)" or a JSON array -> numbers.
std::vector<double> tupleOf(const json& value) {
  std::vector<double> out;
  if (value.is_array()) {
    for (const json& v : value) out.push_back(v.get<double>());
    return out;
  }
  if (!value.is_string()) return out;
  std::string s = value.get<std::string>();
  std::replace(s.begin(), s.end(), '(', ' ');
  std::replace(s.begin(), s.end(), ')', ' ');
  std::replace(s.begin(), s.end(), ',', ' ');
  std::istringstream in(s);
  double d = 0.0;
  while (in >> d) out.push_back(d);
  return out;
}

// The rover's pose in its site frame from the raw-image record the left image came from: attitude
// (s, v1, v2, v3) rotates rover-frame vectors into the site frame, xyz is the rover's origin in the site.
bool roverPoseOf(const std::string& record_path, Eigen::Matrix3d& rover_to_site, Vec3& rover_in_site) {
  const json r = readJson(record_path);
  if (r.is_discarded()) return false;
  const json& ext = r.contains("extended") ? r["extended"] : r;
  const std::vector<double> q = r.contains("attitude") ? tupleOf(r["attitude"]) : std::vector<double>{};
  const std::vector<double> xyz = ext.contains("xyz") ? tupleOf(ext["xyz"]) : std::vector<double>{};
  if (q.size() != 4 || xyz.size() != 3) return false;
  rover_to_site = Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized().toRotationMatrix();
  rover_in_site = Vec3(xyz[0], xyz[1], xyz[2]);
  return true;
}

// tiepoints.csv: point,image,sample_px,line_px[,kind[,status]]; observations whose status says the
// adjustment left them out are skipped.
std::map<long long, std::vector<Observation>> readTies(const std::string& path) {
  std::map<long long, std::vector<Observation>> ties;
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  std::vector<std::string> header;
  {
    std::istringstream h(line);
    std::string f;
    while (std::getline(h, f, ',')) header.push_back(f);
  }
  const auto status_col = std::find(header.begin(), header.end(), "status") - header.begin();
  while (std::getline(in, line)) {
    std::vector<std::string> f;
    std::istringstream l(line);
    std::string x;
    while (std::getline(l, x, ',')) f.push_back(x);
    if (f.size() < 4) continue;
    if (status_col < static_cast<long>(f.size()) && f[status_col] != "kept") continue;
    ties[std::stoll(f[0])].push_back({f[1], Vec2(std::stod(f[2]), std::stod(f[3]))});
  }
  return ties;
}

// Least-squares intersection of a tie point's rays through `models`: Gauss-Newton on the reprojection
// error from the midpoint of the first two rays. false when fewer than two observations have a model or
// the rays do not meet in front of the cameras.
bool triangulate(const std::vector<Observation>& obs, const std::map<std::string, CameraModel>& models, Vec3& x) {
  std::vector<std::pair<const CameraModel*, Vec2>> rays;
  for (const Observation& o : obs) {
    auto it = models.find(o.stem);
    if (it != models.end()) rays.push_back({&it->second, o.pixel});
  }
  if (rays.size() < 2) return false;
  Vec3 o0, d0, o1, d1;
  if (areomap::unproject(*rays[0].first, rays[0].second, o0, d0) != areomap::Status::kOk ||
      areomap::unproject(*rays[1].first, rays[1].second, o1, d1) != areomap::Status::kOk)
    return false;
  // Closest points of the two rays.
  const Vec3 w = o0 - o1;
  const double b = d0.dot(d1), d = d0.dot(w), e = d1.dot(w), den = 1.0 - b * b;
  if (den < 1e-12) return false;
  const double s = (b * e - d) / den, t = (e - b * d) / den;
  if (s <= 0.0 || t <= 0.0) return false;
  x = 0.5 * ((o0 + s * d0) + (o1 + t * d1));
  for (int iter = 0; iter < 20; ++iter) {
    Eigen::Matrix3d n = Eigen::Matrix3d::Zero();
    Vec3 g = Vec3::Zero();
    for (const auto& [model, pixel] : rays) {
      Vec2 p;
      areomap::Mat2x3 j;
      if (areomap::project(*model, x, p, &j) != areomap::Status::kOk) return false;
      n += j.transpose() * j;
      g += j.transpose() * (pixel - p);
    }
    const Vec3 step = n.ldlt().solve(g);
    x += step;
    if (step.norm() < 1e-9) break;
  }
  return std::isfinite(x.norm());
}

// The reprojection residuals (px) of the observations of one point at `x`.
std::vector<double> residualsOf(const std::vector<Observation>& obs, const Vec3& x,
                                const std::map<std::string, CameraModel>& models) {
  std::vector<double> r;
  for (const Observation& o : obs) {
    auto it = models.find(o.stem);
    Vec2 px;
    if (it == models.end() || areomap::project(it->second, x, px) != areomap::Status::kOk) continue;
    r.push_back((px - o.pixel).norm());
  }
  return r;
}

// Reprojection residuals (px) of every observation of every point that triangulates through `models`.
std::vector<double> residuals(const Position& p, const std::map<std::string, CameraModel>& models) {
  std::vector<double> r;
  for (const auto& [id, obs] : p.ties) {
    Vec3 x;
    if (!triangulate(obs, models, x)) continue;
    const std::vector<double> one = residualsOf(obs, x, models);
    r.insert(r.end(), one.begin(), one.end());
  }
  return r;
}

double rms(const std::vector<double>& v) {
  double s = 0.0;
  for (double x : v) s += x * x;
  return v.empty() ? NAN : std::sqrt(s / static_cast<double>(v.size()));
}

double median(std::vector<double> v) {
  if (v.empty()) return NAN;
  std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

// Every rover position of the shared pairs, made once per process.
const std::vector<Position>& positions() {
  static std::vector<Position> all;
  static bool made = false;
  if (made) return all;
  made = true;
  const std::string shared = areomap::test::sharedDataDir() + "/m2020-navcam-stereo-pairs";
  const std::string scratch = areomap::test::scratchDir("real-pairs");
  const int rc = areomap::test::runTool("areomap-dataset", "'" + shared + "' --out '" + scratch + "/datasets'");
  if (rc != 0) {
    std::printf("\n  areomap-dataset exited %d\n", rc);
    return all;
  }
  const json index = readJson(scratch + "/datasets/index.json");
  if (index.is_discarded() || !index.contains("datasets")) return all;
  for (const json& d : index["datasets"]) {
    Position p;
    p.name = d.value("name", "");
    std::string folder = d.value("folder", p.name);
    p.dataset = folder.rfind('/', 0) == 0 ? folder : scratch + "/datasets/" + folder;
    p.products = scratch + "/products-" + p.name;
    p.ground_rc = areomap::test::runTool("areomap-ground", "--dataset '" + p.dataset + "' --out '" + p.products + "'");
    const areomap::Dataset ds = areomap::readDataset(p.dataset);
    const json pano = readJson(p.dataset + "/panorama.json");
    for (std::size_t k = 0; k < ds.pairs.size(); ++k) {
      const areomap::Pair& pair = ds.pairs[k];
      if (!pair.right) continue;
      p.pairs.push_back({pair.left.stem, pair.right->stem});
      for (const areomap::ImageRef* ref : {&pair.left, &*pair.right}) {
        p.image_path[ref->stem] = ref->image_path;
        p.apriori[ref->stem] = areomap::io::readCameraModelForImage(ref->model_path, ref->image_path);
        const std::string adjusted = p.products + "/models/" + ref->stem + ".cahvor";
        if (areomap::test::fileExists(adjusted))
          p.adjusted[ref->stem] = areomap::io::readCameraModelFile(adjusted, p.apriori[ref->stem].width,
                                                                   p.apriori[ref->stem].height);
      }
      const json& left = pano["pairs"][k]["left"];
      if (!p.has_rover_pose && left.contains("source")) {
        std::string src = left["source"].get<std::string>();
        if (src.rfind('/', 0) != 0) src = shared + "/" + src.substr(src.find_last_of('/') + 1);
        p.has_rover_pose = roverPoseOf(src, p.rover_to_site, p.rover_in_site);
      }
    }
    p.ties = readTies(p.products + "/tiepoints.csv");
    const json report = readJson(p.products + "/report.json");
    for (std::size_t k = 0; k < p.pairs.size(); ++k) {
      const json* check = report.is_discarded() ? nullptr : &report["adjustment_check"]["pairs"];
      p.pair_adjusted.push_back(check != nullptr && check->is_array() && k < check->size() &&
                                (*check)[k].value("adjusted", false));
      const auto& [ls, rs] = p.pairs[k];
      if (!p.adjusted.count(ls) || !p.adjusted.count(rs)) continue;
      const areomap::test::FeatureMatches m =
          areomap::test::siftMatches(cv::imread(p.image_path[ls], cv::IMREAD_GRAYSCALE),
                                     cv::imread(p.image_path[rs], cv::IMREAD_GRAYSCALE));
      for (std::size_t i = 0; i < m.left_px.size(); ++i) {
        Vec3 x;
        const std::vector<Observation> obs{{ls, m.left_px[i]}, {rs, m.right_px[i]}};
        // A wrong SIFT match (beyond 1 px from its own intersection) says nothing of the DEM.
        if (triangulate(obs, p.adjusted, x) && rms(residualsOf(obs, x, p.adjusted)) <= 1.0) p.sift_points.push_back(x);
      }
    }
    all.push_back(std::move(p));
  }
  return all;
}

bool haveData() { return areomap::test::requireSharedData("m2020-navcam-stereo-pairs"); }

}  // namespace

TEST_GROUP(RealPairs){};

TEST(RealPairs, EveryPositionIsMappedWithProducts) {
  if (!haveData()) return;
  const std::vector<Position>& all = positions();
  CHECK_TEXT(!all.empty(), "areomap-dataset made no dataset of the shared pairs");
  for (const Position& p : all) {
    CHECK_EQUAL_TEXT(0, p.ground_rc, ("areomap-ground --dataset " + p.dataset).c_str());
    for (const char* f : {"dem.tif", "dem_sigma.tif", "ortho.tif", "report.json", "tiepoints.csv"})
      CHECK_TEXT(areomap::test::fileExists(p.products + "/" + f), (p.name + ": " + f).c_str());
    CHECK_EQUAL_TEXT(p.apriori.size(), p.adjusted.size(), (p.name + ": an adjusted model per image").c_str());
  }
}

// The written models (adjusted, or the a-priori ones kept) explain SIFT matches of the original images,
// found without areomap's matcher, no worse than the a-priori models do: within 5 % (SIFT's own
// localisation noise moves the figure a little between two nearly equal model sets).
TEST(RealPairs, WrittenModelsNoWorseOnIndependentMatches) {
  if (!haveData()) return;
  for (const Position& p : positions()) {
    if (p.ground_rc != 0) continue;
    for (std::size_t k = 0; k < p.pairs.size(); ++k) {
      const auto& [ls, rs] = p.pairs[k];
      const areomap::test::FeatureMatches m =
          areomap::test::siftMatches(cv::imread(p.image_path.at(ls), cv::IMREAD_GRAYSCALE),
                                     cv::imread(p.image_path.at(rs), cv::IMREAD_GRAYSCALE));
      const areomap::test::ModelComparison c = areomap::test::compareModels(
          m, p.apriori.at(ls), p.apriori.at(rs), p.adjusted.at(ls), p.adjusted.at(rs));
      std::printf("\n  %s pair %zu (%s): SIFT %d matches, a-priori %.3f px, written %.3f px", p.name.c_str(), k,
                  p.pair_adjusted[k] ? "adjusted" : "a-priori kept", c.matches, c.rms_a_px, c.rms_b_px);
      CHECK_TEXT(c.matches >= 50, (p.name + ": fewer than 50 SIFT matches").c_str());
      CHECK_TEXT(c.rms_b_px <= 1.05 * c.rms_a_px, (p.name + ": the written models are worse than the a-priori").c_str());
    }
  }
}

// Rectification keeps what both images show: each original left pixel whose ray at 10 m meets the right
// image lands inside the rectified left image, which holds at most twice the original's pixels.
TEST(RealPairs, RectificationKeepsTheOverlap) {
  if (!haveData()) return;
  for (const Position& p : positions()) {
    for (const auto& [ls, rs] : p.pairs) {
      const CameraModel& l = p.apriori.at(ls);
      const areomap::test::RectificationCover c = areomap::test::rectificationCover(l, p.apriori.at(rs), 10.0);
      std::printf("\n  %s: rectified %dx%d, %.1f %% of %d overlap pixels inside", ls.substr(0, 28).c_str(), c.width,
                  c.height, 100.0 * c.inside, c.overlap);
      CHECK(static_cast<double>(c.width) * c.height <= 2.0 * l.width * l.height);
      CHECK(c.inside >= 0.99);
    }
  }
}

TEST(RealPairs, TiesReprojectAfterTheAdjustment) {
  if (!haveData()) return;
  for (const Position& p : positions()) {
    if (p.ground_rc != 0) continue;
    const std::vector<double> after = residuals(p, p.adjusted);
    const std::vector<double> before = residuals(p, p.apriori);
    std::printf("\n  %s: %zu tie points; reprojection RMS %.3f px a priori, %.3f px adjusted (%zu observations)",
                p.name.c_str(), p.ties.size(), rms(before), rms(after), after.size());
    CHECK_TEXT(after.size() >= 20, (p.name + ": fewer than 20 tie observations triangulate").c_str());
    CHECK_TEXT(rms(after) <= 0.3, (p.name + ": tie reprojection RMS after the adjustment above 0.3 px").c_str());
  }
}

TEST(RealPairs, DemAgreesWithIndependentlyTriangulatedPoints) {
  if (!haveData()) return;
  for (const Position& p : positions()) {
    if (p.ground_rc != 0) continue;
    const areomap::DemGrid dem = areomap::readDemGeoTiff(p.products + "/dem.tif");
    Vec3 centre = Vec3::Zero();
    for (const auto& [stem, m] : p.adjusted) centre += m.c;
    centre /= static_cast<double>(p.adjusted.size());
    std::vector<double> near, far;
    for (const auto& [id, obs] : p.ties) {
      Vec3 x;
      double z = 0.0;
      if (!triangulate(obs, p.adjusted, x) || !areomap::products::demCellAt(dem, x.x(), x.y(), z)) continue;
      const double range = std::hypot(x.x() - centre.x(), x.y() - centre.y());
      const double dz = std::abs(z - (-x.z()));
      if (range >= 2.0 && range < 5.0) near.push_back(dz);
      if (range >= 5.0 && range <= 10.0) far.push_back(dz);
    }
    for (const Vec3& x : p.sift_points) {
      double z = 0.0;
      if (!areomap::products::demCellAt(dem, x.x(), x.y(), z)) continue;
      const double range = std::hypot(x.x() - centre.x(), x.y() - centre.y());
      const double dz = std::abs(z - (-x.z()));
      if (range >= 2.0 && range < 5.0) near.push_back(dz);
      if (range >= 5.0 && range <= 10.0) far.push_back(dz);
    }
    std::printf("\n  %s: DEM - tie points and SIFT points median |dz| %.3f m at 2-5 m (%zu), %.3f m at 5-10 m (%zu)",
                p.name.c_str(), median(near), near.size(), median(far), far.size());
    CHECK_TEXT(near.size() + far.size() >= 10, (p.name + ": fewer than 10 tie points on the DEM at 2-10 m").c_str());
    if (near.size() >= 5) CHECK_TEXT(median(near) <= 0.02, (p.name + ": DEM vs ties at 2-5 m").c_str());
    if (far.size() >= 5) CHECK_TEXT(median(far) <= 0.05, (p.name + ": DEM vs ties at 5-10 m").c_str());
  }
}

TEST(RealPairs, DemCoversWhatBothCamerasSee) {
  if (!haveData()) return;
  for (const Position& p : positions()) {
    if (p.ground_rc != 0) continue;
    const areomap::DemGrid dem = areomap::readDemGeoTiff(p.products + "/dem.tif");
    const areomap::DemGrid sigma = areomap::readDemGeoTiff(p.products + "/dem_sigma.tif");
    // The ground plane of the triangulated ties (products::fitGroundPlane: least squares, points beyond 3
    // robust sigmas left out), on which cells the DEM leaves empty are placed.
    std::vector<Vec3> pts;
    for (const auto& [id, obs] : p.ties) {
      Vec3 x;
      if (triangulate(obs, p.adjusted, x)) pts.emplace_back(x.x(), x.y(), -x.z());
    }
    CHECK_TEXT(pts.size() >= 10, (p.name + ": too few tie points for the ground plane").c_str());
    areomap::products::GroundPlane plane;
    CHECK_TEXT(areomap::products::fitGroundPlane(pts, 0.05, plane), (p.name + ": no ground plane").c_str());
    // The library's count (ground/products DemCoverage) with this independent plane, on every cell.
    areomap::products::CoverageCount count;
    for (const auto& [ls, rs] : p.pairs) {
      count += areomap::products::demCoverage(dem, &sigma, p.adjusted.at(ls), p.adjusted.at(rs), plane, 2.0,
                                              10.0);
    }
    const long seen = count.seen, filled = count.filled;
    const double coverage = seen > 0 ? static_cast<double>(filled) / static_cast<double>(seen) : 0.0;
    std::printf("\n  %s: DEM covers %.1f %% of %ld cells both cameras see at 2-10 m", p.name.c_str(), 100 * coverage, seen);
    CHECK_TEXT(seen > 0, (p.name + ": no cell seen by both cameras").c_str());
    CHECK_TEXT(coverage >= 0.9, (p.name + ": DEM coverage below 90 %").c_str());
  }
}

TEST(RealPairs, TerrainLiesAtTheRoverFramesGroundLevel) {
  if (!haveData()) return;
  int checked = 0;
  for (const Position& p : positions()) {
    if (p.ground_rc != 0 || !p.has_rover_pose) continue;
    const areomap::DemGrid dem = areomap::readDemGeoTiff(p.products + "/dem.tif");
    std::vector<double> z_rover;
    for (int row = 0; row < dem.rows; ++row) {
      for (int col = 0; col < dem.cols; ++col) {
        const float v = dem.at(col, row);
        if (v == dem.nodata || !std::isfinite(v)) continue;
        const Vec3 site(dem.northOfRow(row), dem.eastOfCol(col), -static_cast<double>(v));
        const Vec3 rover = p.rover_to_site.transpose() * (site - p.rover_in_site);
        if (rover.x() >= 2.0 && rover.x() <= 4.0 && std::abs(rover.y()) <= 2.0) z_rover.push_back(rover.z());
      }
    }
    if (z_rover.size() < 20) {
      std::printf("\n  %s: no terrain 2-4 m in front of the rover in its DEM (its cameras look elsewhere)", p.name.c_str());
      continue;
    }
    const double zm = median(z_rover);
    std::printf("\n  %s: terrain 2-4 m in front of the rover at rover z %.3f m (median of %zu cells)", p.name.c_str(),
                zm, z_rover.size());
    CHECK_TEXT(std::abs(zm) <= 0.3, (p.name + ": the terrain in front is not at the rover's ground level").c_str());
    ++checked;
  }
  CHECK_TEXT(checked >= 1, "no position sees the terrain in front of the rover");
}
