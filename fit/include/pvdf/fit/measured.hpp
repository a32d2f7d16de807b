// The measured CSV of a fit: pvdf::read_measured (core/measured.hpp), the one reader of measured
// CSVs, under the names the fit has always used.
#pragma once

#include "pvdf/core/measured.hpp"

namespace pvdf::fit {
using pvdf::MeasuredRules;
using pvdf::MeasuredTable;
using pvdf::ObservedColumn;
using pvdf::read_measured;
}  // namespace pvdf::fit
