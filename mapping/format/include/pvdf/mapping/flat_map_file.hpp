// Writing the flat lookup map (pvdf/mapping/flat_map.hpp; docs/lookup.md §8) to files: the binary
// file, or a C header holding the same bytes as an array for firmware images.
#pragma once

#include "pvdf/mapping/map.hpp"

#include <string>
#include <vector>

namespace pvdf::mapping {

/// Writes the flat bytes of `map` atomically to `path`. Throws InputError (naming `source` for a
/// map that cannot be exported, `path` for a folder that cannot be written).
void write_flat_map(const std::string& path, const ChargeMap& map, const std::string& source);

/// The text of a C header (C89 and C++) that defines `static const unsigned char SYMBOL[]` with the
/// flat bytes and `#define SYMBOL_SIZE`, plus comments naming the map's sizes and electrodes.
/// `symbol` must be a C identifier (see c_identifier).
std::string flat_map_c_header(const std::vector<unsigned char>& bytes, const ChargeMap& map, const std::string& symbol,
                              const std::string& source);

/// Writes flat_map_c_header() atomically to `path`.
void write_flat_map_c_header(const std::string& path, const ChargeMap& map, const std::string& symbol, const std::string& source);

/// `text` made a C identifier: characters other than letters, digits and '_' become '_', a
/// leading digit gets a '_' before it, an empty text gives "pvdf_map".
std::string c_identifier(const std::string& text);

}  // namespace pvdf::mapping
