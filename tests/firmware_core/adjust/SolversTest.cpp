// The fast adjuster's solvers one by one, each against an independent computation: the steps of the block
// Cholesky and of PCG against a dense solve of the whole damped normal system (cameras and points, built
// here from the observation and constraint rows), the matrix-free reduced product against the dense Schur
// complement, Anderson acceleration against the fixed point of a linear map, the image index against a scan
// of the observations, and the rig constraints (Eq. 3, Eq. 4) against the synthetic rig's truth. Networks
// from the test generator: one- and two-tier rings, with and without a single image, three seeds.
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include <Eigen/Dense>

#include "firmware_core/adjust/AdjustWorkspace.hpp"
#include "firmware_core/adjust/Alternation.hpp"
#include "firmware_core/adjust/BlockCholesky.hpp"
#include "firmware_core/adjust/Constraints.hpp"
#include "firmware_core/adjust/Network.hpp"
#include "firmware_core/adjust/PcgSolver.hpp"
#include "firmware_core/adjust/ReducedCameraSystem.hpp"
#include "tests/firmware_core/adjust/SyntheticPanorama.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;
using areomap::test::PanoramaConfig;
using areomap::test::PanoramaTruth;

namespace {

// Caller-owned, allocated once (several MiB each).
Network g_solver_net;
AdjustWorkspace g_ws;
BlockCholesky g_cholesky;
PcgSolver g_pcg;
AndersonAccelerator g_anderson;

using MatX = Eigen::MatrixXd;
using VecX = Eigen::VectorXd;

// Small networks (dense systems of a few hundred unknowns) unlike each other: ring sizes, tiers, a single
// image, seeds (under emulation the first seed's two: the dense references are most of the work).
std::vector<PanoramaConfig> smallNetworks() {
  static const uint32_t seeds =
      test::underEmulation("the small networks of seed 1 (seeds 1-3 natively)") ? 1 : 3;
  std::vector<PanoramaConfig> out;
  for (uint32_t seed = 1; seed <= seeds; ++seed) {
    PanoramaConfig one_tier = test::navcamConfig();
    one_tier.tiers = 1;
    one_tier.azimuths = 4 + static_cast<int32_t>(seed);
    one_tier.grid = 5;
    one_tier.seed = seed;
    out.push_back(one_tier);
    PanoramaConfig two_tiers = test::navcamConfig();
    two_tiers.azimuths = 4;
    two_tiers.grid = 4;
    two_tiers.single_image = true;
    two_tiers.seed = seed + 10;
    out.push_back(two_tiers);
  }
  return out;
}

// The network away from its least-squares solution (so that the step is not ~0): every camera turned and
// shifted a little, as a pointing error does.
void makeNetwork(const PanoramaConfig& config) {
  PanoramaTruth truth;
  test::makePanorama(config, g_solver_net, truth);
  g_solver_net.rig.sigma_gimbal_m = 1e-4;
  g_solver_net.rig.sigma_base_m = 1e-4;
  std::mt19937 rng(config.seed);
  std::normal_distribution<double> n(0.0, 1.0);
  for (int32_t i = 0; i < g_solver_net.imageCount(); ++i) {
    Vec6 d;
    for (int32_t k = 0; k < 6; ++k) d(k) = (k < 3 ? 2e-3 : 1e-3) * n(rng);  // m, rad
    applyCameraUpdate(d, g_solver_net.image(i).centre_m, g_solver_net.image(i).m);
  }
  g_ws.buildImageIndex(g_solver_net);
  linearize(g_solver_net, g_ws);
}

// The damped normal system of all unknowns (6 per image, then 3 per solvable point with two or more valid
// rays), built from the rows alone: H = sum J^T J over observations and constraint rows, diagonal scaled by
// (1 + damping) (cameras: + 1e-12, as the solvers do), rhs = J^T r.
struct DenseSystem {
  MatX h;
  VecX rhs;
  std::vector<int32_t> point_column;  // -1: the point is not an unknown
  int32_t cameras = 0;
};

DenseSystem denseSystem(double damping) {
  DenseSystem s;
  s.cameras = 6 * g_solver_net.imageCount();
  s.point_column.assign(g_solver_net.pointCount(), -1);
  int32_t columns = s.cameras;
  for (int32_t p = 0; p < g_solver_net.pointCount(); ++p) {
    int32_t rays = 0;
    for (int32_t k = 0; k < g_solver_net.point(p).obs_count; ++k)
      rays += g_ws.obs_valid[g_solver_net.point(p).obs[k]] ? 1 : 0;
    if (g_solver_net.point(p).solvable && rays >= 2) {
      s.point_column[p] = columns;
      columns += 3;
    }
  }
  s.h = MatX::Zero(columns, columns);
  s.rhs = VecX::Zero(columns);
  for (int32_t k = 0; k < g_solver_net.observationCount(); ++k) {
    const NetObservation& o = g_solver_net.observation(k);
    const int32_t pc = s.point_column[o.point];
    if (o.rejected || pc < 0) continue;
    const NetImage& im = g_solver_net.image(o.image);
    Vec2 r;
    Mat2x6 jc;
    Mat2x3 jp;
    if (!ok(observationRow(o, im, im.centre_m, im.m, g_solver_net.point(o.point).xyz_m, r, &jc, &jp)))
      continue;
    Eigen::Matrix<double, 2, Eigen::Dynamic> j = Eigen::Matrix<double, 2, Eigen::Dynamic>::Zero(2, columns);
    j.block<2, 6>(0, 6 * o.image) = jc;
    j.block<2, 3>(0, pc) = jp;
    s.h += j.transpose() * j;
    s.rhs += j.transpose() * r;
  }
  for (int32_t p = 0; p < g_solver_net.pairCount(); ++p) {
    ConstraintRows rows;
    ConstraintJacobian jac;
    const int32_t n = currentPairConstraintRows(g_solver_net, p, rows, jac);
    MatX j = MatX::Zero(n, columns);
    j.block(0, 6 * g_solver_net.pair(p).left, n, 6) = jac.block(0, 0, n, 6);
    if (g_solver_net.pair(p).right >= 0)
      j.block(0, 6 * g_solver_net.pair(p).right, n, 6) = jac.block(0, 6, n, 6);
    s.h += j.transpose() * j;
    s.rhs -= j.transpose() * rows.head(n);
  }
  for (int32_t c = 0; c < columns; ++c) s.h(c, c) *= 1.0 + damping + (c < s.cameras ? 1e-12 : 0.0);
  return s;
}

double largestDifference(const double* a, const VecX& b, int32_t n) {
  double d = 0.0;
  for (int32_t k = 0; k < n; ++k) d = std::fmax(d, std::fabs(a[k] - b(k)));
  return d;
}

// Anderson's linear test map g(x) = A x + c (A symmetric, eigenvalues in [-0.95, 0.95]).
struct LinearMap {
  MatX a;
  VecX c;
};

LinearMap linearMap(int32_t dim, uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, 1.0);
  MatX q = MatX::Zero(dim, dim);
  for (int32_t i = 0; i < dim; ++i) {
    for (int32_t j = 0; j < dim; ++j) q(i, j) = n(rng);
  }
  const Eigen::HouseholderQR<MatX> qr(q);
  const MatX orthogonal = qr.householderQ();
  VecX eig(dim);
  for (int32_t i = 0; i < dim; ++i) eig(i) = 0.95 * std::cos(3.0 * i + seed);
  eig(0) = 0.95;
  LinearMap m;
  m.a = orthogonal * eig.asDiagonal() * orthogonal.transpose();
  m.c = VecX::Zero(dim);
  for (int32_t i = 0; i < dim; ++i) m.c(i) = n(rng);
  return m;
}

}  // namespace

