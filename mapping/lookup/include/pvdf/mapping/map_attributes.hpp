// Optional number attributes of a charge map, shared by its checks (map.cpp) and the HDF5 file
// (mapping/format): absent in a file = NaN in ChargeMap = unknown.
#pragma once

#include "pvdf/mapping/map.hpp"

#include <array>
#include <utility>

namespace pvdf::mapping {

/// Root attributes that may be absent (files written before they existed, maps without an FEM
/// error estimate): absent in the file = NaN in ChargeMap = unknown. No new format version needed.
inline constexpr std::array<std::pair<const char*, double ChargeMap::*>, 3> optional_number_attributes{{
    {"estimated_relative_error", &ChargeMap::estimated_relative_error},
    {"estimated_deflection_relative_error", &ChargeMap::estimated_deflection_relative_error},
    {"estimated_total_relative_error", &ChargeMap::estimated_total_relative_error},
}};

}  // namespace pvdf::mapping
