// Seen, interpolated, unseen (ground/dem/DemSeen.hpp) on a drawn scene: flat ground with one box-shaped
// rock in front of a camera 1.5 m up. The measured cells are those the camera sees (a horizon sweep in the
// true terrain, ground/dem Viewshed), every third one left out as a matcher would; the cells behind the rock
// carry the estimate a kriging spreads there, the lines of sight that graze the rock's top. Checked: the
// shadow is emptied, the seen gaps stay interpolated, the ground outside the image is emptied; cells of the
// shadow that hold points behind the rock's face (moved along the lines of sight through it) are unseen.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "ground/dem/DemSeen.hpp"
#include "ground/dem/Viewshed.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;
using namespace areomap::dem;

namespace {

constexpr double kEyeUpM = 1.5;
constexpr double kRockHeightM = 0.4;

// Looking north, 20 degrees down, 400 x 300 px, 60 degrees across.
CameraModel northCamera() {
  const double tilt = 20.0 * M_PI / 180.0;
  const Vec3 a(std::cos(tilt), 0.0, std::sin(tilt));
  const Vec3 h(0.0, 1.0, 0.0);
  const Vec3 v = a.cross(h).normalized();
  const int width = 400, height = 300;
  const double focal = 0.5 * width / std::tan(30.0 * M_PI / 180.0);
  CameraModel m;
  m.c = Vec3(0.0, 0.0, -kEyeUpM);
  m.a = a;
  m.h = focal * h + 0.5 * (width - 1) * a;
  m.v = focal * v + 0.5 * (height - 1) * a;
  m.width = width;
  m.height = height;
  return m;
}

bool inRock(double north, double east) { return north >= 4.0 && north < 4.4 && std::fabs(east) < 0.3; }

// The drawn scene: the true terrain, its horizon from the camera, the DEM as kriged (the shadow behind the
// rock at the grazing lines of sight), the cells the camera sees and the measured ones.
struct RockScene {
  DemGrid truth;
  CameraModel camera = northCamera();
  ImageCone cone;
  std::vector<float> horizon;
  KrigingResult kr;
  std::vector<uint8_t> measured, seen;
};

RockScene rockScene() {
  RockScene sc;
  DemGrid& truth = sc.truth;
  truth.cell_m = 0.05;
  truth.north0_m = 10.0;
  truth.east0_m = -5.0;
  truth.cols = truth.rows = 200;
  truth.values.assign(static_cast<std::size_t>(truth.cols) * truth.rows, 0.0f);
  for (int r = 0; r < truth.rows; ++r)
    for (int c = 0; c < truth.cols; ++c)
      if (inRock(truth.northOfRow(r), truth.eastOfCol(c))) truth.at(c, r) = static_cast<float>(kRockHeightM);
  horizonFrom(truth, sc.camera.c, sc.horizon, false);
  sc.cone = imageCone(sc.camera);
  sc.kr.elevation = truth;
  sc.kr.sigma = truth;
  std::fill(sc.kr.sigma.values.begin(), sc.kr.sigma.values.end(), 0.02f);
  sc.measured.assign(truth.values.size(), 0);
  sc.seen.assign(truth.values.size(), 0);
  for (int r = 0; r < truth.rows; ++r) {
    for (int c = 0; c < truth.cols; ++c) {
      const std::size_t i = static_cast<std::size_t>(r) * truth.cols + c;
      const double n = truth.northOfRow(r), e = truth.eastOfCol(c);
      sc.seen[i] = truth.values[i] + 1e-3 >= sc.horizon[i] && imageSees(sc.camera, sc.cone, Vec3(n, e, -truth.values[i]));
      sc.measured[i] = sc.seen[i] && (r + c) % 3 != 0;
      // Behind the rock: the grazing line of sight over its far top edge.
      if (!sc.seen[i] && sc.horizon[i] > truth.values[i] && n > 4.0) sc.kr.elevation.values[i] = sc.horizon[i];
    }
  }
  return sc;
}

}  // namespace

TEST_GROUP(DemSeen){};

