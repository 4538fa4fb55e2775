// areomap-ground's receive loop: subscribes a Transport to the camera stream and the rover's channels,
// collects until the end-of-panorama marker (then waits for the rover's final EO, bounded), writes the
// received pairs as a dataset folder OUT/stream/ (the full-resolution images as decoded), runs the ground
// pass (GroundPass.hpp) into OUT and publishes AREOMAP_PRODUCT (when the transport can publish).
#pragma once

#include <string>

#include "ground/node/GroundPass.hpp"
#include "ground/node/StreamCollector.hpp"
#include "platform/Transport.hpp"

namespace areomap::ground {

struct GroundNodeOptions {
  GroundPassOptions pass;          // out_dir, truth_dir, progress, products hook
  double first_message_timeout_s = 600.0;  // nothing at all arrives: give up (error)
  double idle_timeout_s = 120.0;   // the stream stops without its end marker: make products from what came
  double rover_wait_s = 300.0;     // after the marker, wait for the rover's final EO (while it sends status)
  double rover_silent_s = 5.0;     // ... but not when nothing came from the rover for this long
  bool can_publish = true;         // false for a read-only log replay
};

struct GroundNodeResult {
  StreamCounts stream;
  RoverInputs rover;
  GroundPassResult pass;
  bool product_published = false;
  int64_t messages = 0;
  double receive_seconds = 0.0;    // first message to end of collection
};

// Subscribes (kCapacityExceeded etc. -> cli::InputError naming the URL), collects, runs the pass.
GroundNodeResult runGroundNode(platform::Transport& transport, const std::string& url, const GroundNodeOptions& options);

}  // namespace areomap::ground
