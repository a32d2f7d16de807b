// Reports of a fit: JSON (keys documented in docs/fem-vs-experiment.md §3) and the before/after
// figure (measured against predicted by point and by distance from each electrode).
#pragma once

#include "pvdf/core/scene.hpp"
#include "pvdf/fit/fit.hpp"
#include "pvdf/fit/measured.hpp"

#include <nlohmann/json.hpp>

#include <string>

namespace pvdf::fit {

/// The whole result as JSON (status, parameters, correlation, residuals, FEM statistics).
nlohmann::json to_json(const FitResult& result, const MeasuredTable& measured);

/// Writes the before/after PNG: (a) measured against predicted charge, (b) % difference per
/// observation, (c) charge against distance from each electrode (log–log, seed 001 Fig. 12
/// style), (d) deflection per press (or normalized residuals when no deflection was measured).
void write_fit_png(const FitResult& result, const MeasuredTable& measured, const pvdf::Scene& scene,
                   const std::string& path);

}  // namespace pvdf::fit
