// Degrees and radians for the traverse code: one definition, so that its files can share a translation unit
// (the unity builds, cmake/AreomapUnity.cmake).
#pragma once

namespace areomap::traverse {

inline constexpr double kPi = 3.14159265358979323846;
inline constexpr double kDegToRad = kPi / 180.0;
inline constexpr double kRadToDeg = 180.0 / kPi;

}  // namespace areomap::traverse
