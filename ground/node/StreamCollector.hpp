// The ground node's receiving side: the camera stream (AREOMAP_STEREO_PAIR) and the rover's results
// (AREOMAP_TIEPOINTS, AREOMAP_EO_SOLUTION, AREOMAP_COARSE_DEM, AREOMAP_ROVER_STATUS) as raw bytes from any
// platform::Transport. Every message is checked before it is decoded (msgs/MessageCheck.hpp); a message
// that does not decode, a JPEG that does not decode, an image larger than the rover can map (beyond
// kMaxBinning x its capacity: kMaxBinnedSourceWidth x kMaxBinnedSourceHeight; frames above the capacity
// but within that are kept at full resolution, as sent) or a bad model is counted under its cause and
// dropped, and the stream goes on ("no silent loss").
//
// Sequence numbers (per channel): a message whose sequence was already seen is a duplicate (dropped); one
// that arrives after a later one is `reordered` (kept); the sequences never seen between 0 and the last one
// are the gaps, each named in the warnings with the pairs on either side.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "areomap/eo_solution_t.hpp"
#include "areomap/rover_status_t.hpp"
#include "areomap/site_pose_t.hpp"
#include "areomap/site_t.hpp"
#include "areomap/stereo_pair_t.hpp"
#include "firmware_core/camera/CameraModel.hpp"
#include "ground/dataset/Dataset.hpp"
#include "ground/dataset/TruthFiles.hpp"
#include "ground/io/Panorama.hpp"
#include "ground/pass/PassInputs.hpp"

namespace areomap::ground {

struct ReceivedImage {
  std::string stem;
  cv::Mat pixels;  // 8-bit grey, full resolution as sent
  CameraModel model;
};

struct ReceivedPair {
  int64_t sequence = 0;
  int32_t pair_id = 0;
  int32_t sol = 0;
  int32_t tier = 0;
  ReceivedImage left;
  std::optional<ReceivedImage> right;
};

// Sequence bookkeeping of one channel.
class SequenceTracker {
 public:
  enum class Arrival { kInOrder, kReordered, kDuplicate };
  Arrival record(int64_t sequence);
  std::vector<int64_t> missing() const;  // never seen in [floor, highest]
  // The next panorama of a sender whose numbering goes on (the rover's channels): forget what was seen,
  // count from highest + 1; an older sequence arriving later is a duplicate.
  void restartAfterHighest();
  // For a sender that was running before this node listened (the rover): the first sequence seen starts
  // the count (the earlier ones are not gaps).
  void countFromFirstSeen() { from_first_seen_ = true; }
  int32_t duplicates() const { return duplicates_; }
  int32_t reordered() const { return reordered_; }
  int64_t highest() const { return highest_; }

 private:
  std::set<int64_t> seen_;
  int64_t highest_ = -1;
  int64_t floor_ = 0;
  bool from_first_seen_ = false;
  bool any_seen_ = false;
  int32_t duplicates_ = 0;
  int32_t reordered_ = 0;
};

// A traverse over the stream (areomap-ground --traverse): the site announcements (AREOMAP_SITE) over the
// whole run, and what was refused. report.json of the traverse: `stream`.
struct SiteStreamCounts {
  int32_t sites_announced = 0;
  int32_t site_duplicates = 0;              // an announcement's sequence seen before (dropped)
  std::map<std::string, int32_t> rejected;  // cause -> count: site_<status> (does not decode or fails
                                            // checkSite), site_duplicate (a site id or panorama announced
                                            // before), site_unknown (another traverse, or an index
                                            // beyond it), pair_unannounced_panorama (a pair or end marker
                                            // whose panorama no site announced)
  std::vector<std::string> warnings;        // one sentence per refusal
};

class StreamCollector {
 public:
  StreamCollector();

  // Traverse mode: AREOMAP_SITE announcements are collected (and kept over panoramas); a camera-stream
  // message whose panorama no site announced is rejected (pair_unannounced_panorama) before its sequence
  // is counted; a pair of another announced panorama before this one's end marker ends this one (the
  // marker was lost: a warning) and starts the next.
  void setTraverse(bool traverse) { traverse_ = traverse; }
  // Accepted announcements in arrival order.
  const std::vector<site_t>& sites() const { return sites_; }
  // The announcement whose panorama is `panorama`, nullptr when none.
  const site_t* siteOfPanorama(const std::string& panorama) const;
  const SiteStreamCounts& siteCounts() const { return site_counts_; }

