// RoverNode's publications: the tie points, the coarse DEM and the EO solution of the pair just processed,
// and the status, each encoded into the fixed output buffer and handed to the output Transport. The
// messages' vectors and strings were sized by start(), so filling them makes no heap allocation.
#include "firmware_core/node/RoverNode.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "firmware_core/camera/Binning.hpp"
#include "firmware_core/camera/CameraConversion.hpp"
#include "firmware_core/camera/Photogrammetric.hpp"
#include "msgs/Channels.hpp"

namespace areomap {
namespace {

void setString(std::string& s, const char* text) {
  // Within the capacity reserved at start-up: assign() of a shorter text reuses the buffer.
  std::size_t n = std::strlen(text);
  if (n > static_cast<std::size_t>(kMaxMessageStringChars))
    n = static_cast<std::size_t>(kMaxMessageStringChars);
  s.assign(text, n);
}

}  // namespace

template <class Message>
void RoverNode::publishMessage(const char* channel, Message& message) {
  const int size = message.getEncodedSize();
  if (size <= 0 || static_cast<std::size_t>(size) > kMaxOutgoingBytes ||
      message.encode(out_buffer_, 0, static_cast<int>(kMaxOutgoingBytes)) != size ||
      !ok(out_->publish(channel, out_buffer_, static_cast<std::size_t>(size)))) {
    counters_.publish_failures += 1;
  }
}

void RoverNode::publishTiePoints(int32_t pair_id, int32_t first_observation) {
  tiepoints_.utime = clock_->wallUtime();
  tiepoints_.sequence = seq_tiepoints_++;
  setString(tiepoints_.panorama, panorama_);
  tiepoints_.pair_id = pair_id;
  const int32_t images = 2 * matcher_.pairCount();
  tiepoints_.num_images = images;
  for (int32_t i = 0; i < images; ++i)
    setString(tiepoints_.image_stems[static_cast<std::size_t>(i)], stem_of_matcher_image_[i]);
  const auto& obs = matcher_.observations();
  int32_t n = 0;
  for (int32_t i = first_observation; i < obs.size(); ++i) {
    if (n >= kMaxTiePointsPerMessage) {
      counters_.tie_overflow += 1;
      continue;
    }
    const auto k = static_cast<std::size_t>(n++);
    tiepoints_.point_id[k] = obs[i].point;
    tiepoints_.image_index[k] = static_cast<int16_t>(obs[i].image);
    // In the pixel frame of the image as sent (the matcher's is binned when the frame was).
    const int32_t b = binning_of_matcher_image_[obs[i].image];
    tiepoints_.sample_px[k] = fullResolutionPx(obs[i].sample_px, b);
    tiepoints_.line_px[k] = fullResolutionPx(obs[i].line_px, b);
    tiepoints_.kind[k] = obs[i].kind == TieKind::kIntra ? tiepoints_t::KIND_INTRA : tiepoints_t::KIND_INTER;
  }
  tiepoints_.num_observations = n;
  publishMessage(channels::kTiePoints, tiepoints_);
}

void RoverNode::publishDem(int32_t pair_id) {
  const CoarseDem& dem = coarse_dem_;
  dem_.utime = clock_->wallUtime();
  dem_.sequence = seq_dem_++;
  setString(dem_.panorama, panorama_);
  dem_.pair_id = pair_id;
  const int32_t n = CoarseDem::cells();
  const Vec3 origin = dem.origin();
  // The DEM's grid: row index along +X (north), column along +Y (east) from the outer corner `origin`;
  // the message is north-up, so its row 0 is the DEM's last row.
  dem_.cell_m = CoarseDem::cellSize();
  dem_.east0_m = origin.y();
  dem_.north0_m = origin.x() + n * CoarseDem::cellSize();
  dem_.cols = n;
  dem_.rows = n;
  dem_.nodata_m = -32768.0f;
  dem_.num_points = dem.pointCount();
  dem_.num_cells = n * n;
  for (int32_t r = 0; r < n; ++r) {
    for (int32_t c = 0; c < n; ++c) {
      double z = 0.0;
      const bool has = dem.cellValue(n - 1 - r, c, z);
      dem_.elevation_m[static_cast<std::size_t>(r * n + c)] = has ? static_cast<float>(-z) : dem_.nodata_m;
    }
  }
  publishMessage(channels::kCoarseDem, dem_);
}

void RoverNode::publishEo(int32_t pair_id, bool final_solution) {
  eo_.utime = clock_->wallUtime();
  eo_.sequence = seq_eo_++;
  setString(eo_.panorama, panorama_);
  eo_.last_pair_id = pair_id;
  eo_.num_images = net_.imageCount();
  eo_.is_final = final_solution;
  for (int32_t i = 0; i < net_.imageCount(); ++i) {
    const NetImage& im = net_.image(i);
    eo_entry_t& e = eo_.images[static_cast<std::size_t>(i)];
    setString(e.stem, stem_of_image_[i]);
    e.pair_id = pair_id_of_image_[i];
    e.side = im.side == Side::kLeft ? eo_entry_t::SIDE_LEFT : eo_entry_t::SIDE_RIGHT;
    for (int32_t k = 0; k < 3; ++k) {
      e.center_m[k] = im.centre_m[k];
      e.sigma_center_m[k] = im.sigma[k];
      e.sigma_angles_rad[k] = im.sigma[3 + k];
    }
    opkFromRotation(im.m, e.omega_rad, e.phi_rad, e.kappa_rad);
    // The adjusted model in the pixel frame of the image as sent (rigid moves commute with binning).
    toMessage(unbinnedModel(adjustedModel(network_builder_.model(i), im.m_apriori, im.m, im.centre_m),
                            binning_of_image_[i], full_size_of_image_[i][0], full_size_of_image_[i][1]),
              e.model);
  }
  publishMessage(channels::kEoSolution, eo_);
}

void RoverNode::publishStatus() {
  status_.utime = clock_->wallUtime();
  status_.sequence = seq_status_++;
  status_.state = counters_.finished ? rover_status_t::STATE_FINISHED
                  : panorama_open_   ? rover_status_t::STATE_RUNNING
                                     : rover_status_t::STATE_STARTING;
  status_.pairs_seen = counters_.pairs_seen;
  status_.pairs_accepted = counters_.pairs_accepted;
  status_.pairs_rejected = counters_.pairs_rejected;
  status_.pairs_binned = counters_.pairs_binned;
  for (int32_t i = 0; i < rover_status_t::NUM_CAUSES; ++i) {
    status_.rejected_by_cause[i] =
        i < static_cast<int32_t>(Status::kCount) ? counters_.rejected_by_cause[i] : 0;
  }
  status_.sequence_gaps = counters_.sequence_gaps;
  status_.duplicates = counters_.duplicates;
  status_.reordered = counters_.reordered;
  for (int32_t i = 0; i < rover_status_t::NUM_STAGES; ++i)
    status_.stage_seconds[i] = counters_.stage_seconds[i];
  status_.sweeps = counters_.last_sweeps;
  status_.rms_px = counters_.last_rms_px;
  status_.heap_allocs_after_init = heap_pipeline_;
  status_.static_bytes = memoryBytes();  // static and start-up reserve: the figure the budget covers
  std::size_t n = std::strlen(last_error_);
  status_.last_error.assign(last_error_, n);
  publishMessage(channels::kRoverStatus, status_);
}

void RoverNode::publishSitePoses() {
  for (int32_t k = traverse_.firstPublished(); k < traverse_.siteCount(); ++k) {
    const RoverSiteRecord& rec = traverse_.site(k);
    site_pose_t& m = site_pose_;
    m.utime = clock_->wallUtime();
    m.sequence = seq_site_pose_++;
    setString(m.traverse, traverse_.traverseName());
    setString(m.site_id, rec.site_id);
    setString(m.panorama, rec.panorama);
    m.site_index = rec.site_index;
    m.latest_site_index = traverse_.site(traverse_.siteCount() - 1).site_index;
    for (int32_t i = 0; i < 3; ++i) {
      m.position_m[i] = rec.pose.position_m[i];
      m.sigma_position_m[i] = std::sqrt(std::max(0.0, rec.covariance(i, i)));
      m.sigma_rotation_rad[i] = std::sqrt(std::max(0.0, rec.covariance(3 + i, 3 + i)));
      for (int32_t j = 0; j < 3; ++j) m.rotation[3 * i + j] = rec.pose.rotation(i, j);
    }
    for (int32_t i = 0; i < 6; ++i) {
      for (int32_t j = 0; j < 6; ++j) m.covariance[6 * i + j] = rec.covariance(i, j);
    }
    m.heading_deg = headingDegOf(rec.pose.rotation);
    m.status = rec.status;
    m.tie_observations = rec.tie_observations;
    m.registration = rec.registration;
    m.distance_m = rec.distance_m;
    m.window_sites = traverse_.counters().last_window_sites;
    m.iterations = traverse_.counters().last_iterations;
    m.sigma0 = traverse_.counters().last_sigma0;
    publishMessage(channels::kSitePose, m);
    counters_.site_poses_published += 1;
  }
}

void RoverNode::heartbeat() {
  publishStatus();
}

}  // namespace areomap
