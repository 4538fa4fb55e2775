#include "ground/pass/PassReport.hpp"

#include <algorithm>
#include <filesystem>

#include "ground/adjust/ReportJson.hpp"
#include "ground/cli/Cli.hpp"
#include "ground/io/CameraFile.hpp"
#include "ground/pass/GroundPass.hpp"
#include "msgs/adapters/MessageAdapters.hpp"

namespace areomap::ground {

namespace fs = std::filesystem;

void recordWriteError(GroundPassResult& result, AdjustReport& report, const std::string& error) {
  cli::warn("not written: " + error);
  result.write_errors.push_back(error);
  report.warnings.push_back("Not written: " + error);
}

void writeOrRecord(GroundPassResult& result, AdjustReport& report, const std::function<void()>& write) {
  try {
    write();
  } catch (const std::exception& e) {
    recordWriteError(result, report, e.what());
  }
}

namespace {

json differences(const ImageDifferences& d) {
  return json{{"x", d.x}, {"y", d.y}, {"dist", d.dist}};
}

// report.json "adjustment_check": the hold-out check's figures per pair (HoldOutCheck.hpp).
json holdOutJson(const HoldOutResult& check) {
  json pairs = json::array();
  for (const PairVerdict& v : check.pairs) {
    pairs.push_back({{"pair", v.pair},
                     {"ties", v.ties},
                     {"wrong_ties", v.wrong_ties},
                     {"heldout_apriori_rms_px", v.apriori_rms_px},
                     {"heldout_adjusted_rms_px", v.adjusted_rms_px},
                     {"improvement_px2", v.improvement_px2},
                     {"standard_error_px2", v.standard_error_px2},
                     {"adjusted", v.adjusted},
                     {"reason", v.reason}});
  }
  return json{{"method", "k-fold cross-validation of the tie points (held-out residuals)"},
              {"folds", check.folds},
              {"wrong_observations", check.wrong_observations},
              {"pairs", pairs}};
}

}  // namespace

json passReportJson(const AdjustReport& report, const StreamCounts* stream, const RoverInputs* rover,
                    const json& rover_json, const AdjustOutcome& fast, const GroundPassResult& result) {
  json j = reportJson(report);
  if (stream != nullptr) {
    j["stream"] = {{"pairs", stream->pairs},
                   {"gaps", stream->gaps},
                   {"duplicates", stream->duplicates},
                   {"reordered", stream->reordered},
                   {"rejected", stream->rejected},
                   {"end_of_panorama", stream->end_of_panorama},
                   {"pairs_planned", stream->pairs_planned}};
  }
  if (rover != nullptr) j["rover"] = rover_json;
  j["ground"] = {{"ties", result.rover_ties_used
                              ? "the rover's tie points (AREOMAP_TIEPOINTS)"
                              : "the rover's matcher (firmware_core/match) run on the ground's images"},
                 {"tie_source", result.rover_ties_used ? "rover" : "ground"},
                 {"reference", "integrated adjustment, Ceres sparse Schur"},
                 {"method1_fast_px", differences(fast.after)},
                 {"fast_sweeps", fast.result.sweeps_total},
                 {"fast_vs_integrated_px", *result.fast_vs_ground_px}};
  if (result.truth_eo_fast_px) j["truth"]["eo_px_fast"] = *result.truth_eo_fast_px;
  j["adjustment_check"] = holdOutJson(result.holdout);
  return j;
}

json roverFigures(const RoverInputs* rover, const Network& net, const std::vector<std::string>& stems,
                  const std::string& out, GroundPassResult& result, AdjustReport& report) {
  const Vec3 gimbal = net.rig.gimbal_m[0];
  json rover_json = json::object();
  if (rover != nullptr && rover->eo) {
    fs::create_directories(out + "/rover_models");
    for (const eo_entry_t& e : rover->eo->images) {
      CameraModel model;
      std::string why;
      const char* field = "";
      if (!ok(toCameraModel(e.model, model, field)) || e.stem.empty() ||
          e.stem.find('/') != std::string::npos || !isSafeRelativePath(e.stem, why)) {
        report.warnings.push_back("The rover's EO entry '" + e.stem + "' has no usable model; not written.");
        continue;
      }
      writeOrRecord(result, report,
                    [&] { io::writeCameraModelFile(out + "/rover_models/" + e.stem + ".cahvor", model); });
    }
    int32_t compared = 0;
    result.rover_vs_ground_px = eoDifferencePx(*rover->eo, net, stems, gimbal, &compared);
    rover_json["eo_vs_ground_px"] =
        result.rover_vs_ground_px ? json(*result.rover_vs_ground_px) : json(nullptr);
    rover_json["eo_images_compared"] = compared;
    rover_json["eo_is_final"] = static_cast<bool>(rover->eo->is_final);
    rover_json["sweeps"] = rover->eo->sweeps;
    rover_json["rms_px"] = rover->eo->rms_px;
    if (!rover->eo->is_final)
      report.warnings.push_back("The rover's final EO solution did not arrive; its last one is compared.");
  }
  if (rover != nullptr) {
    if (rover->status) {
      const rover_status_t& s = *rover->status;
      rover_json["heap_allocs_after_init"] = s.heap_allocs_after_init;
      rover_json["static_bytes"] = s.static_bytes;  // static and start-up reserve, against the 72 MiB budget
      const int32_t accepted = std::max(1, s.pairs_accepted);
      double total = 0.0;
      json stages = json::object();
      const char* names[] = {"decode", "features", "match", "dem", "adjust", "publish"};
      for (int k = 0; k < 6; ++k) {
        stages[names[k]] = s.stage_seconds[k] / accepted;
        total += s.stage_seconds[k];
      }
      rover_json["seconds_per_pair"] = total / accepted;
      rover_json["stage_seconds_per_pair"] = stages;
      rover_json["pairs_seen"] = s.pairs_seen;
      rover_json["pairs_accepted"] = s.pairs_accepted;
      rover_json["pairs_rejected"] = s.pairs_rejected;
      rover_json["pairs_binned"] = s.pairs_binned;  // frames above the rover's capacity, binned to fit it
      rover_json["sequence_gaps"] = s.sequence_gaps;
      if (!s.last_error.empty()) report.warnings.push_back("The rover reported: " + s.last_error);
    }
    if (!rover->ties.empty()) {
      writeOrRecord(result, report,
                    [&] { writeObservationsCsv(out + "/rover_tiepoints.csv", rover->ties, true); });
    }
    rover_json["tiepoint_messages"] = rover->tie_messages;
    rover_json["tiepoint_observations"] = rover->tie_observations;
    rover_json["coarse_dem_messages"] = rover->dem_messages;
    for (const std::string& w : rover->warnings) report.warnings.push_back(w);
    if (!rover->eo && !rover->status)
      report.warnings.push_back("Nothing arrived from the rover: no rover figures.");
  }
  return rover_json;
}

}  // namespace areomap::ground
