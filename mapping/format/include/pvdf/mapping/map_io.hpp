// The charge-map file (HDF5, docs/mapping.md): reading and writing, in pvdf::mapping_format. The
// lookup runtime (pvdf::lookup) holds the map in memory and validates it, but has no HDF5: a
// deployed sensor loads the flat export (flat_map_file.hpp) instead.
#pragma once

#include "pvdf/mapping/map.hpp"

#include <string>

namespace pvdf::mapping {

/// Reads and validates a map file. Throws pvdf::InputError naming the file and the dataset or
/// attribute when it is missing, has the wrong type/shape/units, or holds invalid values.
ChargeMap read_map(const std::string& path);

/// Validates and writes a map atomically (temporary file + rename). Throws pvdf::InputError.
void write_map(const std::string& path, const ChargeMap& map);

/// Format identification written into the root attributes.
inline constexpr const char* map_format_name = "pvdfkit-charge-map";
/// Version written; read_map also reads version 1 (no per-node error estimate).
inline constexpr int map_format_version = 2;

}  // namespace pvdf::mapping
