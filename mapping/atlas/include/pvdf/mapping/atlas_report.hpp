// The one JSON form of an atlas generation's report: what `pvdfkit atlas --json` prints and what the
// Python make_atlas returns as its dict. One function, so the two cannot drift apart.
#pragma once

#include "pvdf/mapping/atlas.hpp"

#include <nlohmann/json.hpp>

#include <string>

namespace pvdf::mapping {

/// The report's keys (docs/atlas.md): counts, mirror images, the sweep's model, tolerance and mesh,
/// the atlas cells and probe grid, threads and timings (s); `output` is the atlas file written.
nlohmann::json atlas_report_json(const AtlasReport& report, const ChargeAtlas& atlas, const std::string& output);

}  // namespace pvdf::mapping
