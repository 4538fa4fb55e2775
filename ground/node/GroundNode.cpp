#include "ground/node/GroundNode.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <vector>

#include "ground/cli/Cli.hpp"
#include "ground/node/EventRecorder.hpp"
#include "msgs/Channels.hpp"

namespace areomap::ground {
namespace {

constexpr int32_t kPollMs = 100;
constexpr double kNoRoverWaitS = 5.0;  // after the end marker, when nothing ever came from a rover

int64_t epochMicros() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

enum class Collected { kPanorama, kStreamEnded, kNothing };

// Handles messages until one panorama is complete (its end marker and the rover's final EO, bounded
// waits), the stream ends, or it goes quiet. kNothing when no pair was kept.
Collected collectPanorama(platform::Transport& transport, const std::string& url,
                          const GroundNodeOptions& options, const StreamCollector& collector,
                          bool first_panorama, double& receive_seconds) {
  const double start = cli::nowSeconds();
  double first = -1.0, last_message = start, end_seen = -1.0, last_rover = -1.0;
  int64_t last_count = 0;
  std::size_t last_pairs = 0;
  int64_t rover_messages = 0;
  Collected outcome = Collected::kPanorama;
  for (;;) {
    const Status s = transport.handle(kPollMs);
    const double now = cli::nowSeconds();
    if (s == Status::kEndOfStream) {
      outcome = Collected::kStreamEnded;
      break;
    }
    if (s == Status::kIoError) throw cli::InputError(url, "transport", "receive failed");
    if (s != Status::kOk && s != Status::kTimeout) {
      // A damaged log event: counted, and the replay goes on with the next one.
      cli::warn(url + ": a log event could not be read (" + statusName(s) + ")");
      if (s == Status::kTruncated) {
        outcome = Collected::kStreamEnded;
        break;
      }
      continue;
    }
    if (collector.messagesReceived() != last_count) {
      last_count = collector.messagesReceived();
      last_message = now;
      if (first < 0) first = now;
      const int64_t rover_now = collector.roverTiePointMessages() + collector.roverDemMessages() +
                                (collector.roverStatus() ? collector.roverStatus()->sequence + 1 : 0) +
                                (collector.roverEo() ? collector.roverEo()->sequence + 1 : 0);
      if (rover_now != rover_messages) {
        rover_messages = rover_now;
        last_rover = now;
      }
      const std::size_t pairs = collector.pairs().size();
      if (options.pass.progress && pairs != last_pairs) {
        last_pairs = pairs;
        const StreamCounts c = collector.counts();
        cli::info("received pair " + std::to_string(pairs) +
                  (c.pairs_planned > 0 ? "/" + std::to_string(c.pairs_planned) : std::string()) + " (" +
                  std::to_string(collector.messagesReceived()) + " messages)");
      }
    }
    if (collector.endOfPanorama() && end_seen < 0) {
      end_seen = now;
      if (options.pass.progress) cli::info("end of panorama received");
    }
    if (end_seen >= 0) {
      if (collector.roverFinished()) break;
      if (options.log_replay) continue;  // what the rover sent is further on in the log, if anywhere
      // A rover that was heard may work minutes on a pair without a word; one never heard is not waited for.
      const double rover_quiet = now - (last_rover >= 0 ? last_rover : end_seen);
      if (rover_quiet >
          (last_rover >= 0 ? options.rover_silent_s : std::min(options.rover_silent_s, kNoRoverWaitS)))
        break;
      if (now - end_seen > options.rover_wait_s) {
        cli::warn("the rover's final EO did not arrive within " + std::to_string(options.rover_wait_s) +
                  " s");
        break;
      }
      continue;
    }
    if (first < 0 && now - start > options.first_message_timeout_s) {
      if (!first_panorama) return Collected::kNothing;
      throw cli::InputError(
          url, "stream",
          "no message arrived within " + std::to_string(options.first_message_timeout_s) + " s");
    }
    if (first >= 0 && now - last_message > options.idle_timeout_s) {
      cli::warn("the stream went quiet for " + std::to_string(options.idle_timeout_s) +
                " s without its end-of-panorama marker; making products from what arrived");
      break;
    }
  }
  receive_seconds = first >= 0 ? cli::nowSeconds() - first : 0.0;
  return collector.pairs().empty() ? Collected::kNothing : outcome;
}

// The products of the collected panorama k into its folder, and the manifest message.
GroundNodeResult makePanorama(platform::Transport& transport, const GroundNodeOptions& options,
                              StreamCollector& collector, int32_t k, double receive_seconds) {
  GroundNodeResult result;
  result.panorama_index = k;
  result.out_dir = panoramaOutDir(options.pass.out_dir, options.panoramas, k);
  GroundPassOptions pass_options = options.pass;
  if (options.traverse) {
    const site_t* site = collector.siteOfPanorama(collector.panorama());
    if (site == nullptr) throw std::logic_error("traverse: a collected panorama without its site");
    result.site_id = site->site_id;
    result.out_dir = options.pass.out_dir + "/sites/" + site->site_id;
    const auto truth = options.site_truth_dirs.find(site->site_id);
    pass_options.truth_dir = truth != options.site_truth_dirs.end() ? truth->second : std::string();
    if (options.pass.progress)
      cli::info("site " + site->site_id + " (" + std::to_string(site->site_index + 1) + "/" +
                std::to_string(site->sites_planned) + "): panorama " + collector.panorama() + " received");
  }
  result.receive_seconds = receive_seconds;
  result.messages = collector.messagesReceived();
  result.stream = collector.counts();
  result.rover.eo = collector.roverEo();
  result.rover.status = collector.roverStatus();
  result.rover.tie_messages = collector.roverTiePointMessages();
  result.rover.tie_observations = collector.roverTieObservations();
  result.rover.dem_messages = collector.roverDemMessages();
  result.rover.ties = collector.roverTies();
  result.rover.tie_pairs = collector.roverTiePairs();
  result.rover.tie_messages_missing = collector.roverTieMessagesMissing();
  result.rover.finished = collector.roverFinished();
  result.rover.warnings = collector.roverWarnings();
  if (options.stream_only) return result;

  const std::string& out = result.out_dir;
  pass_options.out_dir = out;
  if (options.pass.progress) cli::info("writing the received images to " + out + "/stream");
  // The images and models as they arrived (stream/ is the record of them; one copy in memory).
  auto panorama =
      std::make_shared<const io::Panorama>(collector.takePanorama(collector.writeDataset(out + "/stream")));
  result.pass = runGroundPass(panorama->dataset, pass_options, &result.stream, &result.rover, panorama);
  result.files = buildManifest(out, "stream/");
  if (options.can_publish) {
    const product_t message = manifestMessage(collector.panorama(), out, result.files, k - 1);
    product_t stamped = message;
    stamped.utime = epochMicros();
    std::vector<uint8_t> bytes(static_cast<std::size_t>(stamped.getEncodedSize()));
    if (stamped.encode(bytes.data(), 0, static_cast<int>(bytes.size())) > 0) {
      result.product_published = ok(transport.publish(channels::kProduct, bytes.data(), bytes.size()));
    }
  }
  return result;
}

}  // namespace

std::string panoramaOutDir(const std::string& out, int32_t panoramas, int32_t k) {
  if (panoramas == 1) return out;
  char name[32];
  std::snprintf(name, sizeof(name), "/panorama-%03d", static_cast<int>(k));
  return out + name;
}

GroundNodeResult runGroundNode(platform::Transport& transport, const std::string& url,
                               const GroundNodeOptions& options, const PanoramaDone& done) {
  StreamCollector collector;
  EventRecorder recorder;
  EventRecorder::Tee tee{&recorder, &StreamCollector::onMessage, &collector};
  const bool record = !options.record_path.empty();
  if (record) {
    const std::filesystem::path parent = std::filesystem::path(options.record_path).parent_path();
    if (!parent.empty()) std::filesystem::create_directories(parent);
    recorder.open(options.record_path);
  }
  collector.setTraverse(options.traverse);
  std::vector<const char*> subscribed = {channels::kStereoPair, channels::kTiePoints, channels::kEoSolution,
                                         channels::kCoarseDem, channels::kRoverStatus};
  if (options.traverse) {
    subscribed.push_back(channels::kSite);
    subscribed.push_back(channels::kSitePose);
  }
  for (const char* channel : subscribed) {
    const Status s = record ? transport.subscribe(channel, &EventRecorder::onMessage, &tee)
                            : transport.subscribe(channel, &StreamCollector::onMessage, &collector);
    if (!ok(s)) throw cli::InputError(url, channel, std::string("cannot subscribe: ") + statusName(s));
  }
  GroundNodeResult last;
  bool ended = false;  // the transport ended; panoramas already read (kept aside) are still made
  const int32_t panoramas = options.traverse ? 0 : options.panoramas;
  for (int32_t k = 1; panoramas <= 0 || k <= panoramas; ++k) {
    double receive_seconds = 0.0;
    Collected collected = Collected::kStreamEnded;
    if (!ended) {
      collected = collectPanorama(transport, url, options, collector, k == 1, receive_seconds);
    } else if (collector.pairs().empty()) {
      collected = Collected::kNothing;
    }
    ended = ended || collected == Collected::kStreamEnded;
    if (collected == Collected::kNothing) {
      if (k == 1) throw cli::InputError(url, channels::kStereoPair, "no usable stereo pair arrived");
      if (collector.messagesReceived() > 0)
        cli::warn("the stream ended inside panorama " + std::to_string(k) + " with no usable pair");
      break;
    }
    GroundNodeResult result = makePanorama(transport, options, collector, k, receive_seconds);
    result.sites = collector.sites();
    result.rover_site_poses = collector.roverSitePoses();
    result.site_counts = collector.siteCounts();
    const site_t* site = options.traverse ? collector.siteOfPanorama(collector.panorama()) : nullptr;
    const bool last_site = site != nullptr && site->is_last;
    if (done) done(result);
    last = std::move(result);
    collector.nextPanorama();
    // What the pass freed on its threads' heaps goes back to the system while the node waits: between
    // panoramas its resident memory is what it holds, not each pass's high-water mark.
    cli::releaseFreedMemory();
    if (last_site) break;  // the traverse's last site is mapped
  }
  last.sites = collector.sites();
  last.site_counts = collector.siteCounts();
  last.recorded = recorder.events();
  last.record_write_errors = recorder.writeErrors();
  return last;
}

}  // namespace areomap::ground
