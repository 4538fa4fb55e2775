// Our CAHVOR/CAHVORE projection against libmrcal's (an independent implementation: mrcal_project with
// LENSMODEL_CAHVOR / LENSMODEL_CAHVORE) on every real camera model of ../shared/data, each read through our
// own readers (the Mars 2020 raw-image record as served and flattened, PDS3 and VICAR labels, the JPL text
// form), so the readers are checked too. Skips when the data is absent.
//
// For each model, pixels on a grid spanning the whole image (edges and corners included) are back-projected
// through our model and the points at several ranges along the rays are projected by both. The conversion to
// mrcal is mrcal's own (mrcal/cahvor.py, _construct_model): fx = Hs, fy = Vs, cx = Hc, cy = Vc; the camera
// frame has the axes Hp = (H - Hc A) / Hs, A x Hp and A, the origin C; the distortion axis O in that frame
// gives alpha = atan2(o_x, o_z), beta = asin(o_y); then R0 R1 R2 (and E0 E1 E2, with the CAHVORE linearity
// as the lens model's configuration). Two exact changes: cahvor.py makes A a unit vector but keeps H and V,
// which changes the model by |A| (labels give A to ~6 digits: ~0.02 px at a tile's corner); here H and V
// are divided by |A| too, the same camera. And mrcal has no skew: it takes A x Hp for Vp where a model's
// Vp = (V - Vc A) / Vs need not be orthogonal to Hp. The skew acts after the distortion (which works on the
// 3-D ray), so it is an exact affine map of mrcal's pixel; it is applied to mrcal's output, and its size is
// printed per model.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

extern "C" {
#include <mrcal/mrcal.h>
}

#include "ground/io/CameraFile.hpp"
#include "ground/io/GdalLabel.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

constexpr int kGrid = 33;                                    // grid nodes per image side
constexpr double kRangesM[] = {0.5, 1.0, 3.0, 10.0, 100.0};  // along each back-projected ray
constexpr double kMaxDisagreementPx = 0.01;

struct Named {
  std::string name;
  CameraModel model;
};

std::string data(const std::string& rel) {
  return test::sharedDataDir() + "/" + rel;
}

// Every real model, each through the reader its file is meant for.
std::vector<Named> realModels() {
  std::vector<Named> out;
  const std::string pairs = data("m2020-navcam-stereo-pairs");
  std::vector<std::string> records;
  for (const auto& e : std::filesystem::directory_iterator(pairs)) {
    if (e.path().extension() == ".json") records.push_back(e.path().string());
  }
  std::sort(records.begin(), records.end());
  for (const std::string& r : records) {
    const io::CameraFile f = io::readCameraFile(r);  // the raw-image record as served
    CHECK(f.format == io::CameraFileFormat::kM2020Json);
    // The records state type 2 (fisheye, linearity 0).
    CHECK(f.model.type == CameraType::kCahvore && f.model.cahvore_kind == CahvoreKind::kFisheye);
    out.push_back({std::filesystem::path(r).filename().string(), f.model});
  }
  const std::string flat =
      "m2020-navcam-cahvore/NLF_0670_0726421423_362ECM_N0320604NCAM08111_01_095J01-metadata.json";
  out.push_back({flat, io::readCameraModelFile(data(flat))});  // flattened, scaled to the browse image
  for (const char* f : {"mer-opportunity-navcam-sol4087/1N491020376ILFCNY9P0706L0M1.IMG",
                        "mer-opportunity-navcam-sol4087/1N491020519ILFCNY9P0706L0M1.IMG"}) {
    const io::CameraFile pds3 = io::readCameraFile(data(f));
    CHECK(pds3.format == io::CameraFileFormat::kPds3);
    out.push_back({std::string(f) + " (PDS3)", pds3.model});
    out.push_back({std::string(f) + " (VICAR)", io::readVicarCamera(data(f)).model});
  }
  // The Spirit excerpts carry no IMAGE object: 1024 x 1024 frames (their PROVENANCE.txt).
  for (const char* f : {"mer-spirit-navcam-sol767-labels/2N194463440EFFAPA0P0685L0M1_label_excerpt.lbl",
                        "mer-spirit-navcam-sol767-labels/2N194463440EFFAPA0P0685R0M1_label_excerpt.lbl"}) {
    out.push_back({f, io::readCameraModelFile(data(f), 1024, 1024)});
  }
  // The oracle's image is 762 x 506 (its PROVENANCE.txt).
  const char* oracle = "cahvor-conversion-oracle/example_vectors.txt";
  out.push_back({oracle, io::readCameraModelFile(data(oracle), 762, 506)});
  return out;
}

// A model in mrcal's terms (mrcal/cahvor.py) plus the skew that mrcal drops.
struct MrcalCamera {
  mrcal_lensmodel_t lens{};
  std::vector<double> intrinsics;
  Mat3 cam_from_ref = Mat3::Identity();  // rows Hp, A x Hp, A
  Vec3 c = Vec3::Zero();
  double skew_a = 1.0, skew_b = 0.0;  // Vp = skew_a (A x Hp) + skew_b Hp
};

