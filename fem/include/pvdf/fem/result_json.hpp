// The JSON form of a solve's result: what `pvdfkit solve --json` prints and what the Python
// package's SolveResult.to_dict() returns (one home for the keys; docs/fem.md lists them).
#pragma once

#include "pvdf/fem/solver.hpp"

#include <nlohmann/json.hpp>

namespace pvdf::fem {

/// Status, model, mesh size, iterations, timings and error estimates always; the fields (loads,
/// electrodes with their charge estimates, samples, VTU files) only when the status is usable.
/// Non-finite numbers come out as null.
nlohmann::json result_json(const Result& result);

}  // namespace pvdf::fem
