#include "ground/pack/Pack.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <set>

#include <lcm/eventlog.h>
#include <opencv2/core.hpp>

#include "areomap/rover_status_t.hpp"
#include "areomap/site_t.hpp"
#include "areomap/stereo_pair_t.hpp"
#include "firmware_core/adjust/Network.hpp"
#include "firmware_core/camera/CameraConversion.hpp"
#include "ground/cli/Cli.hpp"
#include "ground/io/Panorama.hpp"
#include "ground/ties/TieAdjust.hpp"
#include "msgs/Channels.hpp"
#include "msgs/MessageCheck.hpp"
#include "msgs/adapters/MessageAdapters.hpp"
#include "platform/posix/TurboJpegCodec.hpp"

namespace areomap {
namespace {

template <class Message>
std::vector<uint8_t> encodeMessage(const Message& m) {
  std::vector<uint8_t> bytes(static_cast<std::size_t>(m.getEncodedSize()));
  const int used = m.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  if (used < 0) throw std::runtime_error("LCM encode failed");
  bytes.resize(static_cast<std::size_t>(used));
  return bytes;
}

void put3(const Vec3& v, double out[3]) {
  for (int k = 0; k < 3; ++k) out[k] = v[k];
}

struct Encoder {
  platform::TurboJpegCodec codec;
  Encoder() {
    if (!ok(codec.open())) throw std::runtime_error("TurboJPEG does not start");
  }
  std::vector<uint8_t> encode(const cv::Mat& grey, int quality, const std::string& file) {
    std::vector<uint8_t> out(codec.maxEncodedBytes(grey.cols, grey.rows));
    std::size_t bytes = 0;
    const cv::Mat c = grey.isContinuous() ? grey : grey.clone();
    const Status s =
        codec.encodeGray(c.ptr<uint8_t>(0), c.cols, c.rows, quality, out.data(), out.size(), bytes);
    if (!ok(s)) throw cli::InputError(file, "image", std::string("JPEG encoding failed: ") + statusName(s));
    out.resize(bytes);
    return out;
  }
};

void fillSide(stereo_image_t& out, const ImageRef& ref, const io::PanoramaImage& d, Encoder& enc,
              int quality) {
  out.stem = ref.stem;
  out.width_px = d.grey.cols;
  out.height_px = d.grey.rows;
  out.jpeg = enc.encode(d.grey, quality, ref.image_path);
  out.jpeg_bytes = static_cast<int32_t>(out.jpeg.size());
  toMessage(d.model, out.model);
}

int sequenceArg(const std::string& item, const std::string& value) {
  try {
    std::size_t used = 0;
    const int v = std::stoi(value, &used);
    if (used != value.size() || v < 0) throw std::invalid_argument("");
    return v;
  } catch (const std::exception&) {
    throw cli::UsageError("--inject: '" + item + "' needs a sequence number >= 0");
  }
}

bool decodePair(const LogEvent& e, stereo_pair_t& pair) {
  return e.channel == channels::kStereoPair && ok(msgs::decodeMessage(e.data.data(), e.data.size(), pair));
}

bool decodeSiteEvent(const LogEvent& e, site_t& site) {
  return e.channel == channels::kSite && ok(msgs::decodeMessage(e.data.data(), e.data.size(), site));
}

constexpr double kDegPerRad = 180.0 / M_PI;

// The first event's utime: the given one, or now.
int64_t startUtime(const PackOptions& options) {
  if (options.start_utime != 0) return options.start_utime;
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

site_t siteMessage(const Traverse& traverse, std::size_t k, const std::string& panorama) {
  const TraverseSite& site = traverse.sites[k];
  site_t m{};
  m.sequence = static_cast<int64_t>(k);
  m.traverse = traverse.name;
  m.site_id = site.id;
  m.site_index = static_cast<int32_t>(k);
  m.sites_planned = static_cast<int32_t>(traverse.sites.size());
  m.panorama = panorama;
  m.kind = site.kind == SiteKind::kStop ? site_t::KIND_STOP : site_t::KIND_PANORAMA;
  put3(site.apriori.position_m, m.position_m);
  m.heading_deg = site.apriori.heading_rad * kDegPerRad;
  m.has_odometry = site.odometry.has_value();
  if (site.odometry) {
    const OdometryLeg& leg = *site.odometry;
    m.odometry_from = leg.from;
    put3(leg.delta_m, m.delta_m);
    m.delta_heading_deg = leg.delta_heading_rad * kDegPerRad;
    m.distance_m = leg.distance_m;
    put3(leg.sigma_m, m.sigma_m);
    m.sigma_heading_deg = leg.sigma_heading_rad * kDegPerRad;
  }
  m.is_last = k + 1 == traverse.sites.size();
  return m;
}

}  // namespace

std::vector<LogEvent> packDataset(const Dataset& dataset, const PackOptions& options, PackSummary* summary) {
  if (options.quality < 1 || options.quality > 100) throw cli::UsageError("--quality must be 1..100");
  if (!(options.interval_s >= 0.0)) throw cli::UsageError("--interval-s must be >= 0");
  Encoder encoder;
  // Load every pair first: the rig is estimated from all a-priori models (as areomap-ties does).
  std::vector<io::PanoramaImage> left(dataset.pairs.size()), right(dataset.pairs.size());
  auto net = std::make_unique<Network>();
  std::vector<int> sol_of_index;
  cli::Progress progress("pack: reading", dataset.pairs.size());
  for (std::size_t k = 0; k < dataset.pairs.size(); ++k) {
    const Pair& p = dataset.pairs[k];
    left[k] = io::loadPanoramaImage(p.left);
    if (p.right) right[k] = io::loadPanoramaImage(*p.right);
    auto it = std::find(sol_of_index.begin(), sol_of_index.end(), p.sol);
    if (it == sol_of_index.end()) {
      if (static_cast<int>(sol_of_index.size()) >= kMaxSols)
        throw cli::InputError(dataset.root + "/panorama.json", "pairs[" + std::to_string(k) + "].sol",
                              "more than " + std::to_string(kMaxSols) + " sols");
      sol_of_index.push_back(p.sol);
      it = sol_of_index.end() - 1;
    }
    PhotogrammetricCamera cams[2];
    ConversionResidual residual;
    const ImageRef* refs[2] = {&p.left, p.right ? &*p.right : nullptr};
    for (int side = 0; side < (p.right ? 2 : 1); ++side) {
      const Status s =
          cahvorToPhotogrammetric(side == 0 ? left[k].model : right[k].model, cams[side], residual);
      if (!ok(s))
        throw cli::InputError(
            refs[side]->model_path.empty() ? refs[side]->image_path : refs[side]->model_path, "model",
            std::string("no photogrammetric form: ") + statusName(s));
    }
    int32_t pair_index = -1;
    const int tier = std::max(0, std::min(kMaxTiers - 1, p.tier));
    if (!ok(net->addPair(static_cast<int32_t>(it - sol_of_index.begin()), tier, cams[0].io,
                         cams[0].eo.centre_m, cams[0].m, p.right ? &cams[1].io : nullptr, cams[1].eo.centre_m,
                         cams[1].m, pair_index)))
      throw cli::InputError(dataset.root + "/panorama.json", "pairs", "more pairs than the rover's capacity");
    progress.step();
  }
  progress.done();
  std::vector<std::string> notes;
  setRigConstraints(dataset, sol_of_index, *net, notes);
  const bool offsets_given = dataset.rig.left_offset_m.has_value();

  const int64_t start = startUtime(options);
  const int64_t step = static_cast<int64_t>(std::llround(options.interval_s * 1e6));
  std::vector<LogEvent> events;
  PackSummary sum;
  cli::Progress encoding("pack: encoding", dataset.pairs.size());
  for (std::size_t k = 0; k <= dataset.pairs.size(); ++k) {
    stereo_pair_t m{};
    m.utime = start + static_cast<int64_t>(k) * step;
    m.sequence = static_cast<int64_t>(k);
    m.panorama = dataset.name;
    m.pairs_planned = static_cast<int32_t>(dataset.pairs.size());
    m.kind = stereo_pair_t::KIND_END_OF_PANORAMA;
    m.pair_id = -1;
    m.has_right = false;
    m.left.jpeg_bytes = 0;
    m.right.jpeg_bytes = 0;
    if (k < dataset.pairs.size()) {
      const Pair& p = dataset.pairs[k];
      m.kind = stereo_pair_t::KIND_PAIR;
      m.pair_id = p.id;
      m.sol = p.sol;
      m.tier = p.tier;
      m.has_right = p.right.has_value();
      fillSide(m.left, p.left, left[k], encoder, options.quality);
      if (p.right) fillSide(m.right, *p.right, right[k], encoder, options.quality);
      const int sol_index =
          static_cast<int>(std::find(sol_of_index.begin(), sol_of_index.end(), p.sol) - sol_of_index.begin());
      put3(net->rig.gimbal_m[sol_index], m.gimbal_m);
      put3(net->rig.left_offset_m, m.left_offset_m);
      put3(net->rig.right_offset_m, m.right_offset_m);
      put3(net->rig.base_m, m.base_m);
      m.sigma_gimbal_m = net->rig.sigma_gimbal_m;
      m.sigma_base_m = net->rig.sigma_base_m;
      m.gimbal_given = offsets_given && dataset.rig.gimbal_m.count(p.sol) > 0;
      m.offsets_given = offsets_given;
      m.base_given = dataset.rig.base_m.has_value();
      m.sigmas_given = dataset.rig.sigma_gimbal_m.has_value() && dataset.rig.sigma_base_m.has_value();
      sum.jpeg_bytes += m.left.jpeg_bytes + m.right.jpeg_bytes;
      encoding.step();
    }
    events.push_back(LogEvent{channels::kStereoPair, m.utime, encodeMessage(m)});
  }
  encoding.done();
  sum.pairs = static_cast<int>(dataset.pairs.size());
  sum.notes = notes;
  if (summary != nullptr) *summary = sum;
  return events;
}

std::vector<std::string> traversePanoramaNames(const Traverse& traverse, bool* qualified) {
  std::vector<std::string> names;
  std::set<std::string> seen;
  bool qualify = false;
  for (const TraverseSite& site : traverse.sites) {
    const std::string name = readDataset(site.dir).name;
    qualify = qualify || name.empty() || !seen.insert(name).second;
    names.push_back(name);
  }
  if (qualify) {
    for (std::size_t k = 0; k < names.size(); ++k) names[k] = traverse.name + "/" + traverse.sites[k].id;
  }
  if (qualified != nullptr) *qualified = qualify;
  return names;
}

std::vector<LogEvent> packTraverse(const Traverse& traverse, const PackOptions& options,
                                   PackSummary* summary) {
  bool qualified = false;
  const std::vector<std::string> names = traversePanoramaNames(traverse, &qualified);
  const int64_t start = startUtime(options);
  const int64_t step = static_cast<int64_t>(std::llround(options.interval_s * 1e6));
  std::vector<LogEvent> events;
  PackSummary sum;
  if (qualified) {
    sum.notes.push_back(
        "sites share a panorama name (or have none): each site's pairs are named "
        "\"<traverse>/<site id>\" (\"" +
        names.front() + "\", ...)");
  }
  int64_t utime = start;
  for (std::size_t k = 0; k < traverse.sites.size(); ++k) {
    const TraverseSite& site = traverse.sites[k];
    cli::info("pack: site " + std::to_string(k + 1) + "/" + std::to_string(traverse.sites.size()) + ": " +
              site.id + " (panorama " + names[k] + ")");
    Dataset dataset = readDataset(site.dir);
    dataset.name = names[k];
    site_t announcement = siteMessage(traverse, k, names[k]);
    announcement.utime = utime;
    events.push_back(LogEvent{channels::kSite, utime, encodeMessage(announcement)});
    PackOptions site_options = options;
    site_options.start_utime = utime + step;
    PackSummary site_summary;
    std::vector<LogEvent> site_events = packDataset(dataset, site_options, &site_summary);
    utime = site_events.back().utime + step;
    for (LogEvent& e : site_events) events.push_back(std::move(e));
    sum.pairs += site_summary.pairs;
    sum.jpeg_bytes += site_summary.jpeg_bytes;
    for (const std::string& n : site_summary.notes) sum.notes.push_back(site.id + ": " + n);
  }
  if (summary != nullptr) *summary = sum;
  return events;
}

std::vector<LogEvent> injectFaults(const std::vector<LogEvent>& events, const std::string& spec) {
  std::vector<LogEvent> out = events;
  auto find_site = [&](int seq) -> std::size_t {
    for (std::size_t i = 0; i < out.size(); ++i) {
      site_t m;
      if (decodeSiteEvent(out[i], m) && m.sequence == seq) return i;
    }
    throw cli::UsageError("--inject: no site announcement with sequence " + std::to_string(seq) +
                          " in the stream");
  };
  auto find = [&](int seq) -> std::size_t {
    for (std::size_t i = 0; i < out.size(); ++i) {
      stereo_pair_t p;
      if (decodePair(out[i], p) && p.sequence == seq) return i;
    }
    throw cli::UsageError("--inject: no pair with sequence " + std::to_string(seq) + " in the stream");
  };
  auto reencode = [&](std::size_t i, const stereo_pair_t& p) { out[i].data = encodeMessage(p); };
  std::size_t begin = 0;
  while (begin <= spec.size()) {
    std::size_t end = spec.find(',', begin);
    if (end == std::string::npos) end = spec.size();
    const std::string item = spec.substr(begin, end - begin);
    begin = end + 1;
    if (item.empty()) continue;
    const std::size_t colon = item.find(':');
    const std::string name = item.substr(0, colon);
    const std::string value = colon == std::string::npos ? "" : item.substr(colon + 1);
    const int64_t base_utime = out.empty() ? 0 : out.back().utime;
    if (name == "unknown-channel") {
      out.insert(out.begin() + static_cast<long>(out.size() / 2),
                 LogEvent{"AREOMAP_UNKNOWN", base_utime, {1, 2, 3, 4}});
    } else if (name == "wrong-type") {
      rover_status_t s{};
      s.last_error = "injected wrong type";
      out.insert(out.begin() + static_cast<long>(out.size() / 2),
                 LogEvent{channels::kStereoPair, base_utime, encodeMessage(s)});
    } else if (name == "drop-site" || name == "dup-site" || name == "truncate-site") {
      const std::size_t i = find_site(sequenceArg(item, value));
      if (name == "drop-site") {
        out.erase(out.begin() + static_cast<long>(i));
      } else if (name == "truncate-site") {
        out[i].data.resize(out[i].data.size() / 2);
      } else {
        // A second announcement of the site as a new message (the next sequence; later ones renumbered),
        // not a repeated one (a repeat is a duplicate by its sequence alone).
        for (std::size_t j = i + 1; j < out.size(); ++j) {
          site_t later;
          if (!decodeSiteEvent(out[j], later)) continue;
          later.sequence += 1;
          out[j].data = encodeMessage(later);
        }
        site_t m;
        (void)decodeSiteEvent(out[i], m);
        m.sequence += 1;
        LogEvent again = out[i];
        again.data = encodeMessage(m);
        out.insert(out.begin() + static_cast<long>(i) + 1, again);
      }
    } else {
      const int seq = sequenceArg(item, value);
      const std::size_t i = find(seq);
      stereo_pair_t p;
      (void)decodePair(out[i], p);
      if (name == "drop") {
        out.erase(out.begin() + static_cast<long>(i));
      } else if (name == "dup") {
        out.insert(out.begin() + static_cast<long>(i) + 1, out[i]);
      } else if (name == "swap") {
        const std::size_t j = find(seq + 1);
        std::swap(out[i].data, out[j].data);
      } else if (name == "truncate") {
        out[i].data.resize(out[i].data.size() / 2);
      } else if (name == "corrupt-jpeg") {
        // The frame header (SOF0..SOF2) gets sample precision 3 and height 0: no decoder accepts it.
        bool done = false;
        for (std::size_t b = 2; !done && b + 8 < p.left.jpeg.size(); ++b) {
          if (p.left.jpeg[b] == 0xFF && p.left.jpeg[b + 1] >= 0xC0 && p.left.jpeg[b + 1] <= 0xC2) {
            p.left.jpeg[b + 4] = 3;
            p.left.jpeg[b + 5] = 0;
            p.left.jpeg[b + 6] = 0;
            done = true;
          }
        }
        if (!done) throw cli::UsageError("--inject: pair " + value + " has no JPEG frame header to corrupt");
        reencode(i, p);
      } else if (name == "oversize") {
        Encoder enc;
        // One column wider than the rover can bin into its capacity (a frame within kMaxBinning of the
        // capacity is mapped binned, not refused); a model of the same size, so the size is the only fault.
        cv::Mat big(16, kMaxBinnedSourceWidth + 1, CV_8U);
        cv::randu(big, 0, 255);
        p.left.jpeg = enc.encode(big, 90, "oversize");
        p.left.jpeg_bytes = static_cast<int32_t>(p.left.jpeg.size());
        p.left.width_px = big.cols;
        p.left.height_px = big.rows;
        p.left.model.width_px = big.cols;
        p.left.model.height_px = big.rows;
        reencode(i, p);
      } else if (name == "nan-model") {
        p.left.model.a[0] = std::numeric_limits<double>::quiet_NaN();
        reencode(i, p);
      } else {
        throw cli::UsageError("--inject: unknown fault '" + name + "'");
      }
    }
  }
  return out;
}

void writeEventLog(const std::string& path, const std::vector<LogEvent>& events) {
  lcm_eventlog_t* log = lcm_eventlog_create(path.c_str(), "w");
  if (log == nullptr) throw cli::InputError(path, "--out", "cannot create the log file");
  int64_t n = 0;
  for (const LogEvent& e : events) {
    lcm_eventlog_event_t ev{};
    ev.eventnum = n++;
    ev.timestamp = e.utime;
    ev.channellen = static_cast<int32_t>(e.channel.size());
    ev.datalen = static_cast<int32_t>(e.data.size());
    ev.channel = const_cast<char*>(e.channel.c_str());
    ev.data = const_cast<uint8_t*>(e.data.data());
    if (lcm_eventlog_write_event(log, &ev) != 0) {
      lcm_eventlog_destroy(log);
      throw cli::InputError(path, "--out", "write failed (disk full?)");
    }
  }
  lcm_eventlog_destroy(log);
}

}  // namespace areomap
