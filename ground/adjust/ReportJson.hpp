// report.json of an adjustment (AdjustProducts.hpp writeReportJson) as a JSON value, for a caller that adds
// its own keys before it writes the file once (the ground pass: stream, rover, ground, adjustment_check).
#pragma once

#include <nlohmann/json.hpp>

#include "ground/adjust/AdjustProducts.hpp"

namespace areomap::ground {

nlohmann::json reportJson(const AdjustReport& report);

}  // namespace areomap::ground