TEST_GROUP(ReducedCameraSystem){};

TEST(ReducedCameraSystem, CholeskyAndPcgStepsEqualTheDenseDampedSolve) {
  // Dense reference: the camera part of H^-1 rhs; the points' back-substituted steps its point part.
  for (const PanoramaConfig& config : smallNetworks()) {
    for (const double damping : {1e-4, 1e-1}) {
      makeNetwork(config);
      const DenseSystem dense = denseSystem(damping);
      const VecX solution = dense.h.ldlt().solve(dense.rhs);
      const double scale = solution.head(dense.cameras).cwiseAbs().maxCoeff();

      CHECK(g_cholesky.order(g_solver_net));
      CHECK(g_cholesky.assembleAndFactor(g_solver_net, g_ws, damping));
      g_cholesky.solve(g_solver_net, g_ws);
      const double cholesky_error = largestDifference(g_ws.step, solution, dense.cameras);
      for (int32_t p = 0; p < g_solver_net.pointCount(); ++p)
        CHECK_EQUAL(dense.point_column[p] >= 0, g_ws.point_eliminated[p]);
      // The points' steps: back-substitution into a copy of the points (no step here crosses behind a
      // camera).
      std::vector<Vec3> before(g_solver_net.pointCount());
      for (int32_t p = 0; p < g_solver_net.pointCount(); ++p) before[p] = g_solver_net.point(p).xyz_m;
      backSubstitutePoints(g_solver_net, g_ws, g_ws.step);
      double point_error = 0.0;
      double point_scale = 0.0;
      for (int32_t p = 0; p < g_solver_net.pointCount(); ++p) {
        if (dense.point_column[p] < 0) continue;
        const Vec3 step = g_solver_net.point(p).xyz_m - before[p];
        const Vec3 expected = solution.segment<3>(dense.point_column[p]);
        point_error = std::fmax(point_error, (step - expected).cwiseAbs().maxCoeff());
        point_scale = std::fmax(point_scale, expected.cwiseAbs().maxCoeff());
        g_solver_net.point(p).xyz_m = before[p];
      }

      int32_t iterations = 0;
      g_pcg.solve(g_solver_net, g_ws, 1e-12, damping, iterations);
      const double pcg_error = largestDifference(g_ws.step, solution, dense.cameras);
      std::printf(
          "\n  %d pairs %d unknowns, damping %.0e: |step| %.2e; cholesky %.1e, points %.1e (|step| %.2e), "
          "pcg %.1e (%d iterations)",
          g_solver_net.pairCount(), static_cast<int>(dense.rhs.size()), damping, scale,
          cholesky_error / scale, point_error / point_scale, point_scale, pcg_error / scale, iterations);
      CHECK(scale > 1e-5);  // a real step, not ~0
      // Two direct solves of the same system agree to rounding (measured: <= 6e-11 relative at damping 1e-4,
      // ~1e-15 at 1e-1; the stiff 0.1 mm rig rows set the condition).
      CHECK(cholesky_error <= 1e-9 * scale);
      CHECK(point_error <= 1e-10 * point_scale);
      // PCG stopped at |r| <= 1e-12 |v| or its iteration bound (measured <= 5e-11).
      CHECK(pcg_error <= 1e-9 * scale);
    }
  }
}

