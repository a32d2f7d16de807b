// The flat lookup map: a charge map as one compact little-endian byte block that a deployed
// program or a firmware image reads without HDF5 (layout: docs/lookup.md §8). `pvdfkit export-map`
// writes it as a binary file or as a C header holding the same bytes; the runtime reads it back
// into a ChargeMap for the Locator.
#pragma once

#include "pvdf/mapping/map.hpp"

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace pvdf::mapping {

/// The first 8 bytes of every flat map.
inline constexpr char flat_map_magic[8] = {'P', 'V', 'D', 'F', 'F', 'L', 'A', 'T'};
/// The newest version encode_flat_map writes (it writes the oldest version that holds the map's
/// content). Version 2 added the per-node charge error section (content bit 2); version 3 the
/// content bit 3 (those errors are totals: node + between nodes + between force levels, adaptive
/// maps) with the header's former reserved field holding estimated_total_relative_error (f64).
/// Versions 1 and 2 are still read.
inline constexpr std::uint32_t flat_map_version = 3;
inline constexpr std::uint32_t flat_map_oldest_version = 1;
inline constexpr std::uint32_t flat_map_header_bytes = 80;
/// Bytes of each electrode name field (NUL-padded; names are at most 31 bytes).
inline constexpr std::uint32_t flat_map_name_bytes = 32;
/// Content bits of the header.
inline constexpr std::uint32_t flat_map_has_derivatives = 1u << 0;
inline constexpr std::uint32_t flat_map_has_calibration = 1u << 1;
inline constexpr std::uint32_t flat_map_has_charge_error = 1u << 2;  ///< version ≥ 2: estimated_charge_error_C
inline constexpr std::uint32_t flat_map_charge_error_is_total = 1u << 3;  ///< version ≥ 3: ChargeMap::estimated_total_relative_error set
/// Largest flat map the reader accepts (bytes): larger files are refused before anything is read.
inline constexpr std::uint64_t flat_map_max_bytes = std::uint64_t(1) << 30;
/// Largest grid the reader accepts per axis and in force levels.
inline constexpr std::uint32_t flat_map_max_axis = 100000;
inline constexpr std::uint32_t flat_map_max_levels = 1000;

/// The flat bytes of `map` (validated first; throws InputError naming `source` when the map cannot
/// be exported, e.g. an electrode name longer than 31 bytes). Keeps what the lookup uses: grid,
/// mask, force levels, electrodes (names, centres, noise), charges, status, derivatives, the
/// per-node charge error estimates and calibration when present, rim margin, tolerance and
/// estimated error. Not kept: the scene, provenance text, deflections. (The interpolation error
/// the Locator adds is computed from the charges when it is built, so it is the same for the
/// HDF5 map and its flat export.)
std::vector<unsigned char> encode_flat_map(const ChargeMap& map, const std::string& source);

/// Reads a flat map from memory (e.g. the array of an exported C header). Refuses, with
/// InputError naming `source`, the value and the fix: a wrong magic or version, sizes beyond the
/// limits above, a block shorter (truncated) or longer (trailing bytes) than its header says, a
/// checksum mismatch, and any map validate() refuses. Deflections come back as 0.
ChargeMap decode_flat_map(const unsigned char* data, std::size_t size, const std::string& source);

/// Reads a flat map file (decode_flat_map; a file larger than flat_map_max_bytes is refused
/// before it is read).
ChargeMap read_flat_map(const std::string& path);

/// CRC-32 (IEEE 802.3, reflected, as zlib's crc32) of `size` bytes: the flat map's checksum.
std::uint32_t flat_map_crc32(const unsigned char* data, std::size_t size);

}  // namespace pvdf::mapping