MrcalCamera toMrcal(const CameraModel& model) {
  MrcalCamera out;
  const double a_norm = model.a.norm();
  CameraModel m = model;
  m.a /= a_norm;
  m.h /= a_norm;
  m.v /= a_norm;
  const double hc = m.h.dot(m.a), vc = m.v.dot(m.a);
  const Vec3 hs_hp = m.h - hc * m.a, vs_vp = m.v - vc * m.a;
  const double hs = hs_hp.norm(), vs = vs_vp.norm();
  const Vec3 hp = hs_hp / hs, vp = vs_vp / vs;
  const Vec3 vp_orth = m.a.cross(hp);
  out.cam_from_ref.row(0) = hp.transpose();
  out.cam_from_ref.row(1) = vp_orth.transpose();
  out.cam_from_ref.row(2) = m.a.transpose();
  out.c = m.c;
  out.skew_a = vp.dot(vp_orth);
  out.skew_b = vp.dot(hp);
  const Vec3 o = out.cam_from_ref * m.o;
  const double alpha = std::atan2(o.x(), o.z()), beta = std::asin(o.y());
  out.intrinsics = {hs, vs, hc, vc, alpha, beta, m.r.x(), m.r.y(), m.r.z()};
  if (m.type == CameraType::kCahvore) {
    out.lens.type = MRCAL_LENSMODEL_CAHVORE;
    out.lens.LENSMODEL_CAHVORE__config.linearity = cahvoreLinearity(m);
    out.intrinsics.insert(out.intrinsics.end(), {m.e.x(), m.e.y(), m.e.z()});
  } else {
    out.lens.type = MRCAL_LENSMODEL_CAHVOR;
  }
  return out;
}

struct Agreement {
  double max_px = 0.0;
  double skew_px = 0.0;  // the largest correction of mrcal's pixel for the model's skew
  int points = 0;
  Vec2 worst_px = Vec2::Zero();  // where the largest disagreement is: pixel and range
  double worst_range_m = 0.0;
};

Agreement compare(const CameraModel& model) {
  const MrcalCamera cam = toMrcal(model);
  Agreement out;
  for (int j = 0; j < kGrid; ++j) {
    for (int i = 0; i < kGrid; ++i) {
      const Vec2 pixel((model.width - 1.0) * i / (kGrid - 1), (model.height - 1.0) * j / (kGrid - 1));
      Vec3 origin, dir;
      CHECK(unproject(model, pixel, origin, dir) == Status::kOk);
      for (double range_m : kRangesM) {
        const Vec3 point = origin + range_m * dir;
        Vec2 ours;
        CHECK(project(model, point, ours) == Status::kOk);
        const Vec3 p = cam.cam_from_ref * (point - cam.c);
        mrcal_point3_t pm;
        pm.x = p.x();
        pm.y = p.y();
        pm.z = p.z();
        mrcal_point2_t q;
        CHECK(mrcal_project(&q, nullptr, nullptr, &pm, 1, &cam.lens, cam.intrinsics.data()));
        const double hs = cam.intrinsics[0], vs = cam.intrinsics[1];
        const double hc = cam.intrinsics[2], vc = cam.intrinsics[3];
        const double y = cam.skew_a * (q.y - vc) + cam.skew_b * vs / hs * (q.x - hc) + vc;
        out.skew_px = std::fmax(out.skew_px, std::fabs(y - q.y));
        const double d = (Vec2(q.x, y) - ours).norm();
        if (d > out.max_px) {
          out.max_px = d;
          out.worst_px = pixel;
          out.worst_range_m = range_m;
        }
        ++out.points;
      }
    }
  }
  return out;
}

bool haveAll() {
  bool ok = true;
  for (const char* f : {"m2020-navcam-stereo-pairs", "m2020-navcam-cahvore", "mer-opportunity-navcam-sol4087",
                        "mer-spirit-navcam-sol767-labels", "cahvor-conversion-oracle"}) {
    ok = test::requireSharedData(f) && ok;
  }
  return ok;
}

}  // namespace

TEST_GROUP(MrcalProjection){};

TEST(MrcalProjection, EveryRealModelAgreesWithMrcalOverTheImage) {
  if (!haveAll()) return;
  const std::vector<Named> models = realModels();
  CHECK_EQUAL(10 + 1 + 4 + 2 + 1, static_cast<int>(models.size()));
  std::printf("\n%-80s %-8s %5s %10s %10s  %s\n", "model", "type", "L", "max px", "skew px",
              "largest at (pixel, range)");
  std::vector<Agreement> all;
  for (const Named& n : models) {
    CHECK(n.model.width > 0 && n.model.height > 0);
    const Agreement g = compare(n.model);
    const bool e = n.model.type == CameraType::kCahvore;
    std::printf("%-80s %-8s %5.2f %10.3e %10.3e  (%.1f, %.1f) %.1f m\n", n.name.c_str(),
                e ? "CAHVORE" : "CAHVOR", e ? cahvoreLinearity(n.model) : 1.0, g.max_px, g.skew_px,
                g.worst_px.x(), g.worst_px.y(), g.worst_range_m);
    all.push_back(g);
  }
  for (const Agreement& g : all) {
    CHECK_EQUAL(kGrid * kGrid * static_cast<int>(std::size(kRangesM)), g.points);
    CHECK(g.max_px <= kMaxDisagreementPx);
  }
}
