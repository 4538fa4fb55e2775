#include "ground/sim/SimWriter.hpp"

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "ground/dataset/DemRaster.hpp"
#include "ground/io/CameraFile.hpp"
#include "ground/sim/Renderer.hpp"
#include "ground/raster/RasterFiles.hpp"

namespace areomap::sim {
namespace {

void makeFolder(const std::string& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec || !std::filesystem::is_directory(dir)) {
    throw DatasetError(dir, "",
                       "cannot create the folder: " + (ec ? ec.message() : std::string("not a folder")));
  }
}

void writeTextFile(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw DatasetError(path, "", std::string("cannot write: ") + std::strerror(errno));
  out << text;
  out.close();
  if (!out) throw DatasetError(path, "", "write failed");
}

nlohmann::json configJson(const SimConfig& c) {
  nlohmann::json tiers = nlohmann::json::array();
  for (const TierPlan& t : c.tiers) {
    tiers.push_back({{"tilt_deg", t.tilt_deg},
                     {"pairs", t.pairs},
                     {"pan0_deg", t.pan0_deg},
                     {"pan_step_deg", t.pan_step_deg},
                     {"left_only", t.left_only}});
  }
  nlohmann::json j = {{"preset", c.preset},
                      {"seed", c.seed},
                      {"sol", c.sol},
                      {"image_size", {c.width, c.height}},
                      {"hfov_deg", c.hfov_deg},
                      {"focal_px", c.focalPx()},
                      {"rho1", c.rho1},
                      {"rho2", c.rho2},
                      {"o_tilt_deg", c.o_tilt_deg},
                      {"base_m", c.base_m},
                      {"head_forward_m", c.head_forward_m},
                      {"head_up_m", c.head_up_m},
                      {"toe_in_deg", c.toe_in_deg},
                      {"mast_m", c.mast_m},
                      {"tilt_axis_forward_m", c.tilt_axis_forward_m},
                      {"tiers", tiers},
                      {"pointing_error_px", {c.pointing_min_px, c.pointing_max_px}},
                      {"half_extent_m", c.half_extent_m},
                      {"cell_m", c.cell_m},
                      {"relief_m", c.relief_m},
                      {"rock_k", c.rock_k},
                      {"crater_density_per_km2", c.crater_density_per_km2},
                      {"min_rock_m", c.min_rock_m},
                      {"supersample", c.supersample},
                      {"noise_dn", c.noise_dn},
                      {"jpeg_quality", c.jpeg_quality},
                      {"sun_azimuth_deg", c.sun_azimuth_deg},
                      {"sun_elevation_deg", c.sun_elevation_deg},
                      {"shadows", c.shadows},
                      {"check_points", c.check_points},
                      {"range_m", {c.min_range_m, c.max_range_m}}};
  // Only when used, so that the record of an unblurred scene stays as before.
  if (c.blur_px > 0.0) j["blur_px"] = c.blur_px;
  if (c.max_slope_deg > 0.0) {
    j["max_slope_deg"] = c.max_slope_deg;
    j["slope_center_m"] = {c.slope_centre_m.x(), c.slope_centre_m.y()};
  }
  return j;
}

// A site of a traverse: where its frame and the terrain lie (ground/sim/TraverseSim.hpp).
nlohmann::json traverseJson(const SimGeometry& g) {
  const SimConfig& c = g.config;
  nlohmann::json rovers = nlohmann::json::array();
  for (const Eigen::Vector2d& xy : c.rover_xy_m) rovers.push_back({xy.x(), xy.y()});
  const SitePose& pose = *g.terrain_from_site;
  nlohmann::json j = {{"terrain_center_m", {c.terrain_centre_m.x(), c.terrain_centre_m.y()}},
                      {"cover_half_extent_m", c.cover_half_extent_m},
                      {"rover_xy_m", rovers},
                      {"true_pose",
                       {{"position_m", {pose.position_m.x(), pose.position_m.y(), pose.position_m.z()}},
                        {"heading_deg", pose.heading_rad * 180.0 / M_PI}}}};
  if (g.stance) {
    auto attitude = [](const RoverAttitude& a) {
      return nlohmann::json{{"roll_deg", a.roll_rad * 180.0 / M_PI},
                            {"pitch_deg", a.pitch_rad * 180.0 / M_PI}};
    };
    j["true_attitude"] = attitude(g.stance->truth);
    j["apriori_attitude"] = attitude(g.stance->apriori);
    j["base_elevation_m"] = g.stance->base_elevation_m;
  }
  return j;
}

}  // namespace

