#include "ground/ingest/Ingest.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <tuple>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "ground/cli/AtomicFile.hpp"
#include "ground/cli/Cli.hpp"
#include "ground/ingest/Pairing.hpp"
#include "ground/ingest/SiteFrame.hpp"
#include "ground/io/GdalLabel.hpp"
#include "ground/io/ImageFile.hpp"

namespace areomap::ingest {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

struct Position {
  io::Mission mission;
  int site;
  int drive;
  bool operator<(const Position& o) const {
    return std::tie(mission, site, drive) < std::tie(o.mission, o.site, o.drive);
  }
};

struct ReadyPair {
  int left = -1, right = -1;
  CameraModel left_site, right_site;  // the models in the site frame
  double elevation_deg = 0.0;         // the left axis's elevation in the file's (rover) frame
  double clock = 0.0;
};

// The 8-bit grey pixels of a frame (Ingest.hpp).
cv::Mat pixels(const Frame& f) {
  switch (f.camera.format) {
    case io::CameraFileFormat::kPds3:
      return io::readPds3Image8(io::readPds3ImageInfo(f.source));
    case io::CameraFileFormat::kVicar:
    case io::CameraFileFormat::kPds4:
      return io::readGdalImage8(f.source);
    default:
      break;
  }
  if (io::isPds3File(f.image_path)) return io::loadImage8(f.image_path);
  const cv::Mat decoded = cv::imread(f.image_path, cv::IMREAD_UNCHANGED);
  if (decoded.empty()) throw cli::InputError(f.image_path, "image", "cannot decode (PNG, JPEG, PGM, TIFF)");
  return io::toGrey8(decoded);
}

// The frame's pixels, checked against its model's image size.
cv::Mat eyePixels(const Frame& f, const CameraModel& site_model) {
  const cv::Mat grey = pixels(f);
  if (grey.cols != site_model.width || grey.rows != site_model.height) {
    throw cli::InputError(f.image_path, "image",
                          "is " + std::to_string(grey.cols) + "x" + std::to_string(grey.rows) +
                              ", the model's image " + std::to_string(site_model.width) + "x" +
                              std::to_string(site_model.height));
  }
  return grey;
}

void writeEye(const Frame& f, const cv::Mat& grey, const CameraModel& site_model, const std::string& folder) {
  fs::create_directories(folder + "/images");
  fs::create_directories(folder + "/models");
  const std::string image = folder + "/images/" + f.stem + ".png";
  const std::string partial = image + ".partial.png";
  if (!cv::imwrite(partial, grey)) throw cli::InputError(image, "image", "cannot write");
  fs::rename(partial, image);
  io::writeCameraModelFile(folder + "/models/" + f.stem + ".cahvor", site_model);
}

json eyeJson(const Frame& f) {
  return json{{"image", "images/" + f.stem + ".png"},
              {"model", "models/" + f.stem + ".cahvor"},
              {"source", f.source},
              {"product_id", f.camera.acquisition.product_id}};
}

// Tiers by elevation (Ingest.hpp).
void assignTiers(const std::vector<ReadyPair>& pairs, std::vector<int>& tier) {
  std::vector<std::size_t> order(pairs.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return pairs[a].elevation_deg > pairs[b].elevation_deg;
  });
  tier.assign(pairs.size(), 0);
  int t = 0;
  for (std::size_t k = 0; k < order.size(); ++k) {
    if (k > 0 && pairs[order[k - 1]].elevation_deg - pairs[order[k]].elevation_deg > kTierGapDeg) ++t;
    tier[order[k]] = t;
  }
}

// Writes the dataset of one position; a pair whose pixels cannot be read is left out (in `skipped`, as an
// error) and the others written. No pair written: no panorama.json, out.pairs empty.
IngestedDataset writeDataset(const std::vector<Frame>& frames, std::vector<ReadyPair>& pairs,
                             const Position& where, const std::string& out_dir,
                             std::vector<Skipped>& skipped) {
  std::sort(pairs.begin(), pairs.end(), [&](const ReadyPair& a, const ReadyPair& b) {
    return std::tie(a.clock, frames[static_cast<std::size_t>(a.left)].source) <
           std::tie(b.clock, frames[static_cast<std::size_t>(b.left)].source);
  });
  int first_sol = -1;
  for (const ReadyPair& p : pairs) {
    const std::optional<int>& sol = frames[static_cast<std::size_t>(p.left)].camera.acquisition.sol;
    if (sol && (first_sol < 0 || *sol < first_sol)) first_sol = *sol;
  }
  IngestedDataset out;
  out.name = datasetName(where.mission, std::max(first_sol, 0), where.site, where.drive);
  out.folder = out.name;
  const std::string folder = out_dir + "/" + out.folder;
  std::vector<int> tier;
  assignTiers(pairs, tier);
  json list = json::array();
  int width = -1, height = -1;
  bool one_size = true;
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    const ReadyPair& p = pairs[k];
    const Frame& l = frames[static_cast<std::size_t>(p.left)];
    const Frame& r = frames[static_cast<std::size_t>(p.right)];
    const int id = static_cast<int>(out.pairs.size());
    cli::info(out.name + ": pair " + std::to_string(id) + " " + l.stem + " + " + r.stem);
    try {
      const cv::Mat left = eyePixels(l, p.left_site), right = eyePixels(r, p.right_site);
      writeEye(l, left, p.left_site, folder);
      writeEye(r, right, p.right_site, folder);
    } catch (const cli::InputError& e) {
      cli::warn(e.what());
      const std::string bad = e.file();
      for (const Frame* f : {&l, &r}) {
        const bool this_one = bad == f->image_path || bad == f->source;
        skipped.push_back(
            {f->source,
             this_one ? e.what() : "its partner's image could not be read: " + std::string(e.what()), true});
      }
      continue;
    }
    for (const CameraModel* m : {&p.left_site, &p.right_site}) {
      if (width < 0) width = m->width, height = m->height;
      one_size = one_size && m->width == width && m->height == height;
    }
    list.push_back(json{{"id", id},
                        {"sol", l.camera.acquisition.sol.value_or(0)},
                        {"tier", tier[k]},
                        {"left", eyeJson(l)},
                        {"right", eyeJson(r)}});
    out.pairs.push_back(
        {id, {l.camera.acquisition.product_id, l.source}, {r.camera.acquisition.product_id, r.source}});
  }
  json panorama{{"name", out.name},
                {"mission", io::missionName(where.mission)},
                {"site", where.site},
                {"drive", where.drive},
                {"frame", "SITE_FRAME (+X north, +Y east, +Z down, metres)"},
                {"pairs", list}};
  if (one_size && width > 0) panorama["image_size"] = json::array({width, height});
  if (out.pairs.empty()) return out;
  cli::writeFileAtomic(folder + "/panorama.json", panorama.dump(2) + "\n");
  return out;
}

}  // namespace