TEST(ReducedCameraSystem, ReducedProductIsTheDenseSchurComplement) {
  // S = Hcc - Hcp Hpp^-1 Hpc of the dense damped system, applied to random camera vectors.
  std::mt19937 rng(7);
  std::normal_distribution<double> n(0.0, 1.0);
  for (const PanoramaConfig& config : smallNetworks()) {
    makeNetwork(config);
    const double damping = 1e-3;
    const DenseSystem dense = denseSystem(damping);
    const int32_t c = dense.cameras;
    const int32_t p = static_cast<int32_t>(dense.rhs.size()) - c;
    const MatX hpp_inv_hpc = dense.h.bottomRightCorner(p, p).ldlt().solve(dense.h.bottomLeftCorner(p, c));
    const MatX s = dense.h.topLeftCorner(c, c) - dense.h.topRightCorner(c, p) * hpp_inv_hpc;
    int32_t iterations = 0;
    g_pcg.solve(g_solver_net, g_ws, 1e-3, damping, iterations);  // leaves the damped pair and point blocks
    double x[kMaxEoUnknowns];
    double y[kMaxEoUnknowns];
    VecX xv(c);
    for (int32_t k = 0; k < c; ++k) xv(k) = x[k] = n(rng);
    reducedProduct(g_solver_net, g_ws, x, y);
    const VecX expected = s * xv;
    const double error = largestDifference(y, expected, c);
    std::printf("\n  %d pairs: |S x| %.2e, reduced product error %.1e", g_solver_net.pairCount(),
                expected.cwiseAbs().maxCoeff(), error / expected.cwiseAbs().maxCoeff());
    CHECK(error <= 1e-9 * expected.cwiseAbs().maxCoeff());
  }
}

