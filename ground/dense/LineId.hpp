// The equi-parallax line of a dense point (CloudPoint::line, dem::DemPoint::line): the stereo pair and the
// rectified left row it was matched on, in one integer. Header only, so that ground/dem reads it without
// linking the matcher.
#pragma once

#include <cstdint>

namespace areomap::dense {

inline constexpr int64_t kLineRowsPerPair = 65536;  // rows of one rectified image, at most

inline constexpr int64_t lineId(int64_t pair_id, int64_t row) { return pair_id * kLineRowsPerPair + row; }
inline constexpr int64_t linePair(int64_t line) { return line / kLineRowsPerPair; }
inline constexpr int64_t lineRow(int64_t line) { return line % kLineRowsPerPair; }

}  // namespace areomap::dense
