#include <cmath>
#include <cstdio>
#include <random>

#include "firmware_core/camera/CahvInternal.hpp"
#include "tests/firmware_core/camera/TestModels.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

TEST_GROUP(CahvInternal){};

// Models built from stated hs, vs, hc, vc, H' and V' (modelFromSpec: random pointing, focal lengths
// 300-3000 px, principal points anywhere in or near the image, non-orthogonal H and V, 16 seeds): the
// decomposition gives them back, and hs H' + hc A rebuilds H.
TEST(CahvInternal, RecoversTheParametersTheModelWasBuiltFrom) {
  double worst_px = 0.0, worst_unit = 0.0;
  for (uint32_t seed = 1; seed <= 16; ++seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> f(300.0, 3000.0), df(-5.0, 5.0), centre(-200.0, 1200.0),
        angle(-3.0, 3.0), shear(-0.01, 0.01);
    test::ModelSpec spec{};
    spec.vs = f(rng);
    spec.hs = spec.vs + df(rng);
    spec.hc = centre(rng);
    spec.vc = centre(rng);
    spec.shear_rad = shear(rng);
    spec.omega = angle(rng);
    spec.phi = 0.5 * angle(rng);
    spec.kappa = angle(rng);
    spec.o_tilt_rad = 0.0;
    spec.r = Vec3::Zero();
    spec.width = 1024;
    spec.height = 1024;
    const CameraModel m = test::modelFromSpec(spec, Vec3(1.0, -2.0, -1.5));
    // The unit vectors modelFromSpec used (M = [H'; -V'; -A] before the shear of H').
    const Mat3 rot = rotationFromOpk(spec.omega, spec.phi, spec.kappa);
    const Vec3 v_prime = -rot.row(1).transpose();
    const Vec3 h_prime =
        std::cos(spec.shear_rad) * rot.row(0).transpose() + std::sin(spec.shear_rad) * v_prime;
    const CahvInternal in = cahvInternal(m);
    const double px[4] = {in.hs_px - spec.hs, in.vs_px - spec.vs, in.hc_px - spec.hc, in.vc_px - spec.vc};
    for (double d : px) worst_px = std::fmax(worst_px, std::fabs(d));
    worst_unit = std::fmax(worst_unit, (in.h_prime - h_prime).norm());
    worst_unit = std::fmax(worst_unit, (in.v_prime - v_prime).norm());
    CHECK((in.hs_px * in.h_prime + in.hc_px * m.a - m.h).norm() < 1e-9);
    CHECK((in.vs_px * in.v_prime + in.vc_px * m.a - m.v).norm() < 1e-9);
    DOUBLES_EQUAL(0.0, in.h_prime.dot(m.a), 1e-12);
    DOUBLES_EQUAL(0.0, in.v_prime.dot(m.a), 1e-12);
  }
  std::printf("\ncahv internal: worst hs/vs/hc/vc error %.2e px, worst H'/V' error %.2e\n", worst_px,
              worst_unit);
  CHECK(worst_px < 1e-9);
  CHECK(worst_unit < 1e-12);
}
