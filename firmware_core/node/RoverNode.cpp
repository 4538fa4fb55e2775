#include "firmware_core/node/RoverNode.hpp"

#include <cmath>
#include <cstdio>
#include <cstring>

#include "firmware_core/adjust/RigShape.hpp"
#include "firmware_core/camera/Binning.hpp"
#include "msgs/MessageCheck.hpp"

namespace areomap {
namespace {

int32_t stageIndex(RoverStage stage) {
  return static_cast<int32_t>(stage);
}

Vec3 vec(const double v[3]) {
  return Vec3(v[0], v[1], v[2]);
}

}  // namespace

void RoverNode::start(platform::Transport& out, platform::JpegCodec& codec, const platform::Clock& clock,
                      const RoverOptions& options) {
  out_ = &out;
  codec_ = &codec;
  clock_ = &clock;
  options_ = options;
  prepareStereoPair(in_);
  // Outgoing messages: vectors at full size once (encode() uses the count fields, not the sizes).
  tiepoints_.panorama.reserve(kMaxMessageStringChars + 1);
  tiepoints_.image_stems.resize(kMaxImages);
  for (std::string& s : tiepoints_.image_stems) s.reserve(kMaxMessageStringChars + 1);
  tiepoints_.point_id.resize(kMaxTiePointsPerMessage);
  tiepoints_.image_index.resize(kMaxTiePointsPerMessage);
  tiepoints_.sample_px.resize(kMaxTiePointsPerMessage);
  tiepoints_.line_px.resize(kMaxTiePointsPerMessage);
  tiepoints_.kind.resize(kMaxTiePointsPerMessage);
  dem_.panorama.reserve(kMaxMessageStringChars + 1);
  dem_.elevation_m.resize(static_cast<std::size_t>(kCoarseDemCells) * kCoarseDemCells);
  eo_.panorama.reserve(kMaxMessageStringChars + 1);
  eo_.images.resize(kMaxImages);
  for (eo_entry_t& e : eo_.images) e.stem.reserve(kMaxMessageStringChars + 1);
  status_.last_error.reserve(sizeof(last_error_));
  prepareSite(site_in_);
  for (std::string* text : {&site_pose_.traverse, &site_pose_.site_id, &site_pose_.panorama})
    text->reserve(kMaxMessageStringChars + 1);
  traverse_.reset();
  site_panorama_[0] = '\0';
  ended_panorama_[0] = '\0';
  site_announced_ = false;
  last_site_announced_ = false;
  counters_ = RoverCounters{};
  sequence_count_ = 0;
  sequence_head_ = 0;
  highest_sequence_ = -1;
  last_error_[0] = '\0';
  resetPanorama();
}

int64_t RoverNode::staticBytes() const {
  return static_cast<int64_t>(sizeof(RoverNode)) + extra_static_bytes_;
}

double RoverNode::now() const {
  return static_cast<double>(clock_->monotonicUtime()) * 1e-6;
}

void RoverNode::resetPanorama() {
  matcher_.reset();
  matcher_.planForPairs(kMaxPairs);
  network_builder_.reset();
  net_.clear();
  sol_count_ = 0;
  counters_.fido_model = false;
  workspace_full_ = false;
  panorama_open_ = false;
  panorama_[0] = '\0';
  counters_.finished = false;
}

void RoverNode::reject(Status cause, int64_t sequence, int32_t pair_id, const char* what) {
  const int32_t c = static_cast<int32_t>(cause);
  if (c > 0 && c < static_cast<int32_t>(Status::kCount)) counters_.rejected_by_cause[c] += 1;
  counters_.pairs_rejected += 1;
  std::snprintf(last_error_, sizeof(last_error_), "sequence %lld pair %d: %s: %s",
                static_cast<long long>(sequence), static_cast<int>(pair_id), statusName(cause), what);
  if (options_.log_to_stderr) std::fprintf(stderr, "areomap-rover: %s\n", last_error_);
}

bool RoverNode::trackSequence(int64_t sequence) {
  const int32_t tracked = sequence_count_;
  for (int32_t i = 0; i < tracked; ++i) {
    if (sequences_[i] == sequence) {
      counters_.duplicates += 1;
      std::snprintf(last_error_, sizeof(last_error_), "sequence %lld: duplicate, dropped",
                    static_cast<long long>(sequence));
      if (options_.log_to_stderr) std::fprintf(stderr, "areomap-rover: %s\n", last_error_);
      return false;
    }
  }
  sequences_[sequence_head_] = sequence;
  sequence_head_ = (sequence_head_ + 1) % kMaxTrackedSequences;
  if (sequence_count_ < kMaxTrackedSequences) sequence_count_ += 1;
  if (sequence > highest_sequence_ + 1) {
    const int64_t missing = sequence - highest_sequence_ - 1;
    // A corrupt sequence number may jump by up to 2^63: the count saturates instead of overflowing.
    const int64_t room = INT32_MAX - static_cast<int64_t>(counters_.sequence_gaps);
    counters_.sequence_gaps += static_cast<int32_t>(missing < room ? missing : room);
    int32_t len = std::snprintf(last_error_, sizeof(last_error_),
                                "sequence gap: %lld missing:", static_cast<long long>(missing));
    for (int64_t k = 0; k < missing && k < kMaxNamedGapSequences && len > 0 &&
                        len < static_cast<int32_t>(sizeof(last_error_));
         ++k) {
      len += std::snprintf(last_error_ + len, sizeof(last_error_) - static_cast<std::size_t>(len), " %lld",
                           static_cast<long long>(highest_sequence_ + 1 + k));
    }
    if (options_.log_to_stderr) std::fprintf(stderr, "areomap-rover: %s\n", last_error_);
    highest_sequence_ = sequence;
  } else if (sequence <= highest_sequence_) {
    // Below the highest seen and not seen before: it was counted as a gap when the later one came.
    counters_.reordered += 1;
    if (counters_.sequence_gaps > 0) counters_.sequence_gaps -= 1;
    if (options_.log_to_stderr)
      std::fprintf(stderr, "areomap-rover: sequence %lld arrived out of order, processed\n",
                   static_cast<long long>(sequence));
  } else {
    highest_sequence_ = sequence;
  }
  return true;
}

void RoverNode::handleStereoPair(const uint8_t* data, std::size_t size) {
  counters_.pairs_seen += 1;
  const double t0 = now();
  Status s = msgs::checkEncoding(stereo_pair_t::getTypeName(),
                                 static_cast<uint64_t>(stereo_pair_t::getHash()), data, size);
  if (s == Status::kCorruptData && size >= 8 &&
      encodedFingerprint(data, size) != static_cast<uint64_t>(stereo_pair_t::getHash())) {
    // Another message type on this channel (a well-formed one or not): its own cause.
    const uint64_t print = encodedFingerprint(data, size);
    const bool known = print == static_cast<uint64_t>(tiepoints_t::getHash()) ||
                       print == static_cast<uint64_t>(eo_solution_t::getHash()) ||
                       print == static_cast<uint64_t>(coarse_dem_t::getHash()) ||
                       print == static_cast<uint64_t>(rover_status_t::getHash()) ||
                       print == static_cast<uint64_t>(site_pose_t::getHash());
    rejectAndPublish(Status::kUnsupported, -1, -1,
                     known ? "another areomap message type on the stereo-pair channel"
                           : "not a stereo_pair_t (unknown fingerprint)");
    return;
  }
  if (!ok(s)) {
    rejectAndPublish(s, -1, -1, "message does not decode");
    return;
  }
  const char* field = "";
  s = checkStereoPairCapacity(data, size, field);
  if (!ok(s)) {
    rejectAndPublish(s, -1, -1, field);
    return;
  }
  s = msgs::decodeMessage(data, size, in_);
  if (!ok(s)) {
    rejectAndPublish(s, -1, -1, "message does not decode");
    return;
  }
  counters_.stage_seconds[stageIndex(RoverStage::kDecode)] += now() - t0;
  if (counters_.finished && in_.sequence == 0) {
    // After an end-of-panorama marker, sequence 0 starts a new stream (the same log replayed, or the next
    // panorama of a restarted sender): not a duplicate.
    sequence_count_ = 0;
    sequence_head_ = 0;
    highest_sequence_ = -1;
  }
  if (in_.sequence < 0) {
    rejectAndPublish(Status::kInvalidArgument, in_.sequence, in_.pair_id, "negative sequence number");
    return;
  }
  if (!trackSequence(in_.sequence)) {
    publishStatus();
    return;
  }
  if (in_.kind == stereo_pair_t::KIND_END_OF_PANORAMA) {
    counters_.end_markers += 1;
    copyText(in_.panorama.c_str(), ended_panorama_, sizeof(ended_panorama_));
    finishPanorama();
    return;
  }
  if (in_.kind != stereo_pair_t::KIND_PAIR) {
    rejectAndPublish(Status::kInvalidArgument, in_.sequence, in_.pair_id, "kind");
    return;
  }
  processPair(in_.sequence);
}

void RoverNode::handleSite(const uint8_t* data, std::size_t size) {
  const char* field = "";
  const Status s = data == nullptr ? Status::kInvalidArgument : decodeSite(data, size, site_in_, field);
  if (!ok(s)) {
    const int32_t c = static_cast<int32_t>(s);
    if (c > 0 && c < static_cast<int32_t>(Status::kCount)) counters_.rejected_by_cause[c] += 1;
    counters_.sites_rejected += 1;
    std::snprintf(last_error_, sizeof(last_error_), "site announcement: %s: %s", statusName(s), field);
    if (options_.log_to_stderr) std::fprintf(stderr, "areomap-rover: %s\n", last_error_);
    publishStatus();
    return;
  }
  counters_.sites_announced += 1;
  copyText(site_in_.panorama.c_str(), site_panorama_, sizeof(site_panorama_));
  site_announced_ = true;
  last_site_announced_ = site_in_.is_last;
  traverse_.announce(site_in_);
  if (options_.log_to_stderr) {
    std::fprintf(stderr, "areomap-rover: site %s (%d/%d), panorama %s%s\n", site_in_.site_id.c_str(),
                 static_cast<int>(site_in_.site_index + 1), static_cast<int>(site_in_.sites_planned),
                 site_panorama_, site_in_.is_last ? ", the last" : "");
  }
}

bool RoverNode::endOfRun() const {
  if (!counters_.finished) return false;
  if (!site_announced_) return true;
  return last_site_announced_ && std::strcmp(ended_panorama_, site_panorama_) == 0;
}

Status RoverNode::decodeSide(const stereo_image_t& side, int32_t bin, uint8_t* pixels, int32_t& width,
                             int32_t& height) {
  if (side.jpeg_bytes <= 0) return Status::kMissingField;
  int32_t full_w = 0, full_h = 0;
  const Status s = codec_->decodeGrayBinned(side.jpeg.data(), static_cast<std::size_t>(side.jpeg_bytes), bin,
                                            pixels, static_cast<std::size_t>(kMaxImagePixels), full_w, full_h);
  if (!ok(s)) return s;
  if (full_w != side.width_px || full_h != side.height_px) return Status::kCorruptData;
  width = full_w / bin;
  height = full_h / bin;
  if (width > kMaxImageWidth || height > kMaxImageHeight) return Status::kCapacityExceeded;
  return Status::kOk;
}

void RoverNode::rejectAndPublish(Status cause, int64_t sequence, int32_t pair_id, const char* what) {
  reject(cause, sequence, pair_id, what);
  publishStatus();
}

void RoverNode::processPair(int64_t sequence) {
  const int32_t pair_id = in_.pair_id;
  openPanorama();
  if (!workspaceHasRoom(sequence, pair_id)) return;
  CameraModel models[2];
  if (!readModels(sequence, pair_id, models) || !rigValuesFinite(sequence, pair_id) ||
      !imageSizesFit(sequence, pair_id)) {
    return;
  }
  int32_t w[2] = {0, 0}, h[2] = {0, 0};
  if (!decodeImages(sequence, pair_id, w, h)) return;
  // The matcher and the network work in the binned pixel frame.
  models[0] = binnedModel(models[0], binning_);
  models[1] = binnedModel(models[1], binning_);
  int32_t sol_index = -1;
  if (!findSol(sequence, pair_id, sol_index)) return;
  int32_t first_observation = 0;
  if (!matchPair(sequence, pair_id, models, w, h, first_observation)) return;
  double t = now();
  if (!enterNetwork(sequence, pair_id, sol_index, models)) return;
  setRigFromMessage(sol_index);
  counters_.stage_seconds[stageIndex(RoverStage::kAdjust)] += now() - t;
  keepForTraverse(w[0], h[0]);
  counters_.pairs_accepted += 1;
  // Incremental adjustment, warm-started from the previous solution.
  t = now();
  (void)adjustNow(false);
  counters_.stage_seconds[stageIndex(RoverStage::kAdjust)] += now() - t;
  t = now();
  publishTiePoints(pair_id, first_observation);
  publishDem(pair_id);
  publishEo(pair_id, false);
  publishStatus();
  counters_.stage_seconds[stageIndex(RoverStage::kPublish)] += now() - t;
}

// A pair after the end-of-panorama marker starts a new panorama; a panorama's first pair names it and starts
// its clock.
void RoverNode::openPanorama() {
  if (counters_.finished) resetPanorama();
  if (panorama_open_) return;
  panorama_open_ = true;
  panorama_start_s_ = now();
  copyText(in_.panorama.c_str(), panorama_, sizeof(panorama_));
}

bool RoverNode::workspaceHasRoom(int64_t sequence, int32_t pair_id) {
  if (matcher_.pairCount() >= kMaxPairs) {
    rejectAndPublish(Status::kCapacityExceeded, sequence, pair_id,
                     "workspace full: more pairs than kMaxPairs (panorama kept)");
    return false;
  }
  if (workspace_full_ || matcher_.points().size() >= kMaxTiePoints ||
      matcher_.observations().size() + 2 > kMaxObservations) {
    workspace_full_ = true;
    rejectAndPublish(Status::kCapacityExceeded, sequence, pair_id,
                     "workspace full: tie points or observations at capacity (panorama kept)");
    return false;
  }
  return true;
}

bool RoverNode::readModels(int64_t sequence, int32_t pair_id, CameraModel models[2]) {
  const char* field = "";
  Status s = toCameraModel(in_.left.model, models[0], field);
  if (ok(s) && in_.has_right) s = toCameraModel(in_.right.model, models[1], field);
  if (ok(s)) return true;
  char what[96];
  std::snprintf(what, sizeof(what), "a-priori model, component %s", field);
  rejectAndPublish(s, sequence, pair_id, what);
  return false;
}

bool RoverNode::rigValuesFinite(int64_t sequence, int32_t pair_id) {
  const double rig[] = {in_.gimbal_m[0],       in_.gimbal_m[1],       in_.gimbal_m[2],
                        in_.left_offset_m[0],  in_.left_offset_m[1],  in_.left_offset_m[2],
                        in_.right_offset_m[0], in_.right_offset_m[1], in_.right_offset_m[2],
                        in_.base_m[0],         in_.base_m[1],         in_.base_m[2],
                        in_.sigma_gimbal_m,    in_.sigma_base_m};
  for (double v : rig) {
    if (!std::isfinite(v)) {
      rejectAndPublish(Status::kNotFinite, sequence, pair_id, "rig values");
      return false;
    }
  }
  return true;
}

// Sizes read from the message, checked before anything is decoded into the fixed buffers; the pair's
// binning factor: the largest of its images' (one factor for both, so that their templates match).
bool RoverNode::imageSizesFit(int64_t sequence, int32_t pair_id) {
  binning_ = 1;
  for (int32_t side = 0; side < (in_.has_right ? 2 : 1); ++side) {
    const stereo_image_t& image = side == 0 ? in_.left : in_.right;
    const char* field = "";
    const Status s = checkImageSizes(image, field);
    if (!ok(s)) {
      char what[192];
      if (s == Status::kCapacityExceeded) {
        std::snprintf(what, sizeof(what),
                      "%s image: %s: %dx%d is beyond binning by %d into the rover's %dx%d capacity (refused)",
                      side == 0 ? "left" : "right", field, static_cast<int>(image.width_px),
                      static_cast<int>(image.height_px), static_cast<int>(kMaxBinning),
                      static_cast<int>(kMaxImageWidth), static_cast<int>(kMaxImageHeight));
      } else {
        std::snprintf(what, sizeof(what), "%s image: %s", side == 0 ? "left" : "right", field);
      }
      rejectAndPublish(s, sequence, pair_id, what);
      return false;
    }
    const int32_t b = binningFactor(image.width_px, image.height_px);
    if (b > binning_) binning_ = b;
  }
  return true;
}

bool RoverNode::decodeImages(int64_t sequence, int32_t pair_id, int32_t w[2], int32_t h[2]) {
  const double t = now();
  Status s = decodeSide(in_.left, binning_, left_pixels_, w[0], h[0]);
  if (ok(s) && in_.has_right) s = decodeSide(in_.right, binning_, right_pixels_, w[1], h[1]);
  counters_.stage_seconds[stageIndex(RoverStage::kDecode)] += now() - t;
  if (ok(s) && binning_ > 1) {
    counters_.pairs_binned += 1;
    if (options_.log_to_stderr) {
      std::fprintf(stderr, "areomap-rover: pair %d: %dx%d frames binned %dx%d to %dx%d (capacity %dx%d)\n",
                   static_cast<int>(pair_id), static_cast<int>(in_.left.width_px),
                   static_cast<int>(in_.left.height_px), static_cast<int>(binning_), static_cast<int>(binning_),
                   static_cast<int>(w[0]), static_cast<int>(h[0]), static_cast<int>(kMaxImageWidth),
                   static_cast<int>(kMaxImageHeight));
    }
  }
  if (ok(s)) return true;
  rejectAndPublish(s, sequence, pair_id, "JPEG image");
  return false;
}

// The rig's index of the pair's sol: a new one for a sol not seen before in this panorama.
bool RoverNode::findSol(int64_t sequence, int32_t pair_id, int32_t& sol_index) {
  sol_index = -1;
  for (int32_t i = 0; i < sol_count_; ++i) {
    if (sols_[i] == in_.sol) sol_index = i;
  }
  if (sol_index >= 0) return true;
  if (sol_count_ >= kMaxSols) {
    rejectAndPublish(Status::kCapacityExceeded, sequence, pair_id, "more sols than kMaxSols");
    return false;
  }
  sol_index = sol_count_;
  sols_[sol_count_++] = in_.sol;
  return true;
}

// Tie points and coarse DEM: one matcher call, so STAGE_MATCH holds Förstner, NCC, the coarse DEM and the
// inter-stereo ties together (STAGE_FEATURES and STAGE_DEM stay 0); STAGE_ADJUST holds the network update
// and the adjustment. `first_observation`: the pair's first observation in the matcher's list.
bool RoverNode::matchPair(int64_t sequence, int32_t pair_id, const CameraModel models[2], const int32_t w[2],
                          const int32_t h[2], int32_t& first_observation) {
  const double t = now();
  const ImageView left{left_pixels_, w[0], h[0], w[0]};
  const ImageView right{right_pixels_, w[1], h[1], w[1]};
  PairTieReport report;
  first_observation = matcher_.observations().size();
  // The tie budget, planned once per panorama for the pair count the stream announces (as areomap-ties).
  if (matcher_.pairCount() == 0) matcher_.planForPairs(plannedPairs(in_.pairs_planned));
  const Status s = matcher_.addPair(left, in_.has_right ? &right : nullptr, models[0],
                                    in_.has_right ? &models[1] : nullptr, coarse_dem_, report);
  const double match_s = now() - t;
  counters_.stage_seconds[stageIndex(RoverStage::kMatch)] += match_s;
  if (s == Status::kInvalidArgument || s == Status::kCapacityExceeded) {
    rejectAndPublish(s, sequence, pair_id, "rejected by the matcher");
    return false;
  }
  const int32_t matcher_pair = matcher_.pairCount() - 1;
  copyText(in_.left.stem.c_str(), stem_of_matcher_image_[2 * matcher_pair], kMaxMessageStringChars + 1);
  copyText(in_.has_right ? in_.right.stem.c_str() : "", stem_of_matcher_image_[2 * matcher_pair + 1],
           kMaxMessageStringChars + 1);
  binning_of_matcher_image_[2 * matcher_pair] = binning_;
  binning_of_matcher_image_[2 * matcher_pair + 1] = binning_;
  if (report.overflow > 0 && (matcher_.points().size() + 1 >= kMaxTiePoints ||
                              matcher_.observations().size() + 2 > kMaxObservations)) {
    // The matcher's lists ran full inside this pair: its ties are incomplete, so it stays out of the
    // network, and so does every later pair of this panorama (the network keeps what it has).
    workspace_full_ = true;
    char what[128];
    std::snprintf(
        what, sizeof(what),
        "workspace full: %d ties did not fit (%d points, %d observations); pair kept out, panorama kept",
        static_cast<int>(report.overflow), static_cast<int>(matcher_.points().size()),
        static_cast<int>(matcher_.observations().size()));
    rejectAndPublish(Status::kCapacityExceeded, sequence, pair_id, what);
    return false;
  }
  if (s == Status::kNoTexture) {
    // The matcher keeps the pair (no ties); the adjustment cannot resect it, so it stays out of the network.
    counters_.no_texture_pairs += 1;
    rejectAndPublish(s, sequence, pair_id, "no tie point in this pair (kept out of the adjustment)");
    return false;
  }
  return true;
}

// Network: the cameras, new points and observations of the matcher's last pair; the rig comes from the
// message (setRigFromMessage).
bool RoverNode::enterNetwork(int64_t sequence, int32_t pair_id, int32_t sol_index,
                             const CameraModel models[2]) {
  int32_t failed = 0;
  const Status s = network_builder_.syncPair(
      matcher_.ties(), sol_index, in_.tier < 0 ? 0 : (in_.tier >= kMaxTiers ? kMaxTiers - 1 : in_.tier),
      models[0], in_.has_right ? &models[1] : nullptr, net_, failed);
  if (!ok(s)) {
    rejectAndPublish(s, sequence, pair_id, "cannot enter the adjustment network");
    return false;
  }
  const int32_t matcher_pair = matcher_.pairCount() - 1;
  for (int32_t side = 0; side < 2; ++side) {
    const int32_t image = network_builder_.networkImage(2 * matcher_pair + side);
    if (image < 0) continue;
    copyText(stem_of_matcher_image_[2 * matcher_pair + side], stem_of_image_[image],
             kMaxMessageStringChars + 1);
    pair_id_of_image_[image] = pair_id;
    const stereo_image_t& sent = side == 0 ? in_.left : in_.right;
    binning_of_image_[image] = binning_;
    full_size_of_image_[image][0] = sent.width_px;
    full_size_of_image_[image][1] = sent.height_px;
  }
  return true;
}

// The pair's left image kept for the cross-site matching when it belongs to the announced site.
void RoverNode::keepForTraverse(int32_t width, int32_t height) {
  if (!site_announced_ || std::strcmp(panorama_, site_panorama_) != 0) return;
  const int32_t image = network_builder_.networkImage(2 * (matcher_.pairCount() - 1));
  if (image < 0) return;
  const ImageView left{left_pixels_, width, height, width};
  traverse_.keepImage(left, image, network_builder_.model(image), network_builder_.camera(image));
}

void RoverNode::setRigFromMessage(int32_t sol_index) {
  RigConstraints& rigc = net_.rig;
  rigc.gimbal_m[sol_index] = vec(in_.gimbal_m);
  rigc.gimbal_set[sol_index] = true;
  rigc.left_offset_m = vec(in_.left_offset_m);
  rigc.right_offset_m = vec(in_.right_offset_m);
  if (in_.has_right) {
    rigc.base_m = vec(in_.base_m);
    rigc.use_base = true;
  }
  // Sigmas the dataset did not give are held (Network.hpp): the adjuster tightens them from the packer's
  // starting value until the constraints hold to kRigMisfitBound_m. The stream has one flag for both.
  rigc.sigma_gimbal_m = in_.sigma_gimbal_m;
  rigc.sigma_base_m = in_.sigma_base_m;
  rigc.hold_gimbal = !in_.sigmas_given;
  rigc.hold_base = !in_.sigmas_given;
}

// The rig model by the rule of RigShape.hpp on the a-priori cameras the network has: Eq. 3 with the
// message's values, or the FIDO model fitted to them when they do not turn about one point (a first tier
// alone fits Eq. 3; a later one may show that the axes do not meet). Said once per panorama on stderr.
void RoverNode::chooseRigModel() {
  const RigShape shape = checkRigShape(net_);
  RigConstraints& rig = net_.rig;
  counters_.rig_fit_rms_m = shape.fit_rms_m;
  if (shape.one_point) {
    rig.use_gimbal = true;
    rig.use_tilt_arm = rig.use_spin_centre = rig.use_lr_distance = false;
    counters_.fido_model = false;
    return;
  }
  (void)fitFidoRig(net_);
  useFidoModel(net_);
  if (!counters_.fido_model && options_.log_to_stderr) {
    std::fprintf(stderr,
                 "areomap-rover: %s: Eq. 3 misses the a-priori cameras by %.2f mm RMS (one point: at most "
                 "%.2f mm): FIDO model (%s, stereo base)\n",
                 panorama_, shape.fit_rms_m * 1000.0, shape.threshold_m * 1000.0,
                 rig.use_tilt_arm ? "Eq. 3 with the tilt arm" : "distances");
  }
  counters_.fido_model = true;
}

Status RoverNode::adjustNow(bool final_solve) {
  chooseRigModel();
  // Incremental: new points (and points that gained rays) are triangulated with the current EO, the solve
  // warm-starts from the previous solution. Final: the batch solve of the whole network from the a-priori
  // EO, rejections cleared, every point re-triangulated (the computation of areomap-ties --adjust). A final
  // solve warm-started from the incremental solution was measured to stop in another local minimum (tiny:
  // weighted cost 648.74 vs 646.04, EO 0.0057 px apart, each a stationary point for all three methods).
  if (final_solve) net_.resetToApriori();
  int32_t failed = 0;
  (void)net_.triangulateAll(failed);
  FastAdjustResult result;
  const Status s = adjuster_.adjust(net_, options_.adjust, result);
  counters_.adjustments += 1;
  counters_.last_sweeps = result.sweeps_total;
  counters_.last_rms_px = result.rms_px;
  eo_.sweeps = result.sweeps_total;
  eo_.iterations = result.sweeps_total;
  eo_.rms_px = result.rms_px;
  eo_.sigma0 = result.sigma0;
  eo_.stop_rule = result.stop_rule == StopRule::kMaxSweeps ? eo_solution_t::STOP_MAX_SWEEPS
                  : ok(s)                                  ? eo_solution_t::STOP_CONVERGED
                                                           : eo_solution_t::STOP_DIVERGED;
  if (!ok(s)) {
    counters_.adjust_failures += 1;
    std::snprintf(last_error_, sizeof(last_error_), "adjustment after %d pairs: %s",
                  static_cast<int>(net_.pairCount()), statusName(s));
    if (options_.log_to_stderr) std::fprintf(stderr, "areomap-rover: %s\n", last_error_);
  }
  return s;
}

void RoverNode::finishPanorama() {
  if (net_.pairCount() == 0) {
    std::snprintf(last_error_, sizeof(last_error_), "end of panorama without any accepted pair");
    if (options_.log_to_stderr) std::fprintf(stderr, "areomap-rover: %s\n", last_error_);
    counters_.finished = true;
    finishTraverseSite(false);
    publishStatus();
    return;
  }
  const double t = now();
  (void)adjustNow(true);
  counters_.stage_seconds[stageIndex(RoverStage::kAdjust)] += now() - t;
  counters_.finished = true;
  counters_.panorama_seconds = now() - panorama_start_s_;
  publishEo(-1, true);
  finishTraverseSite(true);
  publishStatus();
}

void RoverNode::finishTraverseSite(bool mapped) {
  if (!site_announced_ || std::strcmp(ended_panorama_, site_panorama_) != 0) return;
  const double t = now();
  const Status s = mapped ? traverse_.finishSite(&net_, &network_builder_) : traverse_.finishSite(nullptr, nullptr);
  counters_.traverse_seconds += now() - t;
  const RoverLegReport& leg = traverse_.lastLeg();
  if (options_.log_to_stderr && leg.candidates_a > 0) {
    char text[384];
    describeLeg(leg, text, static_cast<int32_t>(sizeof(text)));
    std::fprintf(stderr, "areomap-rover: site %s: %s\n", site_in_.site_id.c_str(), text);
  }
  if (!ok(s)) {
    std::snprintf(last_error_, sizeof(last_error_), "site %s: %s: not in the site-pose adjustment",
                  site_in_.site_id.c_str(), statusName(s));
    if (options_.log_to_stderr) std::fprintf(stderr, "areomap-rover: %s\n", last_error_);
    if (traverse_.siteCount() == 0) return;
  }
  publishSitePoses();
}

}  // namespace areomap
