// The matcher's output as a neutral tie list: points (a-priori ground position) and their observations
// (image, pixel, kind, score). Nothing in it belongs to the adjustment: firmware_core/adjust's
// NetworkBuilder reads it, and so do the rover's messages and the ground's tie files. Header only (CMake
// target areomap_tie_list), so that a reader of ties needs no part of the matcher.
// Image index = 2 * pair + side (0 left, 1 right), pairs numbered in the order they were added.
#pragma once

#include <cstdint>

#include "firmware_core/base/EigenTypes.hpp"

namespace areomap {

enum class TieKind : uint8_t { kIntra = 0, kInter = 1 };

struct TieObservation {
  int32_t point = -1;
  int32_t image = -1;  // 2 * pair + (0 left, 1 right)
  double sample_px = 0.0;
  double line_px = 0.0;
  TieKind kind = TieKind::kIntra;
  float score = 0.0f;  // NCC
};

struct TiePoint {
  Vec3 ground_m = Vec3::Zero();  // a-priori position (intra triangulation with the a-priori models)
  int32_t pair = -1;             // the pair that found it
  int32_t observation_count = 0;
};

// A read-only view of a tie list (no copy): points[0, point_count), observations[0, observation_count),
// each observation's `point` an index into `points`, its `image` below 2 * pair_count.
struct TieList {
  const TiePoint* points = nullptr;
  int32_t point_count = 0;
  const TieObservation* observations = nullptr;
  int32_t observation_count = 0;
  int32_t pair_count = 0;  // pairs added so far
};

}  // namespace areomap
