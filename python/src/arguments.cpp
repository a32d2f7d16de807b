// Checked conversion of Python arguments (arguments.hpp): one place for the rules every binding
// applies, so that a message for a bad value reads the same in every function.
#include "arguments.hpp"

#include "pvdf/core/io.hpp"

#include <cmath>
#include <filesystem>

#include <unistd.h>

namespace pvdf::python::arg {
namespace {

/// numpy's dtype kinds accepted as numbers: signed and unsigned integers, floating point.
bool numeric_kind(const std::string& kind) { return kind == "i" || kind == "u" || kind == "f"; }

bool is_bool(py::handle value) {
  if (py::isinstance<py::bool_>(value)) return true;
  const py::object numpy_bool = py::module_::import("numpy").attr("bool_");
  return py::isinstance(value, numpy_bool);
}

/// "[2, 1]" for flat index i of an array of `shape` (C order); "" for a 0-d array.
std::string index_text(py::ssize_t i, const std::vector<py::ssize_t>& shape) {
  if (shape.empty()) return "";
  std::vector<py::ssize_t> index(shape.size());
  for (std::size_t d = shape.size(); d-- > 0;) {
    index[d] = shape[d] ? i % shape[d] : 0;
    i = shape[d] ? i / shape[d] : 0;
  }
  std::string text = "[";
  for (std::size_t d = 0; d < index.size(); ++d) text += (d ? ", " : "") + std::to_string(index[d]);
  return text + "]";
}

std::string with_fix(const std::string& fix) { return fix.empty() ? "" : "; " + fix; }

}  // namespace

std::string shown(py::handle value) {
  std::string text;
  try {
    text = py::repr(value).cast<std::string>();
  } catch (const py::error_already_set&) {
    text = "<" + type_name(value) + ">";
  }
  // numpy's repr spans lines: one line, runs of blanks collapsed, other control bytes escaped.
  std::string line;
  for (const char c : text) {
    const char d = c == '\n' || c == '\r' || c == '\t' ? ' ' : c;
    if (!(d == ' ' && !line.empty() && line.back() == ' ')) line += d;
  }
  line = pvdf::escape_control_bytes(line);
  return line.size() > 80 ? line.substr(0, 77) + "..." : line;
}

std::string type_name(py::handle value) {
  const py::handle type = py::type::handle_of(value);
  const std::string module = py::str(type.attr("__module__")).cast<std::string>();
  const std::string name = py::str(type.attr("__qualname__")).cast<std::string>();
  return module == "builtins" ? name : module + "." + name;
}

double number(py::handle value, const std::string& what, const std::string& unit_and_fix) {
  const std::string tail = unit_and_fix.empty() ? "" : " " + unit_and_fix;
  const py::object numbers = py::module_::import("numbers").attr("Real");
  if (value.is_none() || is_bool(value) || !py::isinstance(value, numbers)) {
    // A 0-d numpy array of a number is a number too (e.g. a.max()).
    bool zero_d = false;
    if (py::isinstance<py::array>(value)) {
      const auto a = py::reinterpret_borrow<py::array>(value);
      zero_d = a.ndim() == 0 && numeric_kind(std::string(1, a.dtype().kind()));
    }
    if (!zero_d) {
      throw pvdf::InputError(what + " = " + shown(value) + " (" + type_name(value) + ") must be a real number" + tail);
    }
  }
  double x = 0;
  try {
    x = py::float_(py::reinterpret_borrow<py::object>(value)).cast<double>();
  } catch (const py::error_already_set&) {  // OverflowError: an int beyond the double range
    throw pvdf::InputError(what + " = " + shown(value) + " is too large to be a number" + tail);
  }
  if (!std::isfinite(x)) throw pvdf::InputError(what + " = " + pvdf::format_g(x) + " must be a finite number" + tail);
  return x;
}

double number_in(py::handle value, const std::string& what, double lo, double hi, const std::string& why, bool lo_open) {
  const std::string range = std::string(lo_open ? "(" : "[") + pvdf::format_g(lo) + ", " + pvdf::format_g(hi) + "]";
  const double x = number(value, what, "in " + range + (why.empty() ? "" : " " + why));
  if ((lo_open ? x > lo : x >= lo) && x <= hi) return x;
  throw pvdf::InputError(what + " = " + pvdf::format_g(x) + " must lie in " + range + (why.empty() ? "" : " " + why));
}

std::optional<double> optional_number_in(py::handle value, const std::string& what, double lo, double hi,
                                         const std::string& why, bool lo_open) {
  if (value.is_none()) return std::nullopt;
  return number_in(value, what, lo, hi, why, lo_open);
}

long long integer_in(py::handle value, const std::string& what, long long lo, long long hi, const std::string& why) {
  const std::string rule = "[" + std::to_string(lo) + ", " + std::to_string(hi) + "]" + (why.empty() ? "" : " " + why);
  const py::object integral = py::module_::import("numbers").attr("Integral");
  if (value.is_none() || is_bool(value) || !py::isinstance(value, integral)) {
    throw pvdf::InputError(what + " = " + shown(value) + " (" + type_name(value) + ") must be a whole number in " + rule);
  }
  const py::int_ as_int(py::reinterpret_borrow<py::object>(value));
  // Compared in Python, so that an int beyond 64 bits is refused, not wrapped or overflowed.
  const bool in_range = as_int.attr("__ge__")(py::int_(lo)).cast<bool>() && as_int.attr("__le__")(py::int_(hi)).cast<bool>();
  if (!in_range) {
    throw pvdf::InputError(what + " = " + shown(value) + " must lie in " + rule);
  }
  return as_int.cast<long long>();
}

bool flag(py::handle value, const std::string& what) {
  if (!is_bool(value)) throw pvdf::InputError(what + " = " + shown(value) + " (" + type_name(value) + ") must be True or False");
  return py::cast<bool>(py::bool_(py::reinterpret_borrow<py::object>(value)));
}

std::string text(py::handle value, const std::string& what) {
  if (!py::isinstance<py::str>(value)) throw pvdf::InputError(what + " = " + shown(value) + " (" + type_name(value) + ") must be a str");
  return value.cast<std::string>();
}

std::string path(py::handle value, const std::string& what) {
  py::object text_value;
  try {
    text_value = py::module_::import("os").attr("fspath")(value);
  } catch (const py::error_already_set&) {
    throw pvdf::InputError(what + " = " + shown(value) + " (" + type_name(value) + ") must be a file path (str or pathlib.Path)");
  }
  if (!py::isinstance<py::str>(text_value)) {
    throw pvdf::InputError(what + " = " + shown(value) + " must be a file path given as str (bytes paths are not supported)");
  }
  const std::string p = text_value.cast<std::string>();
  if (p.empty()) throw pvdf::InputError(what + " is empty; give a file path");
  if (p.find('\0') != std::string::npos) throw pvdf::InputError(what + " = " + shown(value) + " holds a NUL byte; give a file path");
  return p;
}

std::string output_file(py::handle value, const std::string& what) {
  namespace fs = std::filesystem;
  const std::string p = path(value, what);
  std::error_code ec;
  if (fs::is_directory(p, ec)) throw pvdf::InputError(what + " = " + p + " is a folder; give a file name");
  const fs::path parent = fs::path(p).parent_path();
  const fs::path folder = parent.empty() ? fs::path(".") : parent;
  if (!fs::is_directory(folder, ec)) {
    throw pvdf::InputError(what + " = " + p + " cannot be written: folder " + folder.string() +
                           " does not exist; create it or choose another path");
  }
  if (::access(folder.c_str(), W_OK) != 0) {
    throw pvdf::InputError(what + " = " + p + " cannot be written: folder " + folder.string() + " is not writable");
  }
  return p;
}

std::string output_folder(py::handle value, const std::string& what) {
  namespace fs = std::filesystem;
  const std::string p = path(value, what);
  std::error_code ec;
  if (fs::exists(p, ec) && !fs::is_directory(p, ec)) {
    throw pvdf::InputError(what + " = " + p + " is an existing file; give a folder (it is created when missing)");
  }
  return p;
}

pvdf::Scene scene(py::handle value, const std::string& what) {
  if (py::isinstance<pvdf::Scene>(value)) return value.cast<pvdf::Scene>();
  const bool path_like = py::isinstance<py::str>(value) || py::hasattr(value, "__fspath__");
  if (!py::isinstance<py::dict>(value) && !path_like) {
    throw pvdf::InputError(what + " = " + shown(value) + " (" + type_name(value) +
                           ") must be a pvdfkit.Scene, a dict of scene keys or a scene file path");
  }
  // A dict is named by the argument in the reader's messages ("solve: scene: membrane.thickness_m = ...").
  const py::object source = py::isinstance<py::dict>(value) ? py::object(py::str(what)) : py::object(py::none());
  return py::module_::import("pvdfkit").attr("load_scene")(value, source).cast<pvdf::Scene>();
}

std::vector<std::string> texts(py::handle value, const std::string& what) {
  if (!py::isinstance<py::list>(value) && !py::isinstance<py::tuple>(value)) {
    throw pvdf::InputError(what + " = " + shown(value) + " (" + type_name(value) + ") must be a list of str");
  }
  std::vector<std::string> out;
  std::size_t i = 0;
  for (const py::handle item : value) out.push_back(text(item, what + "[" + std::to_string(i++) + "]"));
  return out;
}

DoubleArray array(py::handle value, const std::string& what, const ArrayRule& rule) {
  const std::string fix = with_fix(rule.fix);
  if (value.is_none() || py::isinstance<py::str>(value) || py::isinstance<py::bytes>(value) || py::isinstance<py::dict>(value)) {
    throw pvdf::InputError(what + " = " + shown(value) + " (" + type_name(value) + ") must be an array of numbers" + fix);
  }
  py::array a;
  try {
    a = py::module_::import("numpy").attr("asarray")(value);
  } catch (const py::error_already_set&) {
    throw pvdf::InputError(what + " = " + shown(value) + " is not an array of numbers (ragged rows or non-numbers?)" + fix);
  }
  const std::string kind(1, a.dtype().kind());
  if (!numeric_kind(kind)) {
    const std::string dtype = py::str(a.dtype()).cast<std::string>();
    throw pvdf::InputError(what + " = " + shown(value) + " has dtype " + dtype +
                           "; it must hold real numbers (an integer or floating dtype)" + fix);
  }
  DoubleArray out = DoubleArray::ensure(a);
  if (!out) throw pvdf::InputError(what + " = " + shown(value) + " cannot be converted to float64" + fix);
  if (out.size() == 0 && !rule.allow_empty) {
    throw pvdf::InputError(what + " is empty (shape " + shape_text(out) + ")" + (fix.empty() ? "; give at least one value" : fix));
  }
  if (rule.finite) {
    const double* p = out.data();
    for (py::ssize_t i = 0; i < out.size(); ++i) {
      if (!std::isfinite(p[i]) && !(rule.allow_nan && std::isnan(p[i]))) {
        const std::vector<py::ssize_t> shape(out.shape(), out.shape() + out.ndim());
        const std::string rule_text = rule.allow_nan ? "; every value must be a finite number (or NaN where a value is missing)"
                                                     : "; every value must be a finite number";
        throw pvdf::InputError(what + index_text(i, shape) + " = " + pvdf::format_g(p[i]) + " is not finite" +
                               (fix.empty() ? rule_text : fix));
      }
    }
  }
  return out;
}

std::vector<double> vector(py::handle value, const std::string& what, const ArrayRule& rule) {
  const DoubleArray a = array(value, what, rule);
  if (a.ndim() > 1) {
    throw pvdf::InputError(what + " has shape " + shape_text(a) + "; expected a 1-D array (or one number)" + with_fix(rule.fix));
  }
  return std::vector<double>(a.data(), a.data() + a.size());
}

DoubleArray rows(py::handle value, const std::string& what, std::size_t n_columns, const std::string& columns,
                 const ArrayRule& rule) {
  DoubleArray a = array(value, what, rule);
  const py::ssize_t n = py::ssize_t(n_columns);
  if (a.ndim() == 1 && a.shape(0) == n) return DoubleArray::ensure(a.reshape({py::ssize_t(1), n}));
  if (a.ndim() == 2 && a.shape(1) == n) return a;
  throw pvdf::InputError(what + " has shape " + shape_text(a) + "; expected n x " + std::to_string(n_columns) +
                         " rows of " + columns);
}

std::vector<std::array<double, 2>> points(py::handle value, const std::string& what, const ArrayRule& rule) {
  const DoubleArray a = rows(value, what, 2, "(x_m, y_m)", rule);
  std::vector<std::array<double, 2>> out(std::size_t(a.size() / 2));
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = {a.data()[2 * i], a.data()[2 * i + 1]};
  return out;
}

std::vector<std::uint8_t> small_integers(py::handle value, const std::string& what, int max_value, const std::string& meaning) {
  const DoubleArray a = array(value, what, {false, true, meaning});
  std::vector<std::uint8_t> out(std::size_t(a.size()));
  for (py::ssize_t i = 0; i < a.size(); ++i) {
    const double v = a.data()[i];
    if (!(v >= 0 && v <= max_value && v == std::floor(v))) {
      const std::vector<py::ssize_t> shape(a.shape(), a.shape() + a.ndim());
      throw pvdf::InputError(what + index_text(i, shape) + " = " + pvdf::format_g(v) + " must be a whole number in [0, " +
                             std::to_string(max_value) + "]; " + meaning);
    }
    out[std::size_t(i)] = std::uint8_t(v);
  }
  return out;
}

}  // namespace pvdf::python::arg
