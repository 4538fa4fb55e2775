// Fuzz target: every LCM message type of msgs/ through msgs::decodeMessage<T> (the checked decode every
// node uses). Input: one byte that picks the type (value % 9), then the encoded message. For the types the
// rover reads it also runs the rover's own checks in the rover's order (RoverNode::onStereoPair):
// checkEncoding, checkStereoPairCapacity, decode into a message prepared at start-up, toCameraModel.
// Invariant: when checkEncoding accepts the bytes, the generated decode() must consume exactly all of them
// (the embedded-schema walker and lcm-gen's code agree), and a prepared stereo pair must not grow.
#include <cstring>

#include "areomap/camera_model_t.hpp"
#include "areomap/coarse_dem_t.hpp"
#include "areomap/eo_entry_t.hpp"
#include "areomap/eo_solution_t.hpp"
#include "areomap/product_t.hpp"
#include "areomap/rover_status_t.hpp"
#include "areomap/stereo_image_t.hpp"
#include "areomap/stereo_pair_t.hpp"
#include "areomap/tiepoints_t.hpp"
#include "firmware_core/camera/CameraModel.hpp"
#include "msgs/MessageCheck.hpp"
#include "msgs/adapters/MessageAdapters.hpp"
#include "tests/fuzz/FuzzSupport.hpp"

namespace {

using areomap::Status;
using areomap::fuzz::fail;

template <class Message>
void decodeOne(const uint8_t* data, std::size_t size, Message& out) {
  const Status checked =
      areomap::msgs::checkEncoding(Message::getTypeName(), static_cast<uint64_t>(Message::getHash()), data, size);
  const Status decoded = areomap::msgs::decodeMessage(data, size, out);
  if (checked != decoded) fail("lcm_message", "checkEncoding accepted bytes that decode() does not consume exactly");
}

void modelOf(const areomap::camera_model_t& m) {
  areomap::CameraModel model;
  const char* field = "";
  if (areomap::ok(areomap::toCameraModel(m, model, field))) areomap::fuzz::exerciseModel(model, "lcm_message");
}

void stereoPair(const uint8_t* data, std::size_t size) {
  // The rover's receive path: one message object prepared at start-up, reused.
  static areomap::stereo_pair_t pair = [] {
    areomap::stereo_pair_t p;
    areomap::prepareStereoPair(p);
    return p;
  }();
  const Status checked = areomap::msgs::checkEncoding(areomap::stereo_pair_t::getTypeName(),
                                                      static_cast<uint64_t>(areomap::stereo_pair_t::getHash()),
                                                      data, size);
  if (!areomap::ok(checked)) return;
  const char* field = "";
  if (!areomap::ok(areomap::checkStereoPairCapacity(data, size, field))) return;
  const std::size_t left_capacity = pair.left.jpeg.capacity(), right_capacity = pair.right.jpeg.capacity();
  if (!areomap::ok(areomap::msgs::decodeMessage(data, size, pair))) {
    fail("lcm_message", "a stereo pair that passed checkEncoding and the capacity check does not decode");
  }
  if (pair.left.jpeg.capacity() != left_capacity || pair.right.jpeg.capacity() != right_capacity) {
    fail("lcm_message", "decoding a stereo pair within the capacities grew a reserved vector (heap)");
  }
  // lcm-gen's decode() leaves an array untouched when its count is 0: a reused message then keeps the
  // previous pair's bytes in jpeg (the rover reads jpeg_bytes, never jpeg.size(), so they are never used).
  for (const areomap::stereo_image_t* side : {&pair.left, &pair.right}) {
    if (side->jpeg_bytes > 0 && side->jpeg_bytes != static_cast<int32_t>(side->jpeg.size())) {
      fail("lcm_message", "jpeg_bytes differs from the decoded JPEG's size");
    }
  }
  modelOf(pair.left.model);
  modelOf(pair.right.model);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const uint8_t* bytes = data + 1;
  const std::size_t n = size - 1;
  switch (data[0] % 9) {
    case 0: stereoPair(bytes, n); { areomap::stereo_pair_t m; decodeOne(bytes, n, m); } break;
    case 1: { areomap::stereo_image_t m; decodeOne(bytes, n, m); modelOf(m.model); } break;
    case 2: { areomap::camera_model_t m; decodeOne(bytes, n, m); modelOf(m); } break;
    case 3: { areomap::tiepoints_t m; decodeOne(bytes, n, m); } break;
    case 4: { areomap::eo_solution_t m; decodeOne(bytes, n, m); } break;
    case 5: { areomap::eo_entry_t m; decodeOne(bytes, n, m); modelOf(m.model); } break;
    case 6: { areomap::coarse_dem_t m; decodeOne(bytes, n, m); } break;
    case 7: { areomap::rover_status_t m; decodeOne(bytes, n, m); } break;
    default: { areomap::product_t m; decodeOne(bytes, n, m); } break;
  }
  return 0;
}
