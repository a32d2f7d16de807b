// Result types handed to Python: the C++ result structs, and batches of them for the vectorised
// calls. Bound in results.cpp (one place to extend when a struct gains a field).
#pragma once

#include "pvdf/mapping/locator.hpp"

#include <string>
#include <vector>

#ifdef PVDF_PYTHON_WITH_FEM
#include "pvdf/fem/probe_sweep.hpp"
#endif

namespace pvdf::python {

/// N presses located at once (Locator.locate over an N × n_electrodes array).
struct LocationBatch {
  std::vector<pvdf::mapping::Location> items;
};

#ifdef PVDF_PYTHON_WITH_FEM
/// N probe solves on one prepared mesh (ProbeSweep.solve over arrays of positions and forces).
struct SweepBatch {
  std::vector<pvdf::fem::ProbeSolution> items;
  std::size_t n_electrodes = 0;
};
#endif

}  // namespace pvdf::python
