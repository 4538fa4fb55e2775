// Deterministic hashing and value noise: every random quantity of the simulator is a pure function of the
// seed and its coordinates, so output does not depend on thread count or order of work.
#pragma once

#include <cmath>
#include <cstdint>

namespace areomap::sim {

inline uint64_t mix64(uint64_t x) {  // splitmix64 finaliser
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

inline uint64_t hash3(uint64_t seed, int64_t a, int64_t b, uint64_t c = 0) {
  return mix64(seed ^ mix64(static_cast<uint64_t>(a) ^ mix64(static_cast<uint64_t>(b) ^ mix64(c))));
}

// A cheap lattice hash (one finaliser) for noise lattices.
inline uint64_t latticeHash(uint64_t seed, int64_t a, int64_t b) {
  return mix64(seed ^ (static_cast<uint64_t>(a) * 0x9e3779b97f4a7c15ULL) ^ (static_cast<uint64_t>(b) * 0xc2b2ae3d27d4eb4fULL));
}

// Uniform in [0, 1) from a hash.
inline double unit(uint64_t h) { return static_cast<double>(h >> 11) * (1.0 / 9007199254740992.0); }

// Standard normal from two hashes (Box-Muller).
inline double gaussian(uint64_t h1, uint64_t h2) {
  const double u1 = unit(h1) + 1e-300;
  const double u2 = unit(h2);
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
}

// Value noise in [-1, 1] on a unit lattice with smooth (quintic) interpolation.
inline double valueNoise(uint64_t seed, double x, double y) {
  const double fx = std::floor(x), fy = std::floor(y);
  const int64_t ix = static_cast<int64_t>(fx), iy = static_cast<int64_t>(fy);
  const double tx = x - fx, ty = y - fy;
  const double sx = tx * tx * tx * (tx * (tx * 6.0 - 15.0) + 10.0);
  const double sy = ty * ty * ty * (ty * (ty * 6.0 - 15.0) + 10.0);
  const double v00 = unit(latticeHash(seed, ix, iy)), v10 = unit(latticeHash(seed, ix + 1, iy));
  const double v01 = unit(latticeHash(seed, ix, iy + 1)), v11 = unit(latticeHash(seed, ix + 1, iy + 1));
  const double a = v00 + (v10 - v00) * sx, b = v01 + (v11 - v01) * sx;
  return 2.0 * (a + (b - a) * sy) - 1.0;
}

// Sum of `octaves` value-noise octaves from `wavelength` down by halves; amplitude falls by `gain` per
// octave. Returns roughly [-1, 1] scaled by the sum of amplitudes.
inline double fbm(uint64_t seed, double x, double y, double wavelength, int octaves, double gain) {
  double sum = 0.0, amplitude = 1.0, norm = 0.0;
  double freq = 1.0 / wavelength;
  for (int o = 0; o < octaves; ++o) {
    sum += amplitude * valueNoise(seed + 0x51ed2701ULL * static_cast<uint64_t>(o + 1), x * freq + 0.37 * o,
                                  y * freq - 0.61 * o);
    norm += amplitude;
    amplitude *= gain;
    freq *= 2.0;
  }
  return sum / norm;
}

// fbm() along a line of constant x, for grids filled row by row: per octave the x lattice column and its
// weight are fixed, and the two x-interpolated lattice values are reused while y stays in one lattice cell
// (an octave's cell spans several grid nodes). Every value is fbm()'s bit for bit: the same operations on the
// same operands, in the same order.
class FbmAlongY {
 public:
  static constexpr int kMaxOctaves = 16;

  // `octaves` beyond kMaxOctaves are not evaluated.
  FbmAlongY(uint64_t seed, double x, double wavelength, int octaves, double gain)
      : octaves_(octaves < kMaxOctaves ? octaves : kMaxOctaves) {
    double amplitude = 1.0, freq = 1.0 / wavelength;
    for (int o = 0; o < octaves_; ++o) {
      Octave& v = octave_[o];
      v.seed = seed + 0x51ed2701ULL * static_cast<uint64_t>(o + 1);
      v.freq = freq;
      v.y_offset = 0.61 * o;
      v.amplitude = amplitude;
      const double xo = x * freq + 0.37 * o;
      const double fx = std::floor(xo);
      v.ix = static_cast<int64_t>(fx);
      const double tx = xo - fx;
      v.sx = tx * tx * tx * (tx * (tx * 6.0 - 15.0) + 10.0);
      norm_ += amplitude;
      amplitude *= gain;
      freq *= 2.0;
    }
  }

  double operator()(double y) {
    double sum = 0.0;
    for (int o = 0; o < octaves_; ++o) {
      Octave& v = octave_[o];
      const double yo = y * v.freq - v.y_offset;
      const double fy = std::floor(yo);
      const int64_t iy = static_cast<int64_t>(fy);
      const double ty = yo - fy;
      const double sy = ty * ty * ty * (ty * (ty * 6.0 - 15.0) + 10.0);
      if (!v.cached || iy != v.iy) {
        const double v00 = unit(latticeHash(v.seed, v.ix, iy)), v10 = unit(latticeHash(v.seed, v.ix + 1, iy));
        const double v01 = unit(latticeHash(v.seed, v.ix, iy + 1)), v11 = unit(latticeHash(v.seed, v.ix + 1, iy + 1));
        v.a = v00 + (v10 - v00) * v.sx;
        v.b = v01 + (v11 - v01) * v.sx;
        v.iy = iy;
        v.cached = true;
      }
      sum += v.amplitude * (2.0 * (v.a + (v.b - v.a) * sy) - 1.0);
    }
    return sum / norm_;
  }

 private:
  struct Octave {
    uint64_t seed = 0;
    double freq = 0.0, y_offset = 0.0, amplitude = 0.0, sx = 0.0, a = 0.0, b = 0.0;
    int64_t ix = 0, iy = 0;
    bool cached = false;
  };
  Octave octave_[kMaxOctaves];
  int octaves_ = 0;
  double norm_ = 0.0;
};

}  // namespace areomap::sim