  // A platform::MessageHandler: pass the collector as the context.
  static void onMessage(void* context, const char* channel, const uint8_t* data, std::size_t size);
  // After the end-of-panorama marker, camera-stream messages belong to the next panorama: they are kept
  // aside (raw) and handed to it by nextPanorama().
  void receive(const std::string& channel, const uint8_t* data, std::size_t size);

  bool endOfPanorama() const { return end_of_panorama_; }
  // A final EO solution (not on a traverse), or a FINISHED status after a RUNNING one, arrived.
  bool roverFinished() const;
  // Ready for the next panorama (after its products are made): the camera stream's numbering starts
  // again at 0; the rover's channels go on from where they were; the traverse's sites and the rover's site
  // poses are kept (the rover publishes a site's pose only while the site is in its window); everything
  // else is forgotten.
  void nextPanorama();
  // The kept pairs' images and models, moved out of the collector, as the loaded panorama of `written`
  // (writeDataset's, in its pair order): the pass uses what arrived, not a re-read of the files it wrote.
  io::Panorama takePanorama(Dataset written);
  int64_t messagesReceived() const { return messages_; }
  const std::string& panorama() const { return panorama_; }

  // Pairs kept, by pair id.
  std::vector<const ReceivedPair*> pairs() const;
  StreamCounts counts() const;

  // The rover's results (latest by sequence).
  const std::optional<eo_solution_t>& roverEo() const { return rover_eo_; }
  const std::optional<rover_status_t>& roverStatus() const { return rover_status_; }
  // The rover's own site poses (AREOMAP_SITE_POSE): the latest message of each site, by site id, over every
  // panorama so far.
  const std::map<std::string, site_pose_t>& roverSitePoses() const { return rover_site_poses_; }
  int32_t roverTiePointMessages() const { return rover_tie_messages_; }
  int32_t roverTieObservations() const { return rover_tie_observations_; }
  int32_t roverDemMessages() const { return rover_dem_messages_; }
  // Every tie observation the rover sent (image = stem; kind "intra"/"inter"), in arrival order.
  const std::vector<ImageObservation>& roverTies() const { return rover_ties_; }
  // The pairs the rover's AREOMAP_TIEPOINTS messages came for, and how many of those messages were lost.
  const std::set<int32_t>& roverTiePairs() const { return rover_tie_pairs_; }
  int32_t roverTieMessagesMissing() const;
  std::vector<std::string> roverWarnings() const;

  // Writes the kept pairs as a dataset folder (DIR/images/<stem>.png, DIR/models/<stem>.cahvor,
  // DIR/panorama.json with the rig values the stream marks as given), the record of what arrived, and
  // returns that dataset as readDataset would read it (made in memory, not read back).
  Dataset writeDataset(const std::string& dir) const;

 private:
  void reject(const std::string& cause) { ++rejected_[cause]; }
  void rejectPair(const stereo_pair_t& pair, const std::string& cause);
  void receivePair(const uint8_t* data, std::size_t size);
  void receiveSite(const uint8_t* data, std::size_t size);
  void rejectSite(const std::string& cause, const std::string& sentence);
  // The rejection cause, "" when decoded.
  std::string decodeImage(const stereo_image_t& side, ReceivedImage& out);

  std::map<int32_t, ReceivedPair> pairs_;
  std::map<std::string, int32_t> rejected_;
  std::vector<std::string> pair_rejections_;  // sentences naming the pair and the cause
  SequenceTracker pair_sequences_;
  std::map<int64_t, int32_t> pair_of_sequence_;
  std::map<std::string, SequenceTracker> rover_sequences_;
  int32_t duplicate_pair_ids_ = 0;
  bool end_of_panorama_ = false;
  int32_t pairs_planned_ = -1;
  int64_t messages_ = 0;
  std::string panorama_;
  std::optional<stereo_pair_t> rig_source_;  // the first kept pair (rig values), images cleared
  std::optional<eo_solution_t> rover_eo_;
  std::optional<rover_status_t> rover_status_;
  std::map<std::string, site_pose_t> rover_site_poses_;
  int32_t rover_tie_messages_ = 0;
  int32_t rover_tie_observations_ = 0;
  int32_t rover_dem_messages_ = 0;
  std::vector<ImageObservation> rover_ties_;
  std::set<int32_t> rover_tie_pairs_;
  std::vector<std::vector<uint8_t>> next_panorama_;  // camera-stream messages after the end marker
  bool rover_running_seen_ = false;
  std::map<int32_t, std::vector<double>> gimbal_by_sol_;
  // Traverse mode (kept over panoramas by nextPanorama).
  bool traverse_ = false;
  std::vector<site_t> sites_;
  SequenceTracker site_sequences_;
  SiteStreamCounts site_counts_;
};

}  // namespace areomap::ground