void writeSimDataset(const SimGeometry& g, const Terrain& terrain, const std::string& out,
                     const WriteOptions& options) {
  makeFolder(out);
  makeFolder(out + "/models");
  makeFolder(out + "/" + kTruthModelsFolder);
  if (options.images) makeFolder(out + "/images");
  const Dataset ds = g.dataset(out);
  writeDataset(ds, out);

  nlohmann::json pairs = nlohmann::json::array();
  for (const SimPair& p : g.pairs) {
    pairs.push_back({{"id", p.id},
                     {"tier", p.tier},
                     {"pan_deg", p.pan_deg},
                     {"tilt_deg", p.tilt_deg},
                     {"pan_error_rad", p.pan_error_rad},
                     {"tilt_error_rad", p.tilt_error_rad},
                     {"pointing_error_px", p.pointing_error_px}});
  }
  nlohmann::json sim = {{"config", configJson(g.config)},
                        {"terrain",
                         {{"nodes", terrain.nodes()},
                          {"coarse_nodes", terrain.coarseNodes()},
                          {"half_extent_m", terrain.halfExtentM()},
                          {"rocks", terrain.rockCount()},
                          {"craters", terrain.craterCount()}}},
                        {"pairs", pairs},
                        {"check_points", g.points.size()},
                        {"observations", g.observations.size()}};
  if (g.terrain_from_site) sim["traverse"] = traverseJson(g);
  writeTextFile(out + "/" + kTruthFolder + "/sim.json", sim.dump(2) + "\n");

  const std::vector<const SimCamera*> cams = g.cameras();
  for (const SimCamera* c : cams) {
    io::writeCameraModelFile(out + "/models/" + c->stem + ".cahvor", c->apriori);
    io::writeCameraModelFile(out + "/" + kTruthModelsFolder + "/" + c->stem + ".cahvor", c->truth);
  }
  writePointsCsv(out + "/" + kTruthPointsFile, g.points);
  writeObservationsCsv(out + "/" + kTruthObservationsFile, g.observations);
  writeDemGeoTiff(out + "/" + kTruthDemFile,
                  g.terrain_from_site ? terrain.demInFrame(*g.terrain_from_site, Eigen::Vector2d::Zero(),
                                                           g.dem_half_extent_m, terrain.cellM())
                                      : terrain.dem());

  if (!options.images) return;
  const std::vector<int> png_params = {cv::IMWRITE_PNG_COMPRESSION, 6, cv::IMWRITE_PNG_STRATEGY,
                                       cv::IMWRITE_PNG_STRATEGY_DEFAULT};
  for (std::size_t i = 0; i < cams.size(); ++i) {
    const RenderedImage image =
        renderImage(terrain, g.config, g.inTerrain(cams[i]->truth), static_cast<int>(i));
    const cv::Mat view(image.height, image.width, CV_8UC1, const_cast<uint8_t*>(image.pixels.data()));
    const std::string path = out + "/images/" + cams[i]->stem + ".png";
    try {
      raster::writePng(path, view, png_params);
    } catch (const std::exception& e) {
      throw DatasetError(path, "", std::string("cannot write PNG: ") + e.what());
    }
    if (options.on_image) options.on_image(static_cast<int>(i + 1), static_cast<int>(cams.size()));
  }
}

}  // namespace areomap::sim
