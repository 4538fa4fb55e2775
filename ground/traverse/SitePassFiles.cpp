#include "ground/traverse/SitePassFiles.hpp"

#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

#include "ground/dataset/DemRaster.hpp"
#include "ground/io/CameraFile.hpp"
#include "ground/io/Panorama.hpp"

namespace areomap::traverse {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

// `key`.after.`field` of a site's report.json, -1 when absent.
double figure(const json& report, const char* key, const char* field) {
  if (!report.contains(key) || !report[key].is_object() || !report[key].contains("after")) return -1.0;
  const json& after = report[key]["after"];
  return after.contains(field) && after[field].is_number() ? after[field].get<double>() : -1.0;
}

std::optional<DemGrid> rasterIfThere(const std::string& path) {
  if (!fs::exists(path)) return std::nullopt;
  return readDemGeoTiff(path);
}

}  // namespace

bool hasFinishedPass(const std::string& out_dir) {
  return fs::exists(out_dir + "/report.json") && fs::is_directory(out_dir + "/models");
}

std::shared_ptr<const ground::SitePass> loadSitePass(const TraverseSite& site, const std::string& out_dir) {
  std::ifstream in(out_dir + "/report.json");
  const json report = json::parse(in, nullptr, false);
  if (report.is_discarded()) return nullptr;
  auto pass = std::make_shared<ground::SitePass>();
  pass->out_dir = out_dir;
  pass->report.method1_after.dist = figure(report, "method1_px", "dist");
  pass->report.method2_after.z = figure(report, "method2_m", "z");
  pass->report.method3_after.dist = figure(report, "method3_px", "dist");
  if (report.contains("truth") && report["truth"].contains("eo_px") && report["truth"]["eo_px"].is_number()) {
    ground::TruthFigures truth;
    truth.eo_px = report["truth"]["eo_px"].get<double>();
    pass->report.truth = truth;
  }
  pass->dataset = readDataset(site.dir);
  auto panorama = std::make_shared<const io::Panorama>(io::loadPanorama(pass->dataset));
  for (const Pair& pair : pass->dataset.pairs) {
    for (const ImageRef* ref : {&pair.left, pair.right ? &*pair.right : nullptr}) {
      if (ref == nullptr) continue;
      const std::string adjusted = out_dir + "/models/" + ref->stem + ".cahvor";
      if (!fs::is_regular_file(adjusted)) continue;
      pass->stems.push_back(ref->stem);
      pass->apriori.push_back(panorama->find(ref->stem)->model);
      pass->adjusted.push_back(io::readCameraModelFile(adjusted));
    }
  }
  pass->panorama = std::move(panorama);
  pass->dem = rasterIfThere(out_dir + "/dem.tif");
  pass->dem_sigma = rasterIfThere(out_dir + "/dem_sigma.tif");
  pass->ortho = rasterIfThere(out_dir + "/ortho.tif");
  return pass;
}

}  // namespace areomap::traverse
