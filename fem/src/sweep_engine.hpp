// Internal to pvdf::fem: the fixed-mesh probe solver behind pvdf::fem::ProbeSweep. Implemented
// in solver.cc (the one deal.II translation unit); this header exposes std/pvdf types only.
#pragma once

#include "pvdf/core/scene.hpp"
#include "pvdf/fem/probe_sweep.hpp"
#include "pvdf/fem/solver.hpp"

#include <array>
#include <memory>
#include <string>
#include <vector>

namespace pvdf::fem::detail {

/// A-priori sizes of the one mesh a sweep uses for every probe position (m).
struct SweepMeshSizes {
  double region_size_m = 0;     ///< largest cell size anywhere (also under every probe)
  double electrode_size_m = 0;  ///< cell size on the electrodes
  double grading = 1.0;         ///< away from the electrodes: size <= grading x distance
  int global_refinements = 0;   ///< uniform refinements after the grading
};

/// Outcome of one probe solve on the sweep mesh.
struct EngineSolution {
  Status status = Status::no_convergence;
  std::string message;
  int newton_iterations = 0;
  int factorizations = 0;
  bool warm_started = false;
  double deflection_at_load_m = 0;
  double rim_reaction_N = 0;
  std::vector<double> charge_C;
  std::vector<std::array<double, 3>> mean_membrane_force_material_N_per_m;
};

/// Accumulated cost of the probe solves: the public pvdf::fem::SweepTiming.
using EngineTiming = SweepTiming;

class SweepEngine {
 public:
  /// Builds the mesh (graded to the electrodes, nowhere coarser than sizes.region_size_m), the
  /// DOFs, constraints and sparsity for `model` (with/without bending). The scene's loads are ignored.
  SweepEngine(const pvdf::Scene& scene, const Options& options, Model model, bool include_bending,
              const SweepMeshSizes& sizes);
  ~SweepEngine();
  SweepEngine(const SweepEngine&) = delete;
  SweepEngine& operator=(const SweepEngine&) = delete;

  std::size_t n_dofs() const;
  std::size_t n_cells() const;
  EngineTiming timing() const;

  /// One vertical probe (x, y, F). `state` (size n_dofs) is the starting guess when `warm`;
  /// if it was converged under another force `state_force_N` (> 0), it is first scaled by the
  /// pure-membrane law (w by (F/F0)^(1/3), in-plane displacements by (F/F0)^(2/3)). On a usable
  /// outcome `state` receives the converged state.
  EngineSolution solve(double x_m, double y_m, double force_N, std::vector<double>& state, bool warm,
                       double state_force_N = 0);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// The `auto` rule of pvdf::fem::solve: non-empty reason when bending can be neglected for the
/// scene's loads at `options.tolerance` (then: large-rotation membrane without bending).
std::string bending_negligible_reason(const pvdf::Scene& scene, const Options& options);

}  // namespace pvdf::fem::detail
