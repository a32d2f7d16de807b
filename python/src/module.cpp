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
  pp::bind_optimize(m);
#ifdef PVDF_PYTHON_WITH_FEM
  pp::bind_fem(m);
  pp::bind_atlas(m);
  m.attr("has_fem") = true;
#else
  m.attr("has_fem") = false;
#endif
  pybind11::module_ restore = m.def_submodule("restore", "Seed 000 scanner: simulate scans, identify and apply inverse filters");
  pp::bind_restore(restore);
}
