// Degrees and radians: one definition for the rover side and the ground, so that no file keeps its own copy
// (the unity builds put several files into one translation unit).
#pragma once

namespace areomap {

inline constexpr double kPi = 3.14159265358979323846;
inline constexpr double kDegToRad = kPi / 180.0;
inline constexpr double kRadToDeg = 180.0 / kPi;

}  // namespace areomap
