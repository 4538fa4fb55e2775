// areomap-ground's receive loop: subscribes a Transport to the camera stream and the rover's channels,
// collects until the end-of-panorama marker (then waits for the rover's final EO, bounded), writes the
// received pairs as a dataset folder OUT/stream/ (the full-resolution images as decoded: the record; the
// pass takes them from memory), runs the ground pass (ground/pass/GroundPass.hpp) into OUT and publishes
// AREOMAP_PRODUCT (when the transport can publish).
//
// Several panoramas in one run (`panoramas` != 1): after each panorama's products the node forgets it and
// collects the next; panorama k (1-based) goes to OUT/panorama-KKK/ (its own stream/, products and
// report). With `record_path` every received message is appended to an LCM log (EventRecorder.hpp) before
// it is handled: a node killed mid-pass re-makes the same products from `--lcm file://` that log.
//
// A traverse (`traverse`): the node also subscribes to AREOMAP_SITE; each panorama belongs to the site that
// announced its name (StreamCollector traverse mode) and goes to OUT/sites/<site id>/ (with its own
// truth, `site_truth_dirs`); the run ends after the last site's panorama (or when the stream ends). The
// traverse steps after it (poses, merged map) are ground/traverse's (finishTraverse) on the sites' passes,
// called by areomap-ground through StreamTraverse.hpp.
#pragma once

#include <functional>
#include <map>
#include <string>
#include <vector>

#include "ground/node/Manifest.hpp"
#include "ground/node/StreamCollector.hpp"
#include "ground/pass/GroundPass.hpp"
#include "platform/Transport.hpp"

namespace areomap::ground {

struct GroundNodeOptions {
  GroundPassOptions pass;                  // out_dir, truth_dir, progress, products
  double first_message_timeout_s = 600.0;  // nothing at all arrives: give up (error)
  double idle_timeout_s = 120.0;  // the stream stops without its end marker: make products from what came
  double rover_wait_s = 1800.0;   // after the marker, wait for the rover's final EO (while it sends status)
  double rover_silent_s = 300.0;  // ... but not when nothing came from a rover (heard before) for this long
  bool can_publish = true;        // false for a read-only log replay
  bool log_replay = false;        // a log: after the end marker read on (no waiting) for the rover's final EO
  int32_t panoramas = 1;     // panoramas to make products for before returning; 0 = until the stream ends
  bool stream_only = false;  // collect and count only: no pass, no products (replay-loss tests)
  std::string record_path;   // "" = no recording
  bool traverse = false;     // a multi-site traverse (above); `panoramas` is then ignored
  std::map<std::string, std::string> site_truth_dirs;  // site id -> its dataset folder with truth/
};

struct GroundNodeResult {
  StreamCounts stream;
  RoverInputs rover;
  SitePass pass;                     // the panorama's pass as data (its images, solution, products)
  std::vector<ManifestEntry> files;  // the products' manifest (AREOMAP_PRODUCT)
  bool product_published = false;
  int64_t messages = 0;
  double receive_seconds = 0.0;  // first message to end of collection
  std::string out_dir;           // where this panorama's products are
  int32_t panorama_index = 0;    // 1-based
  std::string site_id;           // traverse: the site this panorama belongs to
  // Traverse: the accepted site announcements and the refusals over the whole run (on every result).
  std::vector<site_t> sites;
  std::map<std::string, site_pose_t> rover_site_poses;  // the rover's own (AREOMAP_SITE_POSE), latest per site
  SiteStreamCounts site_counts;
  // The recording (GroundNodeOptions::record_path) over the whole run: events appended, and received
  // messages that could not be appended (a full disk); set on the result runGroundNode returns.
  int64_t recorded = 0;
  int64_t record_write_errors = 0;
};

// Called after each panorama (products made) with its result.
using PanoramaDone = std::function<void(const GroundNodeResult&)>;

// The folder of panorama k (1-based): OUT itself when the run makes one panorama, else OUT/panorama-KKK.
std::string panoramaOutDir(const std::string& out, int32_t panoramas, int32_t k);

// Subscribes (kCapacityExceeded etc. -> cli::InputError naming the URL), collects, runs the pass.
// Returns the last panorama's result (after `done` was called for every panorama).
GroundNodeResult runGroundNode(platform::Transport& transport, const std::string& url,
                               const GroundNodeOptions& options, const PanoramaDone& done = nullptr);

}  // namespace areomap::ground
