// The ground pass's report.json beyond ground/adjust's (the stream's counts, the rover's figures, the
// ground's own, the hold-out check) and the rover's products (rover_models/, rover_tiepoints.csv); and how
// the pass records a product it could not write. Internal to ground/pass (GroundPass.cpp).
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "firmware_core/adjust/Network.hpp"
#include "ground/adjust/AdjustProducts.hpp"
#include "ground/pass/GroundPass.hpp"
#include "ground/ties/TieAdjust.hpp"

namespace areomap::ground {

using json = nlohmann::json;

// A product that could not be written (full disk, folder not writable: `error` names the file): recorded,
// and the pass goes on with the other products.
void recordWriteError(GroundPassResult& result, AdjustReport& report, const std::string& error);
// Runs one product writer; a failure (the writers throw an error naming the file) is recorded.
void writeOrRecord(GroundPassResult& result, AdjustReport& report, const std::function<void()>& write);

// The rover's part of the products: rover_models/, rover_tiepoints.csv, its EO against the ground's, its
// status figures (the report's "rover" object) and warnings.
json roverFigures(const RoverInputs* rover, const Network& net, const std::vector<std::string>& stems,
                  const std::string& out, GroundPassResult& result, AdjustReport& report);

// report.json whole: ground/adjust's report (ReportJson.hpp), then `stream` (when given), `rover` (when
// given), `ground`, truth.eo_px_fast and `adjustment_check`.
json passReportJson(const AdjustReport& report, const StreamCounts* stream, const RoverInputs* rover,
                    const json& rover_json, const AdjustOutcome& fast, const GroundPassResult& result);

}  // namespace areomap::ground
