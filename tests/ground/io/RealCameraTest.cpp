// The camera code on the real models of ../shared/data: conversion agreement (<= 0.05 px RMS), the
// conversion oracle, the Spirit stereo baseline, M2020 scaling. Skips when the data is absent.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "firmware_core/camera/CameraConversion.hpp"
#include "ground/io/CameraFile.hpp"
#include "ground/io/ImageFile.hpp"
#include "platform/heap/HeapCounter.hpp"
#include "tests/firmware_core/camera/ConversionCheck.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

std::string data(const std::string& rel) {
  return test::sharedDataDir() + "/" + rel;
}

const char* const kOpportunity[] = {"mer-opportunity-navcam-sol4087/1N491020376ILFCNY9P0706L0M1.IMG",
                                    "mer-opportunity-navcam-sol4087/1N491020519ILFCNY9P0706L0M1.IMG"};
const char* const kSpiritLeft =
    "mer-spirit-navcam-sol767-labels/2N194463440EFFAPA0P0685L0M1_label_excerpt.lbl";
const char* const kSpiritRight =
    "mer-spirit-navcam-sol767-labels/2N194463440EFFAPA0P0685R0M1_label_excerpt.lbl";
const char* const kM2020 =
    "m2020-navcam-cahvore/NLF_0670_0726421423_362ECM_N0320604NCAM08111_01_095J01-metadata.json";
const char* const kM2020Png =
    "m2020-navcam-cahvore/NLF_0670_0726421423_362ECM_N0320604NCAM08111_01_095J01.png";
const char* const kOracle = "cahvor-conversion-oracle/example_vectors.txt";

bool haveAll() {
  return test::requireSharedData("mer-opportunity-navcam-sol4087") &&
         test::requireSharedData("mer-spirit-navcam-sol767-labels") &&
         test::requireSharedData("m2020-navcam-cahvore") &&
         test::requireSharedData("cahvor-conversion-oracle");
}

struct Named {
  std::string name;
  CameraModel model;
};

std::vector<Named> realModels() {
  std::vector<Named> out;
  for (const char* f : kOpportunity) out.push_back({f, io::readCameraModelFile(data(f))});
  // The Spirit excerpts carry no IMAGE object; the frames are 1024 x 1024 (PROVENANCE.txt).
  out.push_back({kSpiritLeft, io::readCameraModelFile(data(kSpiritLeft), 1024, 1024)});
  out.push_back({kSpiritRight, io::readCameraModelFile(data(kSpiritRight), 1024, 1024)});
  out.push_back({kM2020, io::readCameraModelFile(data(kM2020))});
  // The oracle's image is 506 rows x 762 columns.
  out.push_back({kOracle, io::readCameraModelFile(data(kOracle), 762, 506)});
  return out;
}

}  // namespace

TEST_GROUP(RealCameras){};

// Converted-model projection agrees with the direct CAHVOR/CAHVORE projection to <= 0.05 px RMS
// and <= 0.25 px max over a 32 x 32 grid at ranges 2-50 m.
TEST(RealCameras, ConversionAgreesWithTheDirectProjection) {
  if (!haveAll()) return;
  std::printf("\n%-90s %9s %9s | %9s %9s | %9s %9s\n", "model", "fit rms", "fit max", "2-50m rms", "max",
              "back rms", "back max");
  for (const Named& n : realModels()) {
    PhotogrammetricCamera cam;
    ConversionResidual res, back_res;
    CHECK(cahvorToPhotogrammetric(n.model, cam, res) == Status::kOk);
    const test::Agreement g = test::agreementOverImage(n.model, cam);
    CameraModel back;
    CHECK(photogrammetricToCahvor(cam, back, back_res) == Status::kOk);
    const test::Agreement round = test::agreementBetweenModels(n.model, back);
    std::printf("%-90s %9.4f %9.4f | %9.4f %9.4f | %9.4f %9.4f\n", n.name.c_str(), res.rms_px, res.max_px,
                g.rms_px, g.max_px, round.rms_px, round.max_px);
    CHECK_EQUAL(32 * 32 * 5, g.points);
    CHECK(g.rms_px <= 0.05);
    CHECK(g.max_px <= 0.25);
    // Round trip CAHVOR -> photogrammetric -> CAHVOR within 0.05 px (the CAHVOR models; the CAHVORE one
    // comes back as a CAHVOR and is reported only).
    if (n.model.type == CameraType::kCahvor) CHECK(round.max_px <= 0.05);
  }
}

