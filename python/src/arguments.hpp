// Checked conversion of Python arguments to C++ values. Every bad argument — wrong type, NaN or
// inf, empty, wrong shape, wrong dtype, out of range — becomes a pvdf::InputError (Python:
// pvdfkit.InputError) whose message names the argument, the value, the rule and the fix, as the
// command line's messages do; never a pybind11 TypeError with a signature dump, never a NaN
// carried into a result. The bindings take `py::object` and convert with these.
#pragma once

#include "bindings.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/scene.hpp"

#include <optional>

namespace pvdf::python::arg {

/// repr(value) for messages, cut to 80 characters.
std::string shown(py::handle value);
/// The value's type name as Python prints it ("str", "numpy.ndarray").
std::string type_name(py::handle value);

/// A finite real number: int, float or a numpy number (not bool, str or None). `what` names the
/// argument ("solve: tolerance"), `unit_and_fix` follows the rule ("(N), e.g. 1.0").
double number(py::handle value, const std::string& what, const std::string& unit_and_fix = "");
/// A finite number in [lo, hi] ((lo, hi] when lo_open), refused as the command's number_in
/// refuses a flag: "what = 0.7 must lie in [1e-08, 0.5] why".
double number_in(py::handle value, const std::string& what, double lo, double hi, const std::string& why,
                 bool lo_open = false);
/// None -> nullopt, else number_in.
std::optional<double> optional_number_in(py::handle value, const std::string& what, double lo, double hi,
                                         const std::string& why, bool lo_open = false);
/// A whole number in [lo, hi] (int or numpy integer; not bool, not 3.0).
long long integer_in(py::handle value, const std::string& what, long long lo, long long hi, const std::string& why = "");
/// True or False (also numpy.bool_).
bool flag(py::handle value, const std::string& what);
/// A str.
std::string text(py::handle value, const std::string& what);
/// A file path: a non-empty str or os.PathLike, without NUL bytes.
std::string path(py::handle value, const std::string& what);
/// An output file path, refused as `pvdfkit ... -o` refuses it (app/src/main.cpp): its folder must
/// exist and be writable, and the path must not be a folder.
std::string output_file(py::handle value, const std::string& what);
/// An output folder path: missing (it will be created inside an existing folder) or a folder,
/// never an existing file.
std::string output_folder(py::handle value, const std::string& what);
/// A list or tuple of str.
std::vector<std::string> texts(py::handle value, const std::string& what);

/// How an array argument may look.
struct ArrayRule {
  bool allow_empty = false;  ///< an array of no values is accepted
  bool finite = true;        ///< every value must be finite
  std::string fix;           ///< appended to messages: what to give instead ("charges in C, one column per electrode")
  bool allow_nan = false;    ///< with `finite`: NaN is accepted (a marked missing value), inf is not
};
/// A numeric array-like (list, tuple, numpy array of an integer or floating dtype) as a float64
/// C-contiguous array. Refused: None, str, ragged lists, bool/complex/object/text dtypes, and,
/// unless the rule allows them, empty arrays and non-finite values (named by index).
DoubleArray array(py::handle value, const std::string& what, const ArrayRule& rule = {});
/// The values of a scalar or 1-D array-like.
std::vector<double> vector(py::handle value, const std::string& what, const ArrayRule& rule = {});
/// An n x n_columns array-like as rows (one row of n_columns values also accepted as 1 x
/// n_columns); `columns` names them for messages ("(x_m, y_m, force_N)").
DoubleArray rows(py::handle value, const std::string& what, std::size_t n_columns, const std::string& columns,
                 const ArrayRule& rule = {});
/// The rows of an n x 2 array-like of (x_m, y_m).
std::vector<std::array<double, 2>> points(py::handle value, const std::string& what, const ArrayRule& rule = {});
/// Values of an unsigned 8-bit array (mask, status): whole numbers in [0, max_value].
std::vector<std::uint8_t> small_integers(py::handle value, const std::string& what, int max_value, const std::string& meaning);

/// A scene: a pvdfkit.Scene, or a dict or file path read by pvdfkit.load_scene (same checks and
/// messages as the command line).
pvdf::Scene scene(py::handle value, const std::string& what);

/// An instance of the bound C++ class T; `expected` says what to give ("a pvdfkit.ChargeMap (from
/// read_map, generate_map or synthetic_map)").
template <class T>
T& object(py::handle value, const std::string& what, const std::string& expected) {
  if (!py::isinstance<T>(value)) {
    throw pvdf::InputError(what + " = " + shown(value) + " (" + type_name(value) + ") must be " + expected);
  }
  return value.cast<T&>();
}

}  // namespace pvdf::python::arg
