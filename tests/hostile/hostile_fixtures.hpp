// The files the hostile-input table feeds to pvdfkit: bad scenes, garbage, truncated and deeply
// nested JSON, malformed CSV. Written into one folder by the test before the rows run.
#pragma once

#include <filesystem>
#include <string>

namespace pvdf::test {

/// Writes every fixture file into `dir` (which exists and is empty).
void write_hostile_fixtures(const std::filesystem::path& dir);

/// The seed-001 scene with `edit` applied to its JSON text ({"key": value} merged at the top).
std::string seed001_with(const std::string& patch_json);

}  // namespace pvdf::test