TEST(RealCameras, BackProjectionThenProjectionReturnsThePixel) {
  if (!haveAll()) return;
  for (const Named& n : realModels()) {
    double max_px = 0.0;
    for (int j = 0; j < 32; ++j) {
      for (int i = 0; i < 32; ++i) {
        const Vec2 pixel(-0.5 + n.model.width * (i + 0.5) / 32.0, -0.5 + n.model.height * (j + 0.5) / 32.0);
        Vec3 origin, dir;
        CHECK(unproject(n.model, pixel, origin, dir) == Status::kOk);
        Vec2 back;
        CHECK(project(n.model, origin + 3.0 * dir, back) == Status::kOk);
        max_px = std::fmax(max_px, (back - pixel).norm());
      }
    }
    CHECK(max_px < 1e-6);
  }
}

// The oracle (bvnayak/CAHVOR_camera_model, Di & Li 2004): f, x0, y0 in mm with pixel 0.01838 mm, x0 =
// (hc - cols/2) * pixel, y0 = -(vc - rows/2) * pixel, angles in degrees. Its own forward and reverse
// examples disagree by 0.006 mm in f and 0.008 deg in kappa; it takes f = hs while we take f = vs
// (|hs - vs| = 0.61 px = 0.011 mm here). Tolerances: f 0.02 mm, x0/y0 0.002 mm, angles 0.02 deg.
// Analytic d(pixel)/d(point) of CAHVOR/CAHVORE against central differences, 1e-6 relative.
TEST(RealCameras, ProjectionJacobiansMatchCentralDifferences) {
  if (!haveAll()) return;
  for (const Named& n : realModels()) {
    for (double fx : {0.05, 0.5, 0.95}) {
      for (double fy : {0.05, 0.5, 0.95}) {
        Vec3 origin, dir;
        CHECK(unproject(n.model, Vec2(fx * n.model.width, fy * n.model.height), origin, dir) == Status::kOk);
        const Vec3 point = origin + 6.0 * dir;
        Vec2 px;
        Mat2x3 jac;
        CHECK(project(n.model, point, px, &jac) == Status::kOk);
        for (int k = 0; k < 3; ++k) {
          Vec3 d = Vec3::Zero();
          d(k) = 1e-5;
          Vec2 a, b;
          CHECK(project(n.model, point + d, a) == Status::kOk);
          CHECK(project(n.model, point - d, b) == Status::kOk);
          const Vec2 numeric = (a - b) / 2e-5;
          for (int r = 0; r < 2; ++r) {
            const double scale = std::fmax(1.0, std::fabs(jac(r, k)));
            CHECK(std::fabs(numeric(r) - jac(r, k)) / scale < 1e-6);
          }
        }
      }
    }
  }
}

