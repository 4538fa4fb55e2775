// Filled instances of every message type, for the round-trip tests (values vary with `seed` so that a field
// that is dropped or swapped in the encoding shows).
#pragma once

#include <cstdint>
#include <vector>

#include "areomap/coarse_dem_t.hpp"
#include "areomap/eo_solution_t.hpp"
#include "areomap/product_t.hpp"
#include "areomap/rover_status_t.hpp"
#include "areomap/stereo_pair_t.hpp"
#include "areomap/tiepoints_t.hpp"

namespace areomap::test {

areomap::camera_model_t makeCameraModel(int seed);
areomap::stereo_pair_t makeStereoPair(int seed, int32_t jpeg_bytes);
areomap::tiepoints_t makeTiePoints(int seed, int32_t observations);
areomap::eo_solution_t makeEoSolution(int seed, int32_t images);
areomap::coarse_dem_t makeCoarseDem(int seed, int32_t rows, int32_t cols);
areomap::rover_status_t makeRoverStatus(int seed);
areomap::product_t makeProduct(int seed, int32_t files);

// The encoding of a generated message (with its fingerprint).
template <class Message>
std::vector<uint8_t> encode(const Message& message) {
  std::vector<uint8_t> bytes(static_cast<std::size_t>(message.getEncodedSize()));
  const int used = message.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  bytes.resize(used < 0 ? 0 : static_cast<std::size_t>(used));
  return bytes;
}

}  // namespace areomap::test
