// Every bound of the rover side, with its reason (DESIGN.md "Capacities and memory"). Workspaces are sized
// from these constants only; a pair that exceeds one is rejected with Status::kCapacityExceeded.
#pragma once

#include <cstddef>
#include <cstdint>

namespace areomap {

// Images: MER/MSL Navcam and Hazcam frames are 1024x1024 8-bit after companding; larger frames are
// downsampled on the ground before uplink.
constexpr int32_t kMaxImageWidth = 1024;
constexpr int32_t kMaxImageHeight = 1024;
constexpr int32_t kMaxImagePixels = kMaxImageWidth * kMaxImageHeight;

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

// Total static memory of the rover side for a full panorama.
constexpr std::size_t kStaticMemoryBudgetBytes = 64u * 1024u * 1024u;

static_assert(kMaxImages == 2 * kMaxPairs, "one left and one right image per pair");
static_assert(kMaxObservations >= 2 * kMaxTiePoints, "every tie point needs two observations");

}  // namespace areomap
