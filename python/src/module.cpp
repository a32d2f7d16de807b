// The extension module pvdfkit._pvdfkit: C++ errors become Python exceptions with the same
// message, then each part of the toolkit registers its functions and classes.
#include "bindings.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/version.hpp"

namespace pvdf::python {

std::string shape_text(const py::array& a) {
  std::string text = "(";
  for (py::ssize_t d = 0; d < a.ndim(); ++d) text += (d ? ", " : "") + std::to_string(a.shape(d));
  return text + (a.ndim() == 1 ? ",)" : ")");
}

std::vector<double> to_vector(const DoubleArray& a, const std::string& what) {
  if (a.ndim() > 1) {
    throw InputError(what + ": expected a 1-D array, got " + std::to_string(a.ndim()) + " dimensions");
  }
  return std::vector<double>(a.data(), a.data() + a.size());
}

std::vector<std::array<double, 2>> to_points(const DoubleArray& a, const std::string& what) {
  const bool one = a.ndim() == 1 && a.shape(0) == 2;
  if (!one && !(a.ndim() == 2 && a.shape(1) == 2)) {
    throw InputError(what + ": expected an n x 2 array of (x_m, y_m), got shape " + shape_text(a));
  }
  std::vector<std::array<double, 2>> out(std::size_t(a.size() / 2));
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = {a.data()[2 * i], a.data()[2 * i + 1]};
  return out;
}

void bind_errors(py::module_& m) {
  // Bad input: the message names the input, the value, the rule and the fix (as on the command
  // line after "error: "). A ValueError, so `except ValueError` catches it too.
  py::register_exception<pvdf::InputError>(m, "InputError", PyExc_ValueError);
  // A numerical failure raised where no status can be returned (the command line's exit code 3).
  py::register_exception<pvdf::NumericalError>(m, "NumericalError", PyExc_RuntimeError);
}

}  // namespace pvdf::python

PYBIND11_MODULE(_pvdfkit, m) {
  namespace pp = pvdf::python;
  m.doc() = "pvdfkit: PVDF piezoelectric tactile sensors (C++ core). Use the package `pvdfkit`, not this module.";
  m.attr("__version__") = pvdf::version_string;
  pp::bind_errors(m);
  pp::bind_results(m);
  pp::bind_scene(m);
  pp::bind_maps(m);
#ifdef PVDF_PYTHON_WITH_FEM
  pp::bind_fem(m);
  m.attr("has_fem") = true;
#else
  m.attr("has_fem") = false;
#endif
  pybind11::module_ restore = m.def_submodule("restore", "Seed 000 scanner: simulate scans, identify and apply inverse filters");
  pp::bind_restore(restore);
}