TEST(ReducedCameraSystem, ImageIndexListsEveryObservationOfItsImage) {
  for (const PanoramaConfig& config : smallNetworks()) {
    makeNetwork(config);
    int32_t listed = 0;
    for (int32_t i = 0; i < g_solver_net.imageCount(); ++i) {
      std::vector<int32_t> scan;
      for (int32_t k = 0; k < g_solver_net.observationCount(); ++k) {
        if (g_solver_net.observation(k).image == i) scan.push_back(k);
      }
      const int32_t begin = g_ws.image_obs_start[i];
      CHECK_EQUAL(static_cast<int32_t>(scan.size()), g_ws.image_obs_start[i + 1] - begin);
      for (size_t k = 0; k < scan.size(); ++k) CHECK_EQUAL(scan[k], g_ws.image_obs[begin + k]);
      listed += static_cast<int32_t>(scan.size());
    }
    CHECK_EQUAL(g_solver_net.observationCount(), listed);
  }
}

TEST_GROUP(AndersonAccelerator){};

TEST(AndersonAccelerator, FindsTheFixedPointOfALinearMap) {
  // On a linear map of dimension <= depth, Anderson acceleration is GMRES in disguise: in exact arithmetic it
  // reaches the fixed point x* = (I - A)^-1 c once its history spans the space (dim + 2 map evaluations;
  // the first has no difference yet), where the plain iteration still carries most of its error (the
  // largest eigenvalue is 0.95). In floating point, with the 1e-10 regularisation of its least-squares
  // system, it takes up to two more (measured); by 2 dim + 1 evaluations the error must be rounding. One
  // single image: dim 6 (its scales f / range and f weight the inner product).
  for (uint32_t seed = 1; seed <= 3; ++seed) {
    g_solver_net.clear();
    InteriorOrientation io;
    io.f_px = 800.0 + 200.0 * seed;
    int32_t pair = -1;
    CHECK(ok(g_solver_net.addPair(0, 0, io, Vec3::Zero(), Mat3::Identity(), nullptr, Vec3::Zero(),
                                  Mat3::Identity(), pair)));
    const int32_t dim = 6;
    const LinearMap map = linearMap(dim, seed);
    const VecX fixed = (MatX::Identity(dim, dim) - map.a).ldlt().solve(map.c);
    g_anderson.reset(g_solver_net, 5.0, 10);
    VecX x = VecX::Zero(dim);
    VecX plain = VecX::Zero(dim);
    double error_at_dim = 0.0;
    for (int32_t step = 0; step < 2 * dim + 1; ++step) {
      const VecX g = map.a * x + map.c;
      g_anderson.push(dim, x.data(), g.data());
      VecX candidate(dim);
      x = g_anderson.candidate(dim, g.data(), candidate.data()) ? candidate : g;
      plain = map.a * plain + map.c;
      if (step == dim + 1) error_at_dim = (x - fixed).norm() / fixed.norm();
    }
    const double error = (x - fixed).norm() / fixed.norm();
    const double plain_error = (plain - fixed).norm() / fixed.norm();
    std::printf("\n  seed %u: Anderson error %.1e after %d map evaluations, %.1e after %d; plain %.2f", seed,
                error_at_dim, dim + 2, error, 2 * dim + 1, plain_error);
    CHECK(error < 1e-12);
    CHECK(plain_error > 0.1);
  }
}