TEST(RealCameras, ReproducesTheConversionOracle) {
  if (!haveAll()) return;
  const CameraModel m = io::readCameraModelFile(data(kOracle), 762, 506);
  PhotogrammetricCamera cam;
  ConversionResidual res;
  CHECK(cahvorToPhotogrammetric(m, cam, res) == Status::kOk);
  constexpr double kPixelMm = 0.01838;
  constexpr double kDeg = 180.0 / M_PI;
  const double f_mm = cam.io.f_px * kPixelMm;
  const double x0_mm = (cam.io.x0_px - 762 / 2.0) * kPixelMm;
  const double y0_mm = -(cam.io.y0_px - 506 / 2.0) * kPixelMm;
  std::printf(
      "\noracle: f %.5f mm (29.47677), x0 %.5f mm (-0.09574), y0 %.5f mm (-0.11072), omega %.4f (-72.2992) "
      "phi %.4f (44.2841) kappa %.4f (166.5246) deg\n",
      f_mm, x0_mm, y0_mm, cam.eo.omega_rad * kDeg, cam.eo.phi_rad * kDeg, cam.eo.kappa_rad * kDeg);
  DOUBLES_EQUAL(29.476767942900004, f_mm, 0.02);
  DOUBLES_EQUAL(-0.09574393805999998, x0_mm, 0.002);
  DOUBLES_EQUAL(-0.1107169477400001, y0_mm, 0.002);
  DOUBLES_EQUAL(-72.29916094406916, cam.eo.omega_rad * kDeg, 0.02);
  DOUBLES_EQUAL(44.28412812851018, cam.eo.phi_rad * kDeg, 0.02);
  DOUBLES_EQUAL(166.5245817162046, cam.eo.kappa_rad * kDeg, 0.02);
  CHECK((cam.eo.centre_m - Vec3(3.451904, 3.258335, 1.254338)).norm() < 1e-12);
  // hs, as the oracle lists it (1603.741455), from our h_scale: hs = f * h_scale / cos(shear).
  const double hs = cam.io.f_px * std::hypot(cam.h_scale, cam.h_shear);
  DOUBLES_EQUAL(1603.741455, hs, 0.01);
}

TEST(RealCameras, SpiritStereoBaselineIs0p2003m) {
  if (!haveAll()) return;
  const CameraModel l = io::readCameraModelFile(data(kSpiritLeft), 1024, 1024);
  const CameraModel r = io::readCameraModelFile(data(kSpiritRight), 1024, 1024);
  const double base_m = (r.c - l.c).norm();
  std::printf("\nSpirit |C_R - C_L| = %.6f m\n", base_m);
  DOUBLES_EQUAL(0.2003, base_m, 0.0001);  // 0.2003 is quoted to 4 digits, C to 6
  // Both look the same way within a few degrees (a stereo rig).
  CHECK(l.a.dot(r.a) > std::cos(5.0 * M_PI / 180.0));
}

TEST(RealCameras, M2020ModelIsScaledToTheBrowseImage) {
  if (!haveAll()) return;
  const io::CameraFile f = io::readCameraFile(data(kM2020));
  CHECK(f.format == io::CameraFileFormat::kM2020Json);
  CHECK(f.file_model.type == CameraType::kCahvore);
  CHECK(f.file_model.cahvore_kind == CahvoreKind::kFisheye);
  DOUBLES_EQUAL(0.0, f.file_model.linearity, 0.0);
  DOUBLES_EQUAL(4.0, f.scale, 0.0);
  // The browse PNG is the delivered image: its size is the model's.
  const cv::Mat png = io::loadImage8(data(kM2020Png));
  CHECK_EQUAL(png.cols, f.model.width);
  CHECK_EQUAL(png.rows, f.model.height);
  // The principal point of the scaled model lies near the image centre (within 2 %).
  const double hc = f.model.a.dot(f.model.h), vc = f.model.a.dot(f.model.v);
  std::printf("\nM2020: scale %.0f, hc %.2f vc %.2f px for a %d x %d image\n", f.scale, hc, vc, f.model.width,
              f.model.height);
  CHECK(std::fabs(hc - 0.5 * png.cols) < 0.02 * png.cols);
  CHECK(std::fabs(vc - 0.5 * png.rows) < 0.02 * png.rows);
  // A point projects to the scaled pixel of its detector pixel: detector = offset + scale * pixel.
  const Vec3 point = f.model.c + 10.0 * f.model.a + Vec3(0.7, -1.1, 0.4);
  Vec2 detector, pixel;
  CHECK(project(f.file_model, point, detector) == Status::kOk);
  CHECK(project(f.model, point, pixel) == Status::kOk);
  CHECK((detector - (f.offset_px + f.scale * pixel)).norm() < 1e-9);
}

