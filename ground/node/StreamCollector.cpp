#include "ground/node/StreamCollector.hpp"

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <memory>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>

#include "areomap/coarse_dem_t.hpp"
#include "areomap/tiepoints_t.hpp"
#include "firmware_core/base/Capacities.hpp"
#include "ground/cli/AtomicFile.hpp"
#include "ground/cli/Cli.hpp"
#include "ground/io/CameraFile.hpp"
#include "ground/raster/RasterFiles.hpp"
#include "msgs/Channels.hpp"
#include "msgs/MessageCheck.hpp"
#include "msgs/adapters/MessageAdapters.hpp"
#include "platform/posix/TurboJpegCodec.hpp"

namespace areomap::ground {
namespace {

// The fingerprint of an encoded message (its first 8 bytes, big-endian); false when too short.
bool fingerprintOf(const uint8_t* data, std::size_t size, uint64_t& hash) {
  if (data == nullptr || size < 8) return false;
  hash = 0;
  for (int i = 0; i < 8; ++i) hash = (hash << 8) | data[i];
  return true;
}

// Checks and decodes; on failure returns the rejection cause ("wrong_type" for another type's fingerprint).
template <class Message>
std::string decodeOrCause(const uint8_t* data, std::size_t size, Message& out) {
  uint64_t hash = 0;
  if (fingerprintOf(data, size, hash) && hash != static_cast<uint64_t>(Message::getHash()))
    return "wrong_type";
  const Status s = msgs::decodeMessage(data, size, out);
  return ok(s) ? std::string() : std::string(statusName(s));
}

std::string sequenceNeighbours(const std::map<int64_t, int32_t>& pair_of_sequence, int64_t sequence) {
  std::string text;
  const auto after = pair_of_sequence.upper_bound(sequence);
  if (after != pair_of_sequence.begin()) {
    text += "after pair " + std::to_string(std::prev(after)->second);
  }
  if (after != pair_of_sequence.end()) {
    text += std::string(text.empty() ? "" : ", ") + "before pair " + std::to_string(after->second);
  }
  return text.empty() ? "no pair received" : text;
}

}  // namespace

SequenceTracker::Arrival SequenceTracker::record(int64_t sequence) {
  if (from_first_seen_ && !any_seen_) {
    floor_ = sequence;
    highest_ = sequence - 1;
  }
  any_seen_ = true;
  if (sequence < floor_ || !seen_.insert(sequence).second) {
    ++duplicates_;
    return Arrival::kDuplicate;
  }
  if (sequence < highest_) {
    ++reordered_;
    return Arrival::kReordered;
  }
  highest_ = sequence;
  return Arrival::kInOrder;
}

std::vector<int64_t> SequenceTracker::missing() const {
  std::vector<int64_t> out;
  int64_t expected = floor_;
  for (int64_t s : seen_) {
    if (s < 0) continue;
    for (int64_t k = expected; k < s; ++k) out.push_back(k);
    expected = s + 1;
  }
  return out;
}

void SequenceTracker::restartAfterHighest() {
  seen_.clear();
  floor_ = highest_ + 1;
  duplicates_ = 0;
  reordered_ = 0;
}

StreamCollector::StreamCollector() = default;

void StreamCollector::nextPanorama() {
  std::map<std::string, SequenceTracker> rover_sequences = std::move(rover_sequences_);
  for (auto& [channel, tracker] : rover_sequences) tracker.restartAfterHighest();
  std::vector<std::vector<uint8_t>> next = std::move(next_panorama_);
  const bool traverse = traverse_;
  std::vector<site_t> sites = std::move(sites_);
  SequenceTracker site_sequences = std::move(site_sequences_);
  SiteStreamCounts site_counts = std::move(site_counts_);
  std::map<std::string, site_pose_t> site_poses = std::move(rover_site_poses_);
  *this = StreamCollector();
  rover_site_poses_ = std::move(site_poses);
  rover_sequences_ = std::move(rover_sequences);
  traverse_ = traverse;
  sites_ = std::move(sites);
  site_sequences_ = std::move(site_sequences);
  site_counts_ = std::move(site_counts);
  for (const std::vector<uint8_t>& m : next) receive(channels::kStereoPair, m.data(), m.size());
}

io::Panorama StreamCollector::takePanorama(Dataset written) {
  io::Panorama p;
  const auto take = [](ReceivedImage& image, const ImageRef& ref) {
    if (image.stem != ref.stem) {
      throw std::logic_error("takePanorama: image " + image.stem + " is " + ref.stem +
                             " in the dataset written");
    }
    io::PanoramaImage out;
    out.stem = ref.stem;
    out.image_path = ref.image_path;
    out.grey = std::move(image.pixels);
    if (!out.grey.isContinuous()) out.grey = out.grey.clone();
    out.model = image.model;
    if (out.model.width <= 0) out.model.width = out.grey.cols, out.model.height = out.grey.rows;
    return out;
  };
  std::size_t k = 0;
  for (auto& [id, pair] : pairs_) {
    if (k >= written.pairs.size())
      throw std::logic_error("takePanorama: more pairs than the dataset written");
    const Pair& ref = written.pairs[k++];
    p.left.push_back(take(pair.left, ref.left));
    if (pair.right.has_value() != ref.right.has_value()) {
      throw std::logic_error("takePanorama: pair " + ref.left.stem + " differs from the dataset written");
    }
    p.right.push_back(pair.right ? std::optional<io::PanoramaImage>(take(*pair.right, *ref.right))
                                 : std::nullopt);
  }
  if (k != written.pairs.size()) throw std::logic_error("takePanorama: fewer pairs than the dataset written");
  p.dataset = std::move(written);
  return p;
}

int32_t StreamCollector::roverTieMessagesMissing() const {
  const auto it = rover_sequences_.find(channels::kTiePoints);
  return it == rover_sequences_.end() ? 0 : static_cast<int32_t>(it->second.missing().size());
}

void StreamCollector::onMessage(void* context, const char* channel, const uint8_t* data, std::size_t size) {
  static_cast<StreamCollector*>(context)->receive(channel == nullptr ? "" : channel, data, size);
}

void StreamCollector::receive(const std::string& channel, const uint8_t* data, std::size_t size) {
  ++messages_;
  if (channel == channels::kSite) {
    receiveSite(data, size);
    return;
  }
  if (channel == channels::kStereoPair) {
    if (end_of_panorama_) {
      if (data != nullptr) next_panorama_.emplace_back(data, data + size);
      return;
    }
    receivePair(data, size);
    return;
  }
  auto track = [&](int64_t sequence) {
    const auto [it, inserted] = rover_sequences_.try_emplace(channel);
    if (inserted) it->second.countFromFirstSeen();
    return it->second.record(sequence) != SequenceTracker::Arrival::kDuplicate;
  };
  if (channel == channels::kEoSolution) {
    eo_solution_t eo;
    const std::string cause = decodeOrCause(data, size, eo);
    if (!cause.empty()) return reject("rover_eo_" + cause);
    if (!track(eo.sequence)) return;
    if (!rover_eo_ || eo.sequence > rover_eo_->sequence) rover_eo_ = std::move(eo);
  } else if (channel == channels::kRoverStatus) {
    rover_status_t status;
    const std::string cause = decodeOrCause(data, size, status);
    if (!cause.empty()) return reject("rover_status_" + cause);
    if (!track(status.sequence)) return;
    if (status.state == rover_status_t::STATE_RUNNING) rover_running_seen_ = true;
    if (!rover_status_ || status.sequence > rover_status_->sequence) rover_status_ = std::move(status);
  } else if (channel == channels::kTiePoints) {
    tiepoints_t ties;
    const std::string cause = decodeOrCause(data, size, ties);
    if (!cause.empty()) return reject("rover_tiepoints_" + cause);
    if (!track(ties.sequence)) return;
    ++rover_tie_messages_;
    rover_tie_pairs_.insert(ties.pair_id);
    rover_tie_observations_ += ties.num_observations;
    for (int32_t k = 0; k < ties.num_observations; ++k) {
      const int32_t image = ties.image_index[static_cast<std::size_t>(k)];
      if (image < 0 || image >= ties.num_images) {
        reject("rover_tiepoints_image_index");
        continue;
      }
      ImageObservation o;
      o.point = ties.point_id[static_cast<std::size_t>(k)];
      o.image = ties.image_stems[static_cast<std::size_t>(image)];
      o.sample_px = ties.sample_px[static_cast<std::size_t>(k)];
      o.line_px = ties.line_px[static_cast<std::size_t>(k)];
      o.kind = ties.kind[static_cast<std::size_t>(k)] == tiepoints_t::KIND_INTER ? "inter" : "intra";
      rover_ties_.push_back(o);
    }
  } else if (channel == channels::kSitePose) {
    site_pose_t pose;
    const std::string cause = decodeOrCause(data, size, pose);
    if (!cause.empty()) return reject("rover_site_pose_" + cause);
    if (!track(pose.sequence)) return;
    const auto it = rover_site_poses_.find(pose.site_id);
    if (it == rover_site_poses_.end() || pose.sequence > it->second.sequence) rover_site_poses_[pose.site_id] = pose;
  } else if (channel == channels::kCoarseDem) {
    coarse_dem_t dem;
    const std::string cause = decodeOrCause(data, size, dem);
    if (!cause.empty()) return reject("rover_dem_" + cause);
    if (!track(dem.sequence)) return;
    ++rover_dem_messages_;
  } else {
    reject("unknown_channel");
  }
}

std::string StreamCollector::decodeImage(const stereo_image_t& side, ReceivedImage& out) {
  // One codec per collector thread; TurboJPEG handles are made once.
  static thread_local std::unique_ptr<platform::TurboJpegCodec> codec;
  if (!codec) {
    codec = std::make_unique<platform::TurboJpegCodec>();
    if (!ok(codec->open())) {
      return "jpeg_unsupported";
    }
  }
  if (side.jpeg_bytes <= 0 || side.jpeg.empty()) {
    return "missing_image";
  }
  // The header's size first (a decode into no room stops at the size and reports it): frames up to what
  // the rover maps binned (kMaxBinnedSourceWidth x kMaxBinnedSourceHeight) are kept at full resolution,
  // larger ones are refused as the rover refuses them.
  int32_t width = 0, height = 0;
  uint8_t none = 0;
  Status s = codec->decodeGray(side.jpeg.data(), side.jpeg.size(), &none, 0, width, height);
  if (s == Status::kCapacityExceeded && (width > kMaxBinnedSourceWidth || height > kMaxBinnedSourceHeight)) {
    return "capacity_exceeded";
  }
  std::vector<uint8_t> pixels;
  if (s == Status::kCapacityExceeded && width > 0 && height > 0) {
    pixels.resize(static_cast<std::size_t>(width) * static_cast<std::size_t>(height));
    s = codec->decodeGray(side.jpeg.data(), side.jpeg.size(), pixels.data(), pixels.size(), width, height);
  }
  if (!ok(s)) {
    // Measured: after a damaged JPEG the TurboJPEG handle refused the next, intact images as corrupt; a
    // fresh handle for the next image keeps one bad image from costing the rest of the panorama.
    codec.reset();
    return std::string("jpeg_") + statusName(s);
  }
  if ((side.width_px != 0 && side.width_px != width) || (side.height_px != 0 && side.height_px != height)) {
    return "size_mismatch";
  }
  CameraModel model;
  const char* field = "";
  const Status model_status = toCameraModel(side.model, model, field);
  if (!ok(model_status)) {
    return std::string("model_") + statusName(model_status);
  }
  if (model.width == 0) model.width = width;
  if (model.height == 0) model.height = height;
  std::string why;
  if (side.stem.empty() || side.stem.find('/') != std::string::npos || !isSafeRelativePath(side.stem, why)) {
    return "invalid_stem";
  }
  out.stem = side.stem;
  out.pixels = cv::Mat(height, width, CV_8UC1, pixels.data()).clone();
  out.model = model;
  return std::string();
}

const site_t* StreamCollector::siteOfPanorama(const std::string& panorama) const {
  for (const site_t& site : sites_) {
    if (site.panorama == panorama) return &site;
  }
  return nullptr;
}

void StreamCollector::rejectSite(const std::string& cause, const std::string& sentence) {
  ++site_counts_.rejected[cause];
  site_counts_.warnings.push_back(sentence);
  cli::warn(sentence);
}

void StreamCollector::receiveSite(const uint8_t* data, std::size_t size) {
  if (!traverse_) return reject("site_without_traverse_mode");
  site_t site;
  prepareSite(site);
  const char* field = "";
  uint64_t hash = 0;
  if (fingerprintOf(data, size, hash) && hash != static_cast<uint64_t>(site_t::getHash())) {
    return rejectSite("site_wrong_type", "A message on " + std::string(channels::kSite) +
                                             " is not a site_t (another fingerprint): dropped.");
  }
  const Status s = data == nullptr ? Status::kInvalidArgument : decodeSite(data, size, site, field);
  if (!ok(s)) {
    return rejectSite(std::string("site_") + statusName(s),
                      "A site announcement was rejected (" + std::string(statusName(s)) + ", " + field +
                          "): the pairs of its panorama will be refused as unannounced.");
  }
  if (site_sequences_.record(site.sequence) == SequenceTracker::Arrival::kDuplicate) {
    ++site_counts_.site_duplicates;
    return;
  }
  const std::string what = "site " + site.site_id + " (index " + std::to_string(site.site_index) +
                           ", panorama " + site.panorama + ")";
  if (!sites_.empty()) {
    const site_t& first = sites_.front();
    if (site.traverse != first.traverse || site.sites_planned != first.sites_planned) {
      return rejectSite("site_unknown", "The announcement of " + what + " names traverse '" + site.traverse +
                                            "' of " + std::to_string(site.sites_planned) +
                                            " sites, not this stream's '" + first.traverse + "' of " +
                                            std::to_string(first.sites_planned) + ": dropped.");
    }
    for (const site_t& known : sites_) {
      if (known.site_id == site.site_id || known.panorama == site.panorama ||
          known.site_index == site.site_index) {
        return rejectSite("site_duplicate", "The announcement of " + what + " repeats site " + known.site_id +
                                                " (index " + std::to_string(known.site_index) +
                                                ", panorama " + known.panorama +
                                                "): dropped, the first one stands.");
      }
    }
  }
  ++site_counts_.sites_announced;
  if (site.has_odometry && !sites_.empty()) {
    bool from_known = false;
    for (const site_t& known : sites_) from_known = from_known || known.site_id == site.odometry_from;
    if (!from_known) {
      site_counts_.warnings.push_back("The odometry of " + what + " is from site " + site.odometry_from +
                                      ", which was not announced.");
    }
  }
  sites_.push_back(std::move(site));
}

void StreamCollector::receivePair(const uint8_t* data, std::size_t size) {
  stereo_pair_t msg;
  const std::string cause = decodeOrCause(data, size, msg);
  if (!cause.empty()) return reject(cause);
  if (traverse_) {
    if (siteOfPanorama(msg.panorama) == nullptr) {
      // Before its sequence is counted: the next site's numbering starts at 0 again.
      ++site_counts_.rejected["pair_unannounced_panorama"];
      reject("pair_unannounced_panorama");
      const std::string what =
          msg.kind == stereo_pair_t::KIND_END_OF_PANORAMA
              ? "the end-of-panorama marker"
              : "pair " + std::to_string(msg.pair_id) + " (sequence " + std::to_string(msg.sequence) + ")";
      site_counts_.warnings.push_back("The camera stream's " + what + " of panorama '" + msg.panorama +
                                      "' was rejected: no site announced that panorama.");
      return;
    }
    if (!panorama_.empty() && msg.panorama != panorama_) {
      // The next site's stream before this one's end marker: the marker was lost; this panorama ends here.
      end_of_panorama_ = true;
      pair_rejections_.push_back("The end-of-panorama marker of '" + panorama_ +
                                 "' was not received before the pairs of '" + msg.panorama + "'.");
      next_panorama_.emplace_back(data, data + size);
      return;
    }
  }
  const SequenceTracker::Arrival arrival = pair_sequences_.record(msg.sequence);
  if (arrival == SequenceTracker::Arrival::kDuplicate) return;
  if (panorama_.empty()) panorama_ = msg.panorama;
  if (msg.kind == stereo_pair_t::KIND_END_OF_PANORAMA) {
    end_of_panorama_ = true;
    pairs_planned_ = msg.pairs_planned;
    return;
  }
  if (msg.kind != stereo_pair_t::KIND_PAIR) return reject("invalid_kind");
  if (pairs_.count(msg.pair_id) != 0) {
    ++duplicate_pair_ids_;
    return;
  }
  ReceivedPair pair;
  pair.sequence = msg.sequence;
  pair.pair_id = msg.pair_id;
  pair.sol = msg.sol;
  pair.tier = msg.tier;
  const std::string left_cause = decodeImage(msg.left, pair.left);
  if (!left_cause.empty()) return rejectPair(msg, left_cause);
  if (msg.has_right) {
    ReceivedImage right;
    const std::string right_cause = decodeImage(msg.right, right);
    if (!right_cause.empty()) return rejectPair(msg, right_cause);
    pair.right = std::move(right);
  }
  if (pairs_planned_ < 0) pairs_planned_ = msg.pairs_planned;
  if (msg.gimbal_given) gimbal_by_sol_[msg.sol] = {msg.gimbal_m[0], msg.gimbal_m[1], msg.gimbal_m[2]};
  if (!rig_source_) {
    rig_source_ = msg;
    rig_source_->left.jpeg.clear();
    rig_source_->right.jpeg.clear();
  }
  pair_of_sequence_[msg.sequence] = msg.pair_id;
  pairs_.emplace(msg.pair_id, std::move(pair));
}

void StreamCollector::rejectPair(const stereo_pair_t& pair, const std::string& cause) {
  reject(cause);
  pair_rejections_.push_back("Pair " + std::to_string(pair.pair_id) + " (sequence " +
                             std::to_string(pair.sequence) + ", " + pair.left.stem +
                             ") was rejected: " + cause + "; it is missing from every product.");
}

bool StreamCollector::roverFinished() const {
  // The rover's heartbeat repeats FINISHED after a panorama: it ends this one only after a RUNNING status.
  const bool finished_status =
      rover_running_seen_ && rover_status_ && rover_status_->state == rover_status_t::STATE_FINISHED;
  // On a traverse the rover publishes its site poses after the final EO and before that FINISHED status (one
  // outbox, in order): the site ends with the status, so that the last site's pose is not left unread.
  if (traverse_) return finished_status;
  return (rover_eo_ && rover_eo_->is_final) || finished_status;
}

std::vector<const ReceivedPair*> StreamCollector::pairs() const {
  std::vector<const ReceivedPair*> out;
  for (const auto& [id, pair] : pairs_) out.push_back(&pair);
  return out;
}

StreamCounts StreamCollector::counts() const {
  StreamCounts c;
  c.pairs = static_cast<int32_t>(pairs_.size());
  const std::vector<int64_t> missing = pair_sequences_.missing();
  c.gaps = static_cast<int32_t>(missing.size());
  c.duplicates = pair_sequences_.duplicates() + duplicate_pair_ids_;
  c.reordered = pair_sequences_.reordered();
  c.rejected = rejected_;
  c.end_of_panorama = end_of_panorama_;
  c.pairs_planned = pairs_planned_;
  for (int64_t s : missing) {
    c.warnings.push_back("Camera stream message " + std::to_string(s) + " (" + channels::kStereoPair +
                         ") was never received (" + sequenceNeighbours(pair_of_sequence_, s) +
                         "): that pair is missing from every product.");
  }
  for (const std::string& w : pair_rejections_) c.warnings.push_back(w);
  if (!end_of_panorama_) {
    c.warnings.push_back(
        "The end-of-panorama marker was not received; products are made from the pairs that came.");
  }
  if (pairs_planned_ >= 0 && c.pairs < pairs_planned_) {
    c.warnings.push_back("The panorama plans " + std::to_string(pairs_planned_) + " pairs; " +
                         std::to_string(c.pairs) + " were received intact.");
  }
  for (const auto& [cause, count] : rejected_) {
    c.warnings.push_back(std::to_string(count) + " message(s) rejected: " + cause + ".");
  }
  return c;
}

std::vector<std::string> StreamCollector::roverWarnings() const {
  std::vector<std::string> out;
  for (const auto& [channel, tracker] : rover_sequences_) {
    const std::size_t lost = tracker.missing().size();
    if (lost > 0) {
      out.push_back(std::to_string(lost) + " message(s) of " + channel +
                    " from the rover were never received.");
    }
  }
  return out;
}

Dataset StreamCollector::writeDataset(const std::string& dir) const {
  std::filesystem::create_directories(dir + "/images");
  std::filesystem::create_directories(dir + "/models");
  Dataset d;
  d.root = dir;
  d.name = panorama_.empty() ? "stream" : panorama_;
  auto writeSide = [&](const ReceivedImage& image) {
    const std::string rel = "images/" + image.stem + ".png";
    raster::writePng(dir + "/" + rel, image.pixels);
    const std::string model_rel = "models/" + image.stem + ".cahvor";
    io::writeCameraModelFile(dir + "/" + model_rel, image.model);
    return makeImageRef(dir, rel, model_rel);
  };
  for (const auto& [id, pair] : pairs_) {
    Pair p;
    p.id = id;
    p.sol = pair.sol;
    p.tier = pair.tier;
    p.left = writeSide(pair.left);
    if (pair.right) p.right = writeSide(*pair.right);
    if (d.width == 0) {
      d.width = pair.left.pixels.cols;
      d.height = pair.left.pixels.rows;
    }
    d.pairs.push_back(p);
  }
  if (rig_source_) {
    const stereo_pair_t& r = *rig_source_;
    for (const auto& [sol, g] : gimbal_by_sol_) d.rig.gimbal_m[sol] = Eigen::Vector3d(g[0], g[1], g[2]);
    if (r.offsets_given) {
      d.rig.left_offset_m = Eigen::Vector3d(r.left_offset_m[0], r.left_offset_m[1], r.left_offset_m[2]);
      d.rig.right_offset_m = Eigen::Vector3d(r.right_offset_m[0], r.right_offset_m[1], r.right_offset_m[2]);
    }
    if (r.base_given) d.rig.base_m = Eigen::Vector3d(r.base_m[0], r.base_m[1], r.base_m[2]);
    if (r.sigmas_given) {
      d.rig.sigma_gimbal_m = r.sigma_gimbal_m;
      d.rig.sigma_base_m = r.sigma_base_m;
    }
  }
  areomap::writeDataset(d, dir);
  // What readDataset adds to a dataset that gives its name, size, pair ids and models: the rig notes.
  noteRigDefaults(d);
  return d;
}

}  // namespace areomap::ground