std::string datasetName(io::Mission mission, int sol, int site, int drive) {
  std::string m = io::missionName(mission);
  std::transform(m.begin(), m.end(), m.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (m.empty()) m = "rover";
  char buffer[96];
  std::snprintf(buffer, sizeof buffer, "%s_sol%04d_site%03d_drive%04d", m.c_str(), sol, site, drive);
  return buffer;
}

IngestResult makeDatasets(const std::vector<std::string>& inputs, const std::string& out_dir) {
  IngestResult result;
  FrameScan scan = scanInputs(inputs);
  result.skipped = scan.skipped;
  const std::vector<Frame>& frames = scan.frames;
  const Pairing pairing = pairFrames(frames);
  cli::info(std::to_string(frames.size()) + " frames read, " + std::to_string(pairing.pairs.size()) +
            " stereo pairs");
  for (std::size_t k = 0; k < pairing.unpaired.size(); ++k) {
    result.skipped.push_back(
        {frames[static_cast<std::size_t>(pairing.unpaired[k])].source, pairing.unpaired_reason[k], false});
  }
  std::map<Position, std::vector<ReadyPair>> groups;
  for (const StereoPair& sp : pairing.pairs) {
    const Frame& l = frames[static_cast<std::size_t>(sp.left)];
    const Frame& r = frames[static_cast<std::size_t>(sp.right)];
    const io::Acquisition& a = l.camera.acquisition;
    auto skipBoth = [&](const std::string& why) {
      result.skipped.push_back({l.source, why, false});
      result.skipped.push_back({r.source, why, false});
    };
    if (!a.site || !a.drive) {
      skipBoth("the record or label gives no rover position (site, drive) to group the pair by");
      continue;
    }
    ReadyPair p;
    p.left = sp.left;
    p.right = sp.right;
    std::string why;
    if (!modelInSiteFrame(l.camera, p.left_site, why) || !modelInSiteFrame(r.camera, p.right_site, why)) {
      skipBoth(why);
      continue;
    }
    p.elevation_deg = std::asin(std::clamp(-l.camera.model.a.z(), -1.0, 1.0)) * 180.0 / M_PI;
    p.clock = a.sclk_s.value_or(0.0);
    groups[Position{a.mission, *a.site, *a.drive}].push_back(p);
  }
  fs::create_directories(out_dir);
  for (auto& [where, pairs] : groups) {
    try {
      IngestedDataset written = writeDataset(frames, pairs, where, out_dir, result.skipped);
      if (written.pairs.empty()) continue;
      result.datasets.push_back(std::move(written));
      cli::info("wrote " + out_dir + "/" + result.datasets.back().folder + " (" +
                std::to_string(result.datasets.back().pairs.size()) + " pairs)");
    } catch (const std::exception& e) {
      cli::warn(e.what());
      for (const ReadyPair& p : pairs) {
        for (int f : {p.left, p.right}) {
          result.skipped.push_back({frames[static_cast<std::size_t>(f)].source,
                                    std::string("its dataset could not be written: ") + e.what(), true});
        }
      }
    }
  }
  json datasets = json::array(), skipped = json::array();
  for (const IngestedDataset& d : result.datasets) {
    json pairs = json::array();
    for (const IngestedPair& p : d.pairs) {
      pairs.push_back(json{{"id", p.id},
                           {"left", {{"product_id", p.left.product_id}, {"source", p.left.source}}},
                           {"right", {{"product_id", p.right.product_id}, {"source", p.right.source}}}});
    }
    datasets.push_back(json{{"name", d.name}, {"folder", d.folder}, {"pairs", pairs}});
  }
  for (const Skipped& s : result.skipped) {
    skipped.push_back(json{{"input", s.input}, {"reason", s.reason}});
    result.errors = result.errors || s.error;
  }
  cli::writeFileAtomic(out_dir + "/index.json",
                       json{{"datasets", datasets}, {"skipped", skipped}}.dump(2) + "\n");
  return result;
}

}  // namespace areomap::ingest