// The NLF browse PNG beside its JSON is the delivered image, and the model is read as 1/4 of the detector;
// the same real model, rescaled by the test into the pixels of a subframe at scale 2 from detector column
// 2545 (as the raw-image service delivers the NRF frame), is read as given.
TEST(RealCameras, M2020FramesOfTheRealModel) {
  if (!haveAll()) return;
  const io::CameraFile f = io::readCameraFile(data(kM2020));
  STRCMP_EQUAL("1/4 of the detector from (1, 1)", f.frame.c_str());
  CHECK(f.size_from_file);
  CHECK(f.warnings.empty());  // the PNG is 1288 x 968, as "dimension" says
  STRCMP_EQUAL(data(kM2020Png).c_str(), io::imageBeside(data(kM2020)).c_str());

  const std::string dir = test::scratchDir("real_m2020_frames");
  const int w = 1288, h = 968;
  const Vec2 offset(2544.0 + 0.5, 0.5);  // subframe origin (2545, 1), 1-based; scale 2
  const CameraModel sub = io::rescaledModel(f.file_model, 2.0, offset, w, h);
  std::ifstream in(data(kM2020));
  std::stringstream text;
  text << in.rdbuf();
  nlohmann::json j = nlohmann::json::parse(text.str());
  char list[640];
  auto t = [](const Vec3& v) {
    char b[96];
    std::snprintf(b, sizeof b, "(%.17g,%.17g,%.17g)", v.x(), v.y(), v.z());
    return std::string(b);
  };
  std::snprintf(list, sizeof list, "%s;%s;%s;%s;%s;%s;%s;2;0.0", t(sub.c).c_str(), t(sub.a).c_str(),
                t(sub.h).c_str(), t(sub.v).c_str(), t(sub.o).c_str(), t(sub.r).c_str(), t(sub.e).c_str());
  j["camera_model_component_list"] = list;
  j["scale_factor"] = 2;
  j["subframe_rect"] = nlohmann::json::array({2545.0, 1.0, 2576.0, 1936.0});
  const std::string path = dir + "/NRF-like-metadata.json";
  std::ofstream(path) << j.dump(2);
  const io::CameraFile g = io::readCameraFile(path);
  const double hc = g.model.a.dot(g.model.h), vc = g.model.a.dot(g.model.v);
  std::printf("\nNRF-like subframe of the real model: %s, principal point (%.2f, %.2f) in %d x %d\n",
              g.frame.c_str(), hc, vc, w, h);
  STRCMP_EQUAL("as given", g.frame.c_str());
  CHECK(hc < 0.05 * w);  // near the left edge: the subframe starts just left of the optical axis
  const Vec3 point = f.model.c + 10.0 * f.model.a + Vec3(0.7, -1.1, 0.4);
  Vec2 detector, pixel;
  CHECK(project(f.file_model, point, detector) == Status::kOk);
  CHECK(project(g.model, point, pixel) == Status::kOk);
  CHECK((detector - (offset + 2.0 * pixel)).norm() < 1e-6);
}

TEST(RealCameras, ConversionMakesNoHeapAllocations) {
  if (!haveAll()) return;
  const CameraModel m = io::readCameraModelFile(data(kM2020));
  PhotogrammetricCamera cam;
  ConversionResidual res;
  HeapAllocationScope scope;
  CHECK(cahvorToPhotogrammetric(m, cam, res) == Status::kOk);
  Vec2 px;
  Mat2x3 jac;
  CHECK(project(m, m.c + 5.0 * m.a, px, &jac) == Status::kOk);
  CHECK_EQUAL(0u, scope.allocations());
}
