// Every bound of the rover side, with its reason (DESIGN.md "Capacities and memory"). Workspaces are sized
// from these constants only; a pair that exceeds one is rejected with Status::kCapacityExceeded.
#pragma once

#include <cstddef>
#include <cstdint>

namespace areomap {

// Images: MER/MSL Navcam and Hazcam frames are 1024x1024 8-bit after companding.
constexpr int32_t kMaxImageWidth = 1024;
constexpr int32_t kMaxImageHeight = 1024;
constexpr int32_t kMaxImagePixels = kMaxImageWidth * kMaxImageHeight;
// A larger frame is binned by the smallest integer factor b that fits it (b x b box mean, its model
// rescaled exactly: firmware_core/camera/Binning.hpp), up to this factor: Perseverance Navcam's full
// 5120 x 3840 frame bins by 5, its 1288 x 968 tiles by 2; 8 covers frames up to 8199 px a side. The
// decoder bins while it decodes, one line at a time (a line of at most kMaxBinning (kMaxImageWidth + 1)
// pixels), so no full-size buffer exists. A frame beyond it is rejected (kCapacityExceeded).
constexpr int32_t kMaxBinning = 8;
constexpr int32_t kMaxBinnedSourceWidth = kMaxBinning * (kMaxImageWidth + 1) - 1;
constexpr int32_t kMaxBinnedSourceHeight = kMaxBinning * (kMaxImageHeight + 1) - 1;

// A panorama: the paper's IMP panorama has 64 pairs + 1 single image; a full two-tier Navcam 360 with
// overlap is well under 128 pairs.
constexpr int32_t kMaxPairs = 128;
constexpr int32_t kMaxImages = 2 * kMaxPairs;  // left and right of every pair
constexpr int32_t kMaxSols = 16;               // gimbal centres, one per sol
constexpr int32_t kMaxTiers = 8;               // elevation tiers of a panorama plan

// Tie points: the paper's IMP network has 655; 8192 leaves room for dense intra-stereo gridding.
constexpr int32_t kMaxTiePoints = 8192;
constexpr int32_t kMaxObsPerPoint = 8;  // a point is seen by at most 4 pairs (2 tiers x 2 neighbours)
constexpr int32_t kMaxObservations = kMaxTiePoints * kMaxObsPerPoint;

// Compressed image bytes in one message: quality-95 JPEG of a textured 1024^2 frame is ~0.3-0.6 MiB.
constexpr int32_t kMaxJpegBytes = 2 * 1024 * 1024;

// Iteration bounds (JPL Power of Ten rule 2: every loop has a named maximum).
constexpr int32_t kMaxCameraInverseIterations = 50;  // CAHVOR/CAHVORE pixel -> ray Newton steps

// Total memory of the rover side (static and start-up reserve): 64 MiB for mapping a full panorama, and
// kTraverseMemoryBudgetBytes for localising the rover over a traverse (its site-pose adjustment and the
// cross-site matcher's records of the last sites), which the panorama's workspaces cannot lend since the
// traverse keeps its records from site to site.
constexpr std::size_t kPanoramaMemoryBudgetBytes = 64u * 1024u * 1024u;
constexpr std::size_t kTraverseMemoryBudgetBytes = 8u * 1024u * 1024u;
constexpr std::size_t kStaticMemoryBudgetBytes = kPanoramaMemoryBudgetBytes + kTraverseMemoryBudgetBytes;

static_assert(kMaxImages == 2 * kMaxPairs, "one left and one right image per pair");
static_assert(kMaxObservations >= 2 * kMaxTiePoints, "every tie point needs two observations");

// Camera model text (JPL .cahvor form): one line is a key and at most three numbers at full precision
// (~80 chars); 512 leaves room for comments and covariance lines, which are skipped. A formatted model
// (type, size, seven 3-vectors at 17 digits) takes under 1 KiB.
constexpr std::size_t kMaxModelTextLineChars = 512;
constexpr std::size_t kModelTextBytes = 1024;

// --- Tie points and coarse DEM (firmware_core/match, firmware_core/dem) ---
// Förstner interest points per image: a 32-px spreading grid with at most 2 points per cell on a 1024^2
// frame (32 x 32 cells x 2).
constexpr int32_t kMaxInterestPoints = 2048;
constexpr int32_t kMaxInterestPointsPerCell = 4;
constexpr int32_t kMaxForstnerRadius = 7;  // structure-tensor window up to 15 x 15
// NCC template: 11 x 11 pixels (radius 5) is the usual compromise of distinctiveness and foreshortening.
constexpr int32_t kNccRadius = 5;
constexpr int32_t kNccSide = 2 * kNccRadius + 1;
constexpr int32_t kNccPixels = kNccSide * kNccSide;
// Epipolar search: one sample per pixel along the curve, at most the image diagonal (1448 px), and at most
// +-8 px across it (a-priori pointing errors of a few pixels).
constexpr int32_t kMaxEpipolarSteps = 1536;
constexpr int32_t kMaxEpipolarBandPx = 8;
// Verified intra-stereo ties kept per pair after gridding: 16 x 16 cells of 64 px on a 1024^2 frame.
constexpr int32_t kMaxTiesPerPair = 256;
// Robust parallax-curve fit: bounded reweighting passes.
constexpr int32_t kMaxParallaxFitIterations = 8;
// Coarse DEM per pair: 128 x 128 cells of 0.5 m = 64 m square around the pair, the range where Navcam
// stereo still resolves relief; elevation holes are filled by at most 4 neighbour passes.
constexpr int32_t kCoarseDemCells = 128;
constexpr double kCoarseDemCellM = 0.5;
constexpr int32_t kMaxCoarseDemFillPasses = 4;
// Ray marching through the coarse DEM: steps of half a cell across the 64 m square (diagonal ~91 m).
constexpr int32_t kMaxDemRaySteps = 4 * kCoarseDemCells;
// Inter-stereo search window around the DEM-predicted position: +-16 px (a-priori pointing + DEM error).
constexpr int32_t kInterSearchRadiusPx = 16;

static_assert(kMaxInterestPoints <= (kMaxImageWidth / 32) * (kMaxImageHeight / 32) * 2,
              "spreading grid of 32 px with 2 points per cell bounds the interest points");
static_assert(kMaxTiesPerPair * 2 * kMaxPairs <= kMaxObservations, "intra ties of every pair fit");

// Inter-stereo offset probe: a-priori pointing errors of up to ~15 px per pair (MER mast-head pan/tilt)
// differ by up to ~30 px between two pairs; a few strong ties per image pair are searched +-48 px to
// measure that common offset before the +-kInterSearchRadiusPx search around the corrected prediction.
constexpr int32_t kInterOffsetSearchRadiusPx = 48;
constexpr int32_t kMaxInterOffsetProbes = 24;

// --- Multi-site traverse (firmware_core/adjust/SitePoseAdjuster.hpp) ---
// Sites of one traverse adjustment: the rover stops every 10-30 m, a sol's drive (~100 m) is 4-10 sites;
// 32 sites hold several sols, and the rover's sliding window of the last K sites is a fraction of it. The
// reduced system is dense over the sites (6 x 6 blocks): (6 x 32)^2 doubles = 288 KiB per copy.
constexpr int32_t kMaxSites = 32;
// The ground adjusts a whole traverse at once: areomap-sim writes up to 99 sites (site01..site99), a
// traverse folder holds what the rover sent over several weeks; 128 sites. (The same code, another
// capacity: SitePoseAdjuster.hpp GroundSitePoseAdjuster, 17.7 MiB against the rover's 2.7, ground heap.)
constexpr int32_t kMaxGroundSites = 128;
// Cameras of all sites that see cross-site tie points: a Navcam ring of 10-20 pairs looks forward and
// back with about a third of its images, ~16 cameras per neighbour site; 32 per site leaves room.
constexpr int32_t kMaxCamerasPerSite = 32;
constexpr int32_t kMaxSiteCameras = kMaxSites * kMaxCamerasPerSite;
// Cross-site tie points: ~64 per pair of neighbouring sites already fix a 6-DOF pose to well below the
// odometry; 128 per site pair over the whole window.
constexpr int32_t kMaxCrossSitePointsPerSite = 128;
constexpr int32_t kMaxCrossSitePoints = kMaxSites * kMaxCrossSitePointsPerSite;
// Rays of one cross-site point: a stereo pair at each of up to three sites (6), plus two more images where
// a ring's neighbouring pairs overlap.
constexpr int32_t kMaxObsPerCrossSitePoint = 8;
// Observations: 4 per point on average (a stereo pair at two sites); a point may take 8.
constexpr int32_t kMeanObsPerCrossSitePoint = 4;
constexpr int32_t kMaxCrossSiteObservations = kMaxCrossSitePoints * kMeanObsPerCrossSitePoint;
// Levenberg-Marquardt linearisations of one traverse solve (quadratic convergence: 4-8 from odometry).
constexpr int32_t kMaxSitePoseIterations = 50;

static_assert(kMaxSites >= 2, "a traverse needs two sites to tie");
static_assert(kMaxGroundSites >= kMaxSites, "the ground adjusts at least what the rover holds");
static_assert(kMaxSiteCameras >= 2 * kMaxSites, "every site needs at least a stereo pair");
static_assert(kMaxObsPerCrossSitePoint >= 4, "a point seen by the stereo pairs of two sites has 4 rays");
static_assert(kMaxCrossSiteObservations >= 2 * kMaxCrossSitePoints, "every point needs two observations");

}  // namespace areomap