TEST_GROUP(RigEquations){};

TEST(RigEquations, GimbalAndBaseRowsVanishOnTheTrueRigAndMoveWithTheCameras) {
  // The generator's rig is exact: at the true cameras Eq. 3 and Eq. 4 hold to rounding. Moving the right
  // camera by d moves Eq. 4's residual by exactly d; turning the left camera changes it as its Jacobian says.
  for (uint32_t seed = 1; seed <= 3; ++seed) {
    PanoramaConfig config = test::navcamConfig();
    config.seed = seed;
    config.baseline_m = 0.1 * seed;
    PanoramaTruth truth;
    test::makePanorama(config, g_solver_net, truth);
    const RigConstraints& rig = g_solver_net.rig;
    double worst_gimbal = 0.0;
    double worst_base = 0.0;
    double worst_linear = 0.0;
    for (int32_t p = 0; p < g_solver_net.pairCount(); ++p) {
      const NetPair& pr = g_solver_net.pair(p);
      const int32_t sol = g_solver_net.image(pr.left).sol;
      Vec3 g;
      Mat3x6 jg;
      gimbalRows(truth.centres[pr.left], truth.rotations[pr.left], rig.gimbal_m[sol], rig.left_offset_m, g,
                 jg);
      worst_gimbal = std::fmax(worst_gimbal, g.norm());
      gimbalRows(truth.centres[pr.right], truth.rotations[pr.right], rig.gimbal_m[sol], rig.right_offset_m, g,
                 jg);
      worst_gimbal = std::fmax(worst_gimbal, g.norm());
      Mat3x12 jb;
      baseRows(truth.centres[pr.left], truth.rotations[pr.left], truth.centres[pr.right], rig.base_m, g, jb);
      worst_base = std::fmax(worst_base, g.norm());
      const Vec3 d(1e-3, -2e-3, 0.5e-3);
      Vec3 moved;
      baseRows(truth.centres[pr.left], truth.rotations[pr.left], truth.centres[pr.right] + d, rig.base_m,
               moved, jb);
      CHECK((moved - g - d).norm() < 1e-12);
      // A small turn of the left camera: the residual change to first order is the rotation block times it.
      const Vec3 turn(2e-6, -1e-6, 3e-6);
      Vec3 c_left = truth.centres[pr.left];
      Mat3 m_left = truth.rotations[pr.left];
      Vec6 update;
      update << 0.0, 0.0, 0.0, turn;
      applyCameraUpdate(update, c_left, m_left);
      Vec3 turned;
      baseRows(c_left, m_left, truth.centres[pr.right], rig.base_m, turned, jb);
      Vec12 full = Vec12::Zero();
      full.segment<3>(3) = turn;
      const double linear_error = ((turned - g) - jb * full).norm() / (jb * full).norm();
      worst_linear = std::fmax(worst_linear, linear_error);
    }
    std::printf(
        "\n  seed %u (base %.1f m): true rig misfits gimbal %.1e m, base %.1e m; turn vs Jacobian %.1e", seed,
        config.baseline_m, worst_gimbal, worst_base, worst_linear);
    CHECK(worst_gimbal < 1e-9);
    CHECK(worst_base < 1e-9);
    CHECK(worst_linear < 1e-5);  // second order: |turn| / 2 ~ 2e-6; a wrong block gives O(1)
  }
}
