#include "ground/node/GroundNode.hpp"

#include <chrono>
#include <vector>

#include "ground/cli/Cli.hpp"
#include "msgs/Channels.hpp"

namespace areomap::ground {
namespace {

constexpr int32_t kPollMs = 100;

int64_t epochMicros() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

}  // namespace

GroundNodeResult runGroundNode(platform::Transport& transport, const std::string& url, const GroundNodeOptions& options) {
  StreamCollector collector;
  for (const char* channel : {channels::kStereoPair, channels::kTiePoints, channels::kEoSolution, channels::kCoarseDem,
                              channels::kRoverStatus}) {
    const Status s = transport.subscribe(channel, &StreamCollector::onMessage, &collector);
    if (!ok(s)) throw cli::InputError(url, channel, std::string("cannot subscribe: ") + statusName(s));
  }
  GroundNodeResult result;
  const double start = cli::nowSeconds();
  double first = -1.0, last_message = start, end_seen = -1.0, last_rover = -1.0;
  int64_t last_count = 0;
  std::size_t last_pairs = 0;
  int64_t rover_messages = 0;
  for (;;) {
    const Status s = transport.handle(kPollMs);
    const double now = cli::nowSeconds();
    if (s == Status::kEndOfStream) break;
    if (s == Status::kIoError) throw cli::InputError(url, "transport", "receive failed");
    if (s != Status::kOk && s != Status::kTimeout) {
      // A damaged log event: counted, and the replay goes on with the next one.
      cli::warn(url + ": a log event could not be read (" + statusName(s) + ")");
      if (s == Status::kTruncated) break;
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
      const double rover_quiet = now - (last_rover >= 0 ? last_rover : end_seen);
      if (rover_quiet > options.rover_silent_s) break;
      if (now - end_seen > options.rover_wait_s) {
        cli::warn("the rover's final EO did not arrive within " + std::to_string(options.rover_wait_s) + " s");
        break;
      }
      continue;
    }
    if (first < 0 && now - start > options.first_message_timeout_s) {
      throw cli::InputError(url, "stream", "no message arrived within " + std::to_string(options.first_message_timeout_s) + " s");
    }
    if (first >= 0 && now - last_message > options.idle_timeout_s) {
      cli::warn("the stream went quiet for " + std::to_string(options.idle_timeout_s) +
                " s without its end-of-panorama marker; making products from what arrived");
      break;
    }
  }
  result.receive_seconds = first >= 0 ? cli::nowSeconds() - first : 0.0;
  result.messages = collector.messagesReceived();
  result.stream = collector.counts();
  if (collector.pairs().empty()) throw cli::InputError(url, channels::kStereoPair, "no usable stereo pair arrived");
  result.rover.eo = collector.roverEo();
  result.rover.status = collector.roverStatus();
  result.rover.tie_messages = collector.roverTiePointMessages();
  result.rover.tie_observations = collector.roverTieObservations();
  result.rover.dem_messages = collector.roverDemMessages();
  result.rover.ties = collector.roverTies();
  result.rover.warnings = collector.roverWarnings();

  const std::string& out = options.pass.out_dir;
  if (options.pass.progress) cli::info("writing the received images to " + out + "/stream");
  const Dataset dataset = collector.writeDataset(out + "/stream");
  result.pass = runGroundPass(dataset, options.pass, &result.stream, &result.rover);
  result.pass.files = buildManifest(out, "stream/");
  if (options.can_publish) {
    const product_t message = manifestMessage(collector.panorama(), out, result.pass.files, 0);
    product_t stamped = message;
    stamped.utime = epochMicros();
    std::vector<uint8_t> bytes(static_cast<std::size_t>(stamped.getEncodedSize()));
    if (stamped.encode(bytes.data(), 0, static_cast<int>(bytes.size())) > 0) {
      result.product_published = ok(transport.publish(channels::kProduct, bytes.data(), bytes.size()));
    }
  }
  return result;
}

}  // namespace areomap::ground
