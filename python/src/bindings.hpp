// Shared pieces of the pybind11 bindings: numpy conversion helpers and the per-file bind functions.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace pvdf {
struct Scene;
}
namespace pvdf::mapping {
struct DesignOptions;
}

namespace pvdf::python {

namespace py = pybind11;

/// A new C-contiguous numpy array of `shape` holding a copy of `values` (sizes must agree).
template <class T>
py::array_t<T> to_array(const std::vector<T>& values, std::vector<py::ssize_t> shape) {
  py::array_t<T> out(shape);
  std::copy(values.begin(), values.end(), out.mutable_data());
  return out;
}
/// 1-D copy.
template <class T>
py::array_t<T> to_array(const std::vector<T>& values) {
  return to_array(values, {py::ssize_t(values.size())});
}
/// n × N copy of a vector of fixed-size rows.
template <class T, std::size_t N>
py::array_t<T> to_array(const std::vector<std::array<T, N>>& rows) {
  py::array_t<T> out({py::ssize_t(rows.size()), py::ssize_t(N)});
  T* p = out.mutable_data();
  for (const auto& r : rows) p = std::copy(r.begin(), r.end(), p);
  return out;
}

/// A float64 C-contiguous view/copy of any array-like (lists, ints, float32 are converted).
using DoubleArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

/// "(3, 2)": the shape of an array as numpy prints it, for messages.
std::string shape_text(const py::array& a);

void bind_errors(py::module_& m);
void bind_results(py::module_& m);
void bind_scene(py::module_& m);
void bind_fem(py::module_& m);
/// The charge-density atlas (atlas.cpp; only with the FEM).
void bind_atlas(py::module_& m);
void bind_maps(py::module_& m);
/// The layout search, `design --optimize` (optimize.cpp; atlases only with the FEM).
void bind_optimize(py::module_& m);

/// The rule of the scene key model.tolerance, as `pvdfkit solve/map/atlas --tolerance` apply it
/// (None: not given). fem.cpp.
std::optional<double> tolerance_arg(py::object value, const std::string& what);
/// Force levels (N) as `pvdfkit map/atlas --forces-N` take them: each in (0, 1e4], resolved by the
/// film, distinct. fem.cpp.
std::vector<double> force_levels(py::object value, const std::string& what, const pvdf::Scene& scene);

/// pvdfkit.design's evaluation settings, each argument checked by the rule of `pvdfkit design`'s
/// flag (maps.cpp); `f` prefixes the messages ("design: "). Shared by design and optimize_layouts.
pvdf::mapping::DesignOptions design_options_arg(py::object force_N, py::object min_force_N, py::object max_force_N,
                                                py::object noise_C, py::object target_m, py::object force_known,
                                                py::object adc_bits, py::object full_scale_C, const std::string& f);
void bind_restore(py::module_& m);

}  // namespace pvdf::python
