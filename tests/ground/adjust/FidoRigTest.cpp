// The FIDO-style constraints end to end: areomap-sim --preset fido (navcam cameras on a mast head whose tilt
// axis is 10 cm ahead of the pan axis, so no fixed offset from one gimbal point fits every tilt and
// panorama.json gives the stereo base only), then areomap-adjust with true tie points, over several seeds,
// against the truth: with --fido --no-gimbal (a virtual spin centre per tier, camera-to-centre and
// left-right distances) the adjustment recovers the EO as precisely as its own covariance says; with the
// paper's Eq. 3 fitted to the a-priori models (the default) the model is wrong, the tool says so, and the
// residuals show it.
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

namespace {

nlohmann::json readJson(const std::string& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

// The RMS over eo.csv's images of f (|sigma_rot| + |sigma_C| / 5 m): the EO error in pixels that the
// adjustment's covariance predicts, in the report's own measure (truth.eo_px: f (angle + |dC| / 5 m)).
double predictedEoPx(const std::string& eo_csv, double f_px) {
  double sum = 0.0;
  int n = 0;
  for (const std::array<double, 6>& s : areomap::test::readEoSigmas(eo_csv)) {
    const double centre = std::sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]);
    const double rotation = std::sqrt(s[3] * s[3] + s[4] * s[4] + s[5] * s[5]);
    const double px = f_px * (rotation + centre / 5.0);
    sum += px * px;
    ++n;
  }
  return n > 0 ? std::sqrt(sum / n) : 0.0;
}

bool warns(const nlohmann::json& report, const std::string& text) {
  for (const auto& w : report["warnings"]) {
    if (w.get<std::string>().find(text) != std::string::npos) return true;
  }
  return false;
}

}  // namespace

TEST_GROUP(FidoRig){};

TEST(FidoRig, SpinCentreConstraintsRecoverTheEoOfAMastWithAnOffsetTiltAxis) {
  const double f_px = 511.5 / std::tan(22.5 * M_PI / 180.0);  // the preset's 1024 px over 45 degrees
  for (const int seed : {1, 2, 3}) {
    const std::string data = areomap::test::scratchDir("fido-rig-" + std::to_string(seed));
    CHECK_EQUAL(0, areomap::test::runTool("areomap-sim", "--preset fido --no-images --threads 1 --seed " +
                                                             std::to_string(seed) + " --out " + data));
    const nlohmann::json pano = readJson(data + "/panorama.json");
    CHECK(!pano["rig"].contains("gimbal_m") && pano["rig"].contains("base_m"));

    const std::string fido = areomap::test::scratchDir("fido-rig-fido-" + std::to_string(seed));
    const std::string gimbal = areomap::test::scratchDir("fido-rig-gimbal-" + std::to_string(seed));
    const std::string common = " --truth-ties --noise-px 0.3 --seed " + std::to_string(seed);
    CHECK_EQUAL(0, areomap::test::runTool("areomap-adjust",
                                          data + " --out " + fido + common + " --fido --no-gimbal"));
    CHECK_EQUAL(0, areomap::test::runTool("areomap-adjust", data + " --out " + gimbal + common));
    const nlohmann::json rf = readJson(fido + "/report.json");
    const nlohmann::json rg = readJson(gimbal + "/report.json");
    const double before = rf["truth"]["eo_px_before"];
    const double eo_fido = rf["truth"]["eo_px"], eo_gimbal = rg["truth"]["eo_px"];
    const double sigma0_fido = rf["sigma0"], sigma0_gimbal = rg["sigma0"];
    const double predicted = predictedEoPx(fido + "/eo.csv", f_px);
    const double ground_fido = rf["truth"]["ground_m"], ground_gimbal = rg["truth"]["ground_m"];
    std::printf(
        "\n  seed %d: EO vs truth %.2f px a priori; --fido --no-gimbal %.3f px (its covariance: %.3f px), "
        "sigma0 %.3f, ground %.4f m; Eq. 3 fitted %.3f px, sigma0 %.3f, ground %.4f m\n",
        seed, before, eo_fido, predicted, sigma0_fido, ground_fido, eo_gimbal, sigma0_gimbal, ground_gimbal);
    // The observations carry 0.3 px noise and sigma 0.3 px: a right model leaves sigma0 near 1.
    CHECK(sigma0_fido > 0.8 && sigma0_fido < 1.25);
    // The a-priori pointing (3-15 px) is recovered to a tenth or better, and no worse than the covariance
    // predicts: the FIDO model leaves no error of its own. (The prediction is above the aligned error: it
    // holds the weakly fixed common tilt that the truth comparison removes.)
    CHECK(eo_fido < 0.1 * before);
    CHECK(eo_fido < predicted);
    // Eq. 3 held on this mast is the wrong model: the tool says so, and the residuals show it.
    CHECK(warns(rg, "does not turn the cameras about one point"));
    CHECK(!warns(rf, "does not turn the cameras about one point"));
    CHECK(sigma0_gimbal > 2.0);
    CHECK(eo_gimbal > 5.0 * eo_fido);
    CHECK(ground_fido < ground_gimbal);
  }
}
