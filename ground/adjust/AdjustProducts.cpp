#include "ground/adjust/AdjustProducts.hpp"
#include "ground/adjust/ReportJson.hpp"

#include <filesystem>
#include <sstream>
#include <nlohmann/json.hpp>

#include "firmware_core/camera/CameraConversion.hpp"
#include "ground/cli/AtomicFile.hpp"
#include "ground/cli/Cli.hpp"
#include "ground/dataset/RigSigmas.hpp"
#include "ground/dataset/TruthFiles.hpp"
#include "ground/io/CameraFile.hpp"

namespace areomap::ground {

namespace {

nlohmann::json imageJson(const ImageDifferences& d) {
  return {{"x", d.x}, {"y", d.y}, {"dist", d.dist}, {"count", d.count}};
}

nlohmann::json groundJson(const GroundDifferences& d) {
  return {{"x", d.x}, {"y", d.y}, {"z", d.z}, {"count", d.count}};
}

template <typename T>
nlohmann::json optionalJson(const std::optional<T>& v) {
  return v ? nlohmann::json(*v) : nlohmann::json(nullptr);
}

// Products are written whole or not at all: the text is built in memory, then written under a temporary
// name in the same folder and renamed (cli::writeFileAtomic, which names the file on failure).
void writeTextProduct(const std::string& path, const std::string& text) {
  const std::filesystem::path p(path);
  std::error_code ec;
  if (p.has_parent_path()) std::filesystem::create_directories(p.parent_path(), ec);
  cli::writeFileAtomic(path, text);
}

}  // namespace

void setRigFigures(AdjustReport& report, const Network& net) {
  const ConstraintMisfit misfit = networkMisfit(net);
  report.max_gimbal_misfit_m = misfit.gimbal_m;
  report.max_base_misfit_m = misfit.base_m;
  report.sigma_gimbal_m = net.rig.sigma_gimbal_m;
  report.sigma_base_m = net.rig.sigma_base_m;
  heldSigmaOutcome(net.rig, misfit, report.estimated, report.warnings);
}

void demCoverageTotal(const std::vector<DemCoverageFigure>& figures, long& seen, long& filled) {
  seen = 0;
  filled = 0;
  for (const DemCoverageFigure& c : figures) {
    seen += c.seen_2_5m + c.seen_5_10m;
    filled += c.filled_2_5m + c.filled_5_10m;
  }
}

nlohmann::json reportJson(const AdjustReport& r) {
  nlohmann::json j;
  j["method1_px"] = {{"before", imageJson(r.method1_before)}, {"after", imageJson(r.method1_after)}};
  j["method2_m"] = {{"before", groundJson(r.method2_before)}, {"after", groundJson(r.method2_after)}};
  j["method3_px"] = {{"before", imageJson(r.method3_before)}, {"after", imageJson(r.method3_after)}};
  j["figures"] = "method1_px, method2_m, method3_px: mean absolute differences; rms_px: RMS per coordinate; "
                 "truth: RMS, eo in pixel equivalent f x (angle + |dC| / 5 m), datum rotation removed";
  j["rms_px"] = r.rms_px;
  j["sigma0"] = r.sigma0;
  j["iterations"] = r.iterations;
  j["tie_points"] = {{"intra", r.tie_points.intra}, {"inter", r.tie_points.inter}, {"rejected", r.tie_points.rejected}};
  nlohmann::json seconds = nlohmann::json::object();
  for (const auto& [stage, s] : r.seconds) seconds[stage] = s;
  j["seconds"] = seconds;
  if (r.truth) {
    j["truth"] = {{"eo_px", r.truth->eo_px},
                  {"ground_m", optionalJson(r.truth->ground_m)},
                  {"dem_rmse_m", optionalJson(r.truth->dem_rmse_m)},
                  {"eo_px_raw", r.truth->eo_px_raw},
                  {"ground_m_raw", optionalJson(r.truth->ground_m_raw)},
                  {"eo_px_before", optionalJson(r.truth->eo_px_before)},
                  {"dem_unseen_empty", optionalJson(r.truth->dem_unseen_empty)},
                  {"dem_seen_filled", optionalJson(r.truth->dem_seen_filled)},
                  {"ortho_agreement", optionalJson(r.truth->ortho_agreement)}};
  }
  j["warnings"] = r.warnings;
  j["adjustment"] = {{"solver", r.solver},
                     {"stop_rule", r.stop_rule},
                     {"constraints", r.constraints},
                     {"estimated", r.estimated},
                     {"max_gimbal_misfit_m", r.max_gimbal_misfit_m},
                     {"max_base_misfit_m", r.max_base_misfit_m},
                     {"sigma_gimbal_m", r.sigma_gimbal_m},
                     {"sigma_base_m", r.sigma_base_m}};
  if (!r.dense_pairs.empty()) {
    nlohmann::json pairs = nlohmann::json::array();
    for (const DensePairNoise& p : r.dense_pairs) {
      pairs.push_back({{"pair", p.pair},
                       {"match_sigma_px", p.match_sigma_px},
                       {"match_sigma_source", p.match_sigma_source},
                       {"match_sigma_samples", p.samples}});
    }
    j["dense"] = {{"pairs", pairs}};
  }
  if (!r.dem_coverage.empty()) {
    // A fraction is null where the band holds no cell both cameras see.
    auto fraction = [](long filled, long seen) {
      return seen > 0 ? nlohmann::json(static_cast<double>(filled) / static_cast<double>(seen)) : nlohmann::json();
    };
    nlohmann::json pairs = nlohmann::json::array();
    for (const DemCoverageFigure& c : r.dem_coverage) {
      pairs.push_back({{"pair", c.pair},
                       {"fraction_2_5m", fraction(c.filled_2_5m, c.seen_2_5m)},
                       {"fraction_5_10m", fraction(c.filled_5_10m, c.seen_5_10m)},
                       {"cells_seen_2_5m", c.seen_2_5m},
                       {"cells_seen_5_10m", c.seen_5_10m}});
    }
    long seen = 0, filled = 0;
    demCoverageTotal(r.dem_coverage, seen, filled);
    j["dem_coverage"] = {{"fraction_2_10m", fraction(filled, seen)}, {"pairs", pairs}};
  }
  return j;
}

void writeReportJson(const std::string& path, const AdjustReport& r) {
  writeTextProduct(path, reportJson(r).dump(2) + "\n");
}

void writeEoCsv(const std::string& path, const Network& net, const std::vector<std::string>& stems) {
  std::ostringstream out;
  // Rotation sigmas are about the camera axes (the local update M' = exp([delta]x) M), radians.
  out << "image,pair,side,x_m,y_m,z_m,omega_rad,phi_rad,kappa_rad,sigma_x_m,sigma_y_m,sigma_z_m,"
         "sigma_rot_x_rad,sigma_rot_y_rad,sigma_rot_z_rad\n";
  for (int i = 0; i < net.imageCount(); ++i) {
    const NetImage& im = net.image(i);
    double o = 0.0, p = 0.0, k = 0.0;
    opkFromRotation(im.m, o, p, k);
    out << stems[i] << "," << im.pair << "," << (im.side == Side::kLeft ? "L" : "R");
    for (const double v : {im.centre_m.x(), im.centre_m.y(), im.centre_m.z(), o, p, k}) out << "," << formatDouble(v);
    for (int c = 0; c < 6; ++c) out << "," << formatDouble(im.sigma(c));
    out << "\n";
  }
  writeTextProduct(path, out.str());
}

CameraModel adjustedModelOf(const Network& net, int image, const CameraModel& apriori) {
  const NetImage& im = net.image(image);
  return adjustedModel(apriori, im.m_apriori, im.m, im.centre_m);
}

void writeAdjustedModels(const std::string& dir, const Network& net, const std::vector<CameraModel>& apriori,
                         const std::vector<std::string>& stems, std::vector<std::string>* errors) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);  // a failure shows as each model's write error
  for (int i = 0; i < net.imageCount(); ++i) {
    try {
      io::writeCameraModelFile(dir + "/" + stems[i] + ".cahvor", adjustedModelOf(net, i, apriori[i]));
    } catch (const std::exception& e) {
      if (errors == nullptr) throw;
      errors->push_back(e.what());
    }
  }
}

}  // namespace areomap::ground
