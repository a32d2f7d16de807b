// The clamp's bending layer as a boundary condition (docs/fem.md §3.4): what callers outside
// clamp_layer.cpp need — the condition's share of the tolerance and the PVDF_CLAMP_LAYER switch.
// The condition itself is FilmSolver's (film_solver.hpp: solve_probe_with_clamp_layer,
// clamp_layer_charge_error_C).
#pragma once

#include "pvdf/fem/solver.hpp"

namespace pvdf::fem::detail {

/// The clamp-layer condition's share of the tolerance (clamp_layer.cpp, docs/fem.md §3.4):
/// 3/4 · tolerance − the other model errors (relative; non-finite counts as the whole tolerance).
/// The condition is kept where its estimate is within it, else the rim-graded reference path.
double clamp_layer_share(double tolerance, double other_model_error);

/// `options` with the PVDF_CLAMP_LAYER bench switch applied (read like PVDF_FACTORIZATION):
/// "rim-graded" = Options::clamp_layer_condition off (the reference path), "no-shift" = no in-plane
/// shift, unset or empty = as given; another value throws pvdf::InputError.
Options with_clamp_layer_switch(Options options);

/// PVDF_CLAMP_LAYER=accept (bench only): `solve` keeps the condition where its estimate exceeds its
/// share (instead of the rim-graded path), so its effectivity can be measured there.
bool clamp_layer_accepted();

/// PVDF_RIM_GRADING=uniform (bench only): the rim-graded path grades the whole rim to the centred
/// press's layer width, as before r14 (the conservative reference mesh), instead of the layer's own
/// width along the rim. Unset, empty or "local": the default; another value throws pvdf::InputError.
bool rim_grading_uniform();

}  // namespace pvdf::fem::detail
