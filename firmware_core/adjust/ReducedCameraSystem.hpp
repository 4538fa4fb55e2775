// The blocks every fast solver is built from (Di, Xu, Li §3.3): a 3x3 normal block per ground point, a 12x12
// block per stereo pair (6x6 for a single image, the unused half the identity) with the pair's rig
// constraints (Eq. 3, Eq. 4, FIDO variants, datum prior), and the reduced camera system (RCS) that is left
// when every point is eliminated by its 3x3 block:
//   S = C - W N^-1 W^T,   v = g - W N^-1 b
// with C, g the pairs' blocks and right-hand sides, N, b the points' and W the pair-point coupling. The
// solvers use it in three ways: the alternation solves one pair's reduced block at a time (Gauss-Seidel),
// PCG applies S matrix-free (reducedProduct), the block Cholesky assembles and factorises S itself
// (BlockCholesky.hpp). After a camera step the points are back-substituted through their 3x3 blocks.
//
// Everything works on the observation rows cached by linearize() in the AdjustWorkspace; unknowns of an
// image are the local update [dC, delta] of Constraints.hpp, 6 per image in per-image arrays.
#pragma once

#include <cstdint>

#include "firmware_core/adjust/AdjustWorkspace.hpp"
#include "firmware_core/adjust/Network.hpp"
#include "firmware_core/base/EigenTypes.hpp"
#include "firmware_core/base/Status.hpp"

namespace areomap {

// An observation that carries weight: not rejected, and its point solvable.
bool usableObservation(const Network& net, const NetObservation& o);

// The whitened residual of observation o at the network's current camera and point (Constraints.hpp
// observationRow); not kOk when the point is behind the camera.
[[nodiscard]] Status currentResidual(const Network& net, const NetObservation& o, Vec2& residual);

// Total weighted cost (whitened squares of every usable observation and every pair's constraint rows) of
// the network's current state, with the image RMS per coordinate (px) and the number of observations in
// front of their cameras. An observation behind its camera is charged a cost far above any real residual.
double weightedCost(const Network& net, double* rms_px = nullptr, int32_t* active = nullptr);

// Moves a point by `delta`, halving the step while it would put the point behind one of its cameras (a
// far point's depth is nearly free and its Gauss-Newton step can overshoot through infinity).
void movePoint(const Network& net, NetPoint& pt, const Vec3& delta);

// Adds a pair's constraint rows (gimbal, base and the FIDO variants) to its 12x12 normal equations; a single
// image (no right camera) gets the 6x6 system, the unused block the identity with a zero right-hand side.
void addPairConstraints(const Network& net, int32_t pair, Mat12& n, Vec12& b);

// A pair's 12 EO unknowns (left 0-5, right 6-11; a single image leaves 6-11 at zero) in a per-image
// array of 6 values per image, and back.
Vec12 gatherPair(const NetPair& pr, const double* per_image);
void scatterPair(const NetPair& pr, const Vec12& v, double* per_image);

// Every pair's 12x12 system with the points fixed, linearised at the current state, and its step (the plain
// alternation's pair pass). kDegenerate when a block is singular, kNotFinite for a non-finite step.
[[nodiscard]] Status pairStep(Network& net, AdjustWorkspace& ws);

// Whitened residual and Jacobians of every usable observation at the current state, into ws.obs_*.
void linearize(const Network& net, AdjustWorkspace& ws);

// Every point's 3x3 normal block (Levenberg-damped by `damping`), its inverse and right-hand side over all
// its rays, from the observation rows of the last linearize(); ws.point_eliminated marks the points whose
// block is invertible.
void pointBlocks(const Network& net, AdjustWorkspace& ws, double damping);

// Pair `pair`'s 12x12 block and right-hand side from the cached rows and its constraints, and (couple) the
// coupling W (12x3, ws.coupling) to every eliminated point it sees (listed in ws.touched). Returns the
// number of such points.
int32_t pairBlock(const Network& net, AdjustWorkspace& ws, int32_t pair, Mat12& n, Vec12& b, bool couple);

// Eliminates the touched points from a pair's block: n -= W N^-1 W^T, b -= W N^-1 b_point (b may be null).
void reducePairBlock(const AdjustWorkspace& ws, int32_t n_touched, Mat12& n, Vec12* b);

// The RCS right-hand side in place: v = g - W N^-1 b, with `v` (6 per image) holding g on entry.
void reduceRightHandSide(const Network& net, const AdjustWorkspace& ws, double* v);

// y = (C - W N^-1 W^T) x with C the pair blocks in ws.pair_normal, through the cached observation rows.
void reducedProduct(const Network& net, const AdjustWorkspace& ws, const double* x, double* y);

// After the cameras took `camera_step` (6 per image): each eliminated point's step N^-1 (b - W^T x).
void backSubstitutePoints(Network& net, const AdjustWorkspace& ws, const double* camera_step);

}  // namespace areomap
