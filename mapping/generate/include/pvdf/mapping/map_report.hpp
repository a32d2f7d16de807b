// The one JSON form of a map generation's report: what `pvdfkit map --json` prints (the command adds
// its output path, mesh and the process's peak memory) and what the Python generate_map returns as
// its report dict (which adds setup_s). One function, so the two cannot drift apart.
#pragma once

#include "pvdf/mapping/generate.hpp"

#include <nlohmann/json.hpp>

namespace pvdf::mapping {

/// The report's keys (docs/map-generation.md §1); NaN values are written as null.
nlohmann::json map_report_json(const MapReport& report, const ChargeMap& map);

}  // namespace pvdf::mapping