TEST(DemSeen, ShadowBehindARockEmptiedSeenGapsKept) {
  RockScene sc = rockScene();
  const DemGrid& truth = sc.truth;
  const CameraModel& camera = sc.camera;
  const ImageCone& cone = sc.cone;
  const std::vector<float>& horizon = sc.horizon;
  KrigingResult& kr = sc.kr;
  const std::vector<uint8_t>&measured = sc.measured, &seen = sc.seen;
  const DemSeen classes = classifyDemCells(kr, measured, {camera});
  long long shadow = 0, shadow_emptied = 0, gaps = 0, gaps_kept = 0, outside = 0, outside_emptied = 0;
  for (int r = 0; r < truth.rows; ++r) {
    for (int c = 0; c < truth.cols; ++c) {
      const std::size_t i = static_cast<std::size_t>(r) * truth.cols + c;
      const bool empty = kr.elevation.values[i] == kr.elevation.nodata;
      CHECK_EQUAL(empty, classes.classes[i] == kCellUnseen);
      if (measured[i]) CHECK_EQUAL(kCellMeasured, classes.classes[i]);
      const double n = truth.northOfRow(r), e = truth.eastOfCol(c);
      if (!seen[i] && horizon[i] > truth.values[i] + 1e-3 && n > 4.4) {
        ++shadow;
        shadow_emptied += empty;
      } else if (seen[i] && !measured[i]) {
        ++gaps;
        gaps_kept += classes.classes[i] == kCellInterpolated;
      } else if (!imageSees(camera, cone, Vec3(n, e, 0.0))) {
        ++outside;
        outside_emptied += empty;
      }
    }
  }
  std::printf("\n  shadow %lld cells, %.1f %% emptied; seen gaps %lld, %.1f %% kept; outside the image %lld, %.1f %% "
              "emptied\n", shadow, 100.0 * shadow_emptied / std::max(1LL, shadow), gaps,
              100.0 * gaps_kept / std::max(1LL, gaps), outside, 100.0 * outside_emptied / std::max(1LL, outside));
  CHECK(shadow > 200);
  CHECK(shadow_emptied >= 0.9 * shadow);
  CHECK(gaps_kept >= 0.98 * gaps);
  CHECK(outside > 1000);
  CHECK_EQUAL(outside, outside_emptied);
}

// Points behind the rock's near face: shadow cells holding points on the lines of sight through the face
// (a match's range error carries it along its ray beyond the surface the pixel images). The camera shows the
// face at their pixels, nearer by more than the points' sigma allows: unseen, and the seen cells measured.
TEST(DemSeen, PointsBehindARockFaceUnseen) {
  RockScene sc = rockScene();
  const DemGrid& truth = sc.truth;
  const double face_up = 0.35, face_north = 4.0;
  long long planted = 0;
  for (int r = 0; r < truth.rows; ++r) {
    for (int c = 0; c < truth.cols; ++c) {
      const std::size_t i = static_cast<std::size_t>(r) * truth.cols + c;
      const double n = truth.northOfRow(r), e = truth.eastOfCol(c);
      if (sc.seen[i] || n < 4.6 || n > 5.2 || std::fabs(e) > 0.2 * n / face_north) continue;
      // The line of sight from the eye through the face at face_up, at this cell.
      const double up = kEyeUpM - (kEyeUpM - face_up) * std::hypot(n, e) / std::hypot(face_north, e * face_north / n);
      if (up <= truth.values[i] + 0.01 || up >= sc.horizon[i]) continue;
      sc.kr.elevation.values[i] = static_cast<float>(up);
      sc.measured[i] = 1;
      ++planted;
    }
  }
  const DemSeen classes = classifyDemCells(sc.kr, sc.measured, {sc.camera});
  long long planted_unseen = 0, seen_measured = 0, seen_kept = 0;
  for (std::size_t i = 0; i < truth.values.size(); ++i) {
    if (sc.measured[i] && !sc.seen[i]) planted_unseen += classes.classes[i] == kCellUnseen;
    if (sc.measured[i] && sc.seen[i]) {
      ++seen_measured;
      seen_kept += classes.classes[i] == kCellMeasured;
    }
  }
  std::printf("\n  points behind the face: %lld cells, %lld unseen (%lld hidden); seen measured %lld, %lld kept\n",
              planted, planted_unseen, classes.hidden, seen_measured, seen_kept);
  CHECK(planted > 50);
  // Those whose pixel and its vertical neighbours all show the face (the rest lie by the face's top edge,
  // or at a column the decimated cells leave without a face: no evidence, kept).
  CHECK(planted_unseen >= planted / 3);
  CHECK_EQUAL(seen_measured, seen_kept);
}
