// Charge maps (HDF5 through the C++ reader and writer), the lookup over numpy arrays of charges,
// synthetic stand-in maps, calibration presses and the layout evaluation.
#include "arguments.hpp"
#include "bindings.hpp"
#include "results.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"
#include "pvdf/core/json_reader.hpp"
#include "pvdf/mapping/calibration.hpp"
#include "pvdf/mapping/design.hpp"
#include "pvdf/mapping/locator.hpp"
#include "pvdf/mapping/map.hpp"
#include "pvdf/mapping/map_io.hpp"

#include <cmath>
#include <limits>
#include <optional>

namespace pvdf::python {
namespace {

using pvdf::mapping::ChargeMap;
using pvdf::mapping::Location;

/// A read-only numpy copy: an in-place edit (m.charge_C[0, 0, 0, 0] = 1) raises numpy's "assignment
/// destination is read-only" instead of changing a temporary copy silently; assign a whole array
/// (m.charge_C = q) to change a map.
template <class T>
py::array_t<T> read_only(const std::vector<T>& values, std::vector<py::ssize_t> shape) {
  py::array_t<T> out = to_array(values, std::move(shape));
  out.attr("setflags")(py::arg("write") = false);
  return out;
}

/// A float64 property of ChargeMap holding a flattened array shown with shape `shape(map)`. The
/// setter takes any numeric array-like of finite values (checked by arg::array; NaN also where
/// `allow_nan`: the results hold NaN at points that did not converge).
template <class Shape>
void array_property(py::class_<ChargeMap>& c, const char* name, std::vector<double> ChargeMap::*member, Shape shape,
                    bool allow_nan, const char* fix, const char* doc) {
  const std::string what = std::string("ChargeMap.") + name;
  c.def_property(
      name, [=](const ChargeMap& m) { return read_only(m.*member, shape(m)); },
      [=](ChargeMap& m, py::object value) {
        const DoubleArray a = arg::array(value, what, {false, true, fix, allow_nan});
        (m.*member).assign(a.data(), a.data() + a.size());
      },
      doc);
}

/// A uint8 property (mask, status): whole numbers in [0, max_value].
template <class Shape>
void code_property(py::class_<ChargeMap>& c, const char* name, std::vector<std::uint8_t> ChargeMap::*member, Shape shape,
                   int max_value, const char* meaning, const char* doc) {
  const std::string what = std::string("ChargeMap.") + name;
  c.def_property(
      name, [=](const ChargeMap& m) { return read_only(m.*member, shape(m)); },
      [=](ChargeMap& m, py::object value) { m.*member = arg::small_integers(value, what, max_value, meaning); }, doc);
}

/// A relative error attribute: None (unknown, stored as NaN as in the file format) or finite >= 0.
void error_property(py::class_<ChargeMap>& c, const char* name, double ChargeMap::*member, const char* doc) {
  const std::string what = std::string("ChargeMap.") + name;
  c.def_property(
      name, [=](const ChargeMap& m) -> py::object {
        return std::isnan(m.*member) ? py::object(py::none()) : py::object(py::float_(m.*member));
      },
      [=](ChargeMap& m, py::object value) {
        m.*member = value.is_none() ? std::numeric_limits<double>::quiet_NaN()
                                    : arg::number_in(value, what, 0, 1e6, "(a relative error; None = unknown)");
      },
      doc);
}

/// A string attribute.
void text_property(py::class_<ChargeMap>& c, const char* name, std::string ChargeMap::*member, const char* doc) {
  const std::string what = std::string("ChargeMap.") + name;
  c.def_property(
      name, [=](const ChargeMap& m) { return m.*member; },
      [=](ChargeMap& m, py::object value) { m.*member = arg::text(value, what); }, doc);
}

/// "" or a JSON object: the scene the map was computed for. Checked where it is set and again
/// before a map is written (a map read from a file is not re-parsed until written).
void check_scene_json(const std::string& text, const std::string& what) {
  if (text.empty()) return;
  const nlohmann::json j = pvdf::parse_json_text(text, what);
  if (!j.is_object()) {
    throw pvdf::InputError(what + " must be a JSON object (the scene's keys), e.g. scene.to_dict() as json.dumps; got " +
                           pvdf::escape_control_bytes(text.substr(0, 40)));
  }
}

/// noise_C: one 1-sigma noise (C) for every electrode or one per electrode, each in `range`.
std::vector<double> noise_list(py::object value, const std::string& what, bool below_1e6) {
  if (value.is_none()) return {};
  const auto v = arg::vector(value, what, {false, true, "give 1-sigma charge noise in C, one value or one per electrode"});
  for (std::size_t k = 0; k < v.size(); ++k) {
    if (!(v[k] > 0) || (below_1e6 && !(v[k] < 1e-6))) {
      throw pvdf::InputError(what + "[" + std::to_string(k) + "] = " + pvdf::format_g(v[k]) +
                             (below_1e6 ? " must lie in (0, 1e-6) C (a 1-sigma charge noise)" : " must be > 0 (C, a 1-sigma charge noise)"));
    }
  }
  return v;
}

/// `call` (Locator::predict or Locator::charge_error) at every press (x_m[i], y_m[i], force_N[i] or
/// one force for all), checked as `what`: shape (N, n_electrodes), NaN off the map.
py::array_t<double> per_press(const pvdf::mapping::Locator& loc, py::object x_m, py::object y_m, py::object force_N, const std::string& what,
                              bool (pvdf::mapping::Locator::*call)(double, double, double, double*) const) {
  const auto xs = arg::vector(x_m, what + ": x_m", {false, true, "give positions in m"});
  const auto ys = arg::vector(y_m, what + ": y_m", {false, true, "give positions in m"});
  auto fs = arg::vector(force_N, what + ": force_N", {false, true, "give forces in N"});
  if (xs.size() != ys.size()) {
    throw pvdf::InputError(what + ": x_m has " + std::to_string(xs.size()) + " values and y_m " +
                           std::to_string(ys.size()) + "; give one y_m per x_m");
  }
  if (fs.size() == 1) fs.assign(xs.size(), fs[0]);
  if (fs.size() != xs.size()) {
    throw pvdf::InputError(what + ": force_N has " + std::to_string(fs.size()) + " values for " +
                           std::to_string(xs.size()) + " positions; give one value or one per position");
  }
  for (std::size_t i = 0; i < fs.size(); ++i) {
    if (!(fs[i] > 0 && fs[i] <= 1e4)) {
      throw pvdf::InputError(what + ": force_N[" + std::to_string(i) + "] = " + pvdf::format_g(fs[i]) +
                             " must lie in (0, 1e4] N");
    }
  }
  const std::size_t ne = loc.n_electrodes();
  py::array_t<double> out({py::ssize_t(xs.size()), py::ssize_t(ne)});
  double* p = out.mutable_data();
  for (std::size_t i = 0; i < xs.size(); ++i, p += ne) {
    if (!(loc.*call)(xs[i], ys[i], fs[i], p)) std::fill(p, p + ne, std::numeric_limits<double>::quiet_NaN());
  }
  return out;
}

const char* map_expected = "a pvdfkit.ChargeMap (from read_map, generate_map or synthetic_map)";

void bind_charge_map(py::module_& m) {
  py::class_<ChargeMap> c(m, "ChargeMap", R"doc(A charge map: every electrode's charge for a probe at every grid position and force level.

Arrays (SI units): x_m (nx,), y_m (ny,), forces_N (nf,), mask (ny, nx) uint8 (1 = mapped),
charge_C (nf, ny, nx, n_electrodes) (C), deflection_at_load_m (nf, ny, nx) (m), status
(nf, ny, nx) uint8 (0 ok, 1 not_converged, 2 outside, 3 not_computed), electrode_centers_m
(n_electrodes, 2), noise_C (n_electrodes,) (C, 1-sigma).

Reading an array attribute gives a read-only copy: ``m.charge_C[0, 0, 0, 0] = 1`` raises numpy's
"assignment destination is read-only" rather than editing a copy that is then discarded. To change
a map assign a whole array: ``q = m.charge_C.copy(); q[...] = ...; m.charge_C = q``. Every
assignment is checked (numeric dtype, finite values; NaN allowed in charge_C and
deflection_at_load_m, where points that did not converge hold it) and raises InputError naming the
attribute; pvdfkit.write_map checks shapes and values as the C++ writer does.)doc");
  c.def(py::init<>(), "An empty map: set the axes, electrodes and results, then write_map.")
      .def_property_readonly("nx", &ChargeMap::nx)
      .def_property_readonly("ny", &ChargeMap::ny)
      .def_property_readonly("nf", &ChargeMap::nf)
      .def_property_readonly("n_electrodes", &ChargeMap::ne)
      .def_property(
          "scene_json", [](const ChargeMap& m) { return m.scene_json; },
          [](ChargeMap& m, py::object value) {
            std::string text = arg::text(value, "ChargeMap.scene_json");
            check_scene_json(text, "ChargeMap.scene_json");
            m.scene_json = std::move(text);
          },
          "the scene the map was computed for, as JSON text ('' = unknown)")
      .def_property(
          "tolerance", [](const ChargeMap& m) { return m.tolerance; },
          [](ChargeMap& m, py::object value) {
            m.tolerance = arg::number_in(value, "ChargeMap.tolerance", 0, 0.5, "(requested relative charge error; 0 = none)");
          },
          "requested relative error of the computed charges")
      .def_property(
          "rim_margin_m", [](const ChargeMap& m) { return m.rim_margin_m; },
          [](ChargeMap& m, py::object value) { m.rim_margin_m = arg::number_in(value, "ChargeMap.rim_margin_m", 0, 1, "m"); },
          "positions closer than this to the rim are masked out (m)")
      .def_property(
          "electrode_names", [](const ChargeMap& m) { return m.electrode_names; },
          [](ChargeMap& m, py::object value) { m.electrode_names = arg::texts(value, "ChargeMap.electrode_names"); },
          "electrode names, in the order of the charge columns")
      .def_property(
          "electrode_centers_m", [](const ChargeMap& m) {
            py::array_t<double> out = to_array(m.electrode_centers_m);
            out.attr("setflags")(py::arg("write") = false);
            return out;
          },
          [](ChargeMap& m, py::object a) {
            m.electrode_centers_m = arg::points(a, "ChargeMap.electrode_centers_m", {false, true, "give one [x_m, y_m] per electrode"});
          },
          "centroid of each electrode (m), shape (n_electrodes, 2)")
      .def_property_readonly("calibration", [](const ChargeMap& m) -> py::object {
        if (!m.calibration) return py::none();
        py::dict d;
        d["gain"] = to_array(m.calibration->gain);
        d["offset_C"] = to_array(m.calibration->offset_C);
        d["source"] = m.calibration->source;
        return d;
      }, "None, or the fitted per-electrode gain and offset_C (C)")
      .def("allocate", &ChargeMap::allocate, "Sizes the result arrays for the axes, forces and electrodes (status = not_computed).")
      .def("__repr__", [](const ChargeMap& m) {
        return "<ChargeMap " + std::to_string(m.nx()) + " x " + std::to_string(m.ny()) + " positions, " +
               std::to_string(m.nf()) + " force levels, " + std::to_string(m.ne()) + " electrodes, model " + m.model + ">";
      });
  text_property(c, "pvdfkit_version", &ChargeMap::pvdfkit_version, "version of pvdfkit that wrote the map");
  text_property(c, "model", &ChargeMap::model, "kinematics/model used ('von-karman', 'synthetic-analytic', ...)");
  text_property(c, "description", &ChargeMap::description, "free text");
  error_property(c, "estimated_relative_error", &ChargeMap::estimated_relative_error,
                 "estimated relative error of the charges (largest per-node estimate); None = unknown");
  error_property(c, "estimated_deflection_relative_error", &ChargeMap::estimated_deflection_relative_error,
                 "estimated relative error of deflection_at_load_m; None = unknown");
  const auto flat = [](std::size_t n) { return std::vector<py::ssize_t>{py::ssize_t(n)}; };
  array_property(c, "x_m", &ChargeMap::x_m, [=](const ChargeMap& m) { return flat(m.nx()); }, false,
                 "give the grid x in m, ascending and equally spaced", "grid x (m), shape (nx,)");
  array_property(c, "y_m", &ChargeMap::y_m, [=](const ChargeMap& m) { return flat(m.ny()); }, false,
                 "give the grid y in m, ascending and equally spaced", "grid y (m), shape (ny,)");
  array_property(c, "forces_N", &ChargeMap::forces_N, [=](const ChargeMap& m) { return flat(m.nf()); }, false,
                 "give the force levels in N, ascending and > 0", "force levels (N), shape (nf,)");
  array_property(c, "noise_C", &ChargeMap::noise_C, [=](const ChargeMap& m) { return flat(m.noise_C.size()); }, false,
                 "give one 1-sigma charge noise in C per electrode", "1-sigma charge noise per electrode (C)");
  const auto grid = [](const ChargeMap& m) { return std::vector<py::ssize_t>{py::ssize_t(m.ny()), py::ssize_t(m.nx())}; };
  const auto points = [](const ChargeMap& m) {
    return std::vector<py::ssize_t>{py::ssize_t(m.nf()), py::ssize_t(m.ny()), py::ssize_t(m.nx())};
  };
  // A shape that does not match the axes (e.g. while the user is still assigning them) is shown flat.
  const auto or_flat = [](auto shape) {
    return [shape](const ChargeMap& m, std::size_t size) {
      auto s = shape(m);
      py::ssize_t n = 1;
      for (auto d : s) n *= d;
      return n == py::ssize_t(size) ? s : std::vector<py::ssize_t>{py::ssize_t(size)};
    };
  };
  const auto grid_s = or_flat(grid);
  const auto points_s = or_flat(points);
  const auto charges_s = or_flat([](const ChargeMap& m) {
    return std::vector<py::ssize_t>{py::ssize_t(m.nf()), py::ssize_t(m.ny()), py::ssize_t(m.nx()), py::ssize_t(m.ne())};
  });
  code_property(c, "mask", &ChargeMap::mask, [=](const ChargeMap& m) { return grid_s(m, m.mask.size()); }, 1,
                "1 = mapped position, 0 = not", "1 = mapped position, uint8 shape (ny, nx)");
  array_property(c, "charge_C", &ChargeMap::charge_C, [=](const ChargeMap& m) { return charges_s(m, m.charge_C.size()); },
                 true, "give charges in C, shape (nf, ny, nx, n_electrodes)", "charges (C), shape (nf, ny, nx, n_electrodes)");
  array_property(c, "deflection_at_load_m", &ChargeMap::deflection_at_load_m,
                 [=](const ChargeMap& m) { return points_s(m, m.deflection_at_load_m.size()); }, true,
                 "give deflections in m, shape (nf, ny, nx)", "w at the probe (m), shape (nf, ny, nx)");
  code_property(c, "status", &ChargeMap::status, [=](const ChargeMap& m) { return points_s(m, m.status.size()); }, 3,
                "0 ok, 1 not_converged, 2 outside, 3 not_computed",
                "point status, uint8 shape (nf, ny, nx): 0 ok, 1 not_converged, 2 outside, 3 not_computed");

  m.def("read_map", [](py::object path) { return pvdf::mapping::read_map(arg::path(path, "read_map: path")); },
        py::arg("path"), "Reads and validates an HDF5 charge map (InputError naming the dataset at fault).");
  m.def("write_map", [](py::object path, py::object map_arg) {
          const std::string p = arg::output_file(path, "write_map: path");
          const ChargeMap& map = arg::object<ChargeMap>(map_arg, "write_map: map", map_expected);
          check_scene_json(map.scene_json, "write_map: map.scene_json");
          pvdf::mapping::write_map(p, map);
        },
        py::arg("path"), py::arg("map"), "Validates and writes a map atomically (HDF5).");
  m.def("validate_map", [](py::object map_arg, py::object source) {
          const ChargeMap& map = arg::object<ChargeMap>(map_arg, "validate_map: map", map_expected);
          const std::string name = arg::text(source, "validate_map: source");
          check_scene_json(map.scene_json, name + ": scene_json");
          pvdf::mapping::validate(map, name);
        },
        py::arg("map"), py::arg("source") = "map", "Checks shapes, axes and values; InputError naming the dataset at fault.");
  m.def("synthetic_map", [](py::object scene, py::object spacing_m, py::object force_N, py::object noise_C) {
          const std::string f = "synthetic_map: ";
          const pvdf::Scene s = arg::scene(scene, f + "scene");
          const double spacing = arg::number_in(spacing_m, f + "spacing_m", 1e-4, 0.02, "m");
          const double force = arg::number_in(force_N, f + "force_N", 0, 1e4, "N (a press pushes the film)", true);
          const double noise = arg::number_in(noise_C, f + "noise_C", 0, 1e-6, "C (a 1-sigma charge noise)", true);
          return pvdf::mapping::synthetic_map_for_scene(s, spacing, force, noise);
        },
        py::arg("scene"), py::arg("spacing_m") = 0.001, py::arg("force_N") = 1.0, py::arg("noise_C") = 0.05e-12,
        "The analytic stand-in map of a scene's layout (seconds, not an FEM prediction): grid step spacing_m (m, in "
        "[1e-4, 0.02]), one force level force_N (N), noise_C (C, in (0, 1e-6]) on every channel; the ranges of "
        "`pvdfkit synthetic-map`.");
}

/// A force argument of the lookup where 0 (or None) means "not given": else finite and in (0, 1e4] N.
double optional_force(py::object value, const std::string& what, const std::string& zero_means) {
  if (value.is_none()) return 0.0;
  const double f = arg::number(value, what, "(N; 0 or None = " + zero_means + ")");
  if (f == 0.0) return 0.0;
  if (!(f > 0 && f <= 1e4)) {
    throw pvdf::InputError(what + " = " + pvdf::format_g(f) + " must lie in (0, 1e4] N, or be 0 or None (" + zero_means + ")");
  }
  return f;
}

void bind_locator(py::module_& m) {
  using pvdf::mapping::Locator;
  py::dict flags;
  flags["outside_map"] = pvdf::mapping::flag::outside_map;
  flags["ambiguous"] = pvdf::mapping::flag::ambiguous;
  flags["no_press"] = pvdf::mapping::flag::no_press;
  flags["poor_fit"] = pvdf::mapping::flag::poor_fit;
  flags["force_extrapolated"] = pvdf::mapping::flag::force_extrapolated;
  flags["scaling_assumed"] = pvdf::mapping::flag::scaling_assumed;
  flags["not_converged"] = pvdf::mapping::flag::not_converged;
  flags["ill_conditioned"] = pvdf::mapping::flag::ill_conditioned;
  m.attr("FLAGS") = flags;
  m.def("flags_text", [](py::object flags_arg) {
          return pvdf::mapping::flags_text(std::uint32_t(arg::integer_in(flags_arg, "flags_text: flags", 0, 0xffffffffLL)));
        },
        py::arg("flags"), "'ok' or the set flag names joined by '|'.");

  py::class_<Locator>(m, "Locator", R"doc(The lookup: from the charges of a pressed sensor to where and how hard it was pressed.

Built once from a ChargeMap (coarse table + smooth interpolant), then ``locate`` takes an
(N, n_electrodes) array of charges (C) and returns Locations (arrays of length N, with 1-sigma
values and flags). Every option is checked when the Locator is made, and every charge when it is
located (a NaN or inf charge is refused naming its row and column, never turned into a flag).
Thread-safe in C++; the GIL is released while locating.)doc")
      .def(py::init([](py::object map_arg, py::object noise_C, py::object use_calibration, py::object known_force_N,
                       py::object min_force_N, py::object max_force_N, py::object chi2_limit, py::object max_starts,
                       py::object max_iterations, py::object no_press_snr) {
             const std::string f = "Locator: ";
             const ChargeMap& map = arg::object<ChargeMap>(map_arg, f + "map", map_expected);
             // A map assembled in Python may be inconsistent (sizes, axes): checked as the reader checks a
             // file, before the Locator indexes into it.
             pvdf::mapping::validate(map, f + "map");
             pvdf::mapping::LocatorOptions o;
             o.noise_C = noise_list(noise_C, f + "noise_C", true);
             if (!o.noise_C.empty() && o.noise_C.size() != 1 && o.noise_C.size() != map.ne()) {
               throw pvdf::InputError(f + "noise_C has " + std::to_string(o.noise_C.size()) + " values; give 1 or " +
                                      std::to_string(map.ne()) + " (one per electrode) in C");
             }
             o.use_calibration = arg::flag(use_calibration, f + "use_calibration");
             o.known_force_N = optional_force(known_force_N, f + "known_force_N", "the force is unknown");
             o.min_force_N = optional_force(min_force_N, f + "min_force_N", "half the map's lowest level");
             o.max_force_N = optional_force(max_force_N, f + "max_force_N", "twice the map's highest level");
             if (o.min_force_N > 0 && o.max_force_N > 0 && !(o.min_force_N < o.max_force_N)) {
               throw pvdf::InputError(f + "min_force_N = " + pvdf::format_g(o.min_force_N) + " and max_force_N = " +
                                      pvdf::format_g(o.max_force_N) + ": need 0 < min_force_N < max_force_N (N)");
             }
             o.chi2_limit = arg::number_in(chi2_limit, f + "chi2_limit", 0, 1e12,
                                           "(0 = automatic, about 11 for three electrodes; else the chi^2 above which a fit is not within noise)");
             if (o.chi2_limit != 0 && !(o.chi2_limit > 0)) throw pvdf::InputError(f + "chi2_limit must be 0 (automatic) or > 0");
             o.max_starts = int(arg::integer_in(max_starts, f + "max_starts", 1, Location::max_solutions,
                                                "(Levenberg-Marquardt starts per press)"));
             o.max_iterations = int(arg::integer_in(max_iterations, f + "max_iterations", 1, 10000, "(iterations per start)"));
             o.no_press_snr = arg::number_in(no_press_snr, f + "no_press_snr", 0, 1e6,
                                             "(RMS signal-to-noise below which a sample is no_press; 0 = never)");
             py::gil_scoped_release release;
             return std::make_unique<Locator>(map, o);
           }),
           py::arg("map"), py::arg("noise_C") = py::none(), py::arg("use_calibration") = true, py::arg("known_force_N") = py::none(),
           py::arg("min_force_N") = py::none(), py::arg("max_force_N") = py::none(), py::arg("chi2_limit") = 0.0,
           py::arg("max_starts") = 6, py::arg("max_iterations") = 40, py::arg("no_press_snr") = 3.0,
           "noise_C: 1-sigma charge noise (C, > 0), one value or one per electrode (default: the map's); known_force_N: "
           "fit (x, y) only at this force (N, in (0, 1e4]; None or 0 = unknown); min/max_force_N: plausible force range "
           "(N; None or 0 = from the map's levels); chi2_limit: >= 0, 0 = automatic; max_starts: 1..8; max_iterations: "
           "1..10000; no_press_snr: >= 0 (0 = never no_press).")
      .def("locate", [](const Locator& loc, py::object charges_C, py::object known_force_N) {
             const std::size_t ne = loc.n_electrodes();
             const std::string columns = "charges in C, one column per electrode (" + [&] {
               std::string names;
               for (const auto& n : loc.electrode_names()) names += (names.empty() ? "" : ", ") + n;
               return names;
             }() + ")";
             const DoubleArray q_rows = arg::rows(charges_C, "Locator.locate: charges_C", ne, columns,
                                                 {true, true, "give measured charges in C (finite); repair or drop the row"});
             const std::size_t n = std::size_t(q_rows.shape(0));
             std::vector<double> forces;
             if (!known_force_N.is_none()) {
               forces = arg::vector(known_force_N, "Locator.locate: known_force_N",
                                    {false, true, "give the known force in N, one value or one per row (None = unknown)"});
               if (forces.size() == 1) forces.assign(n, forces[0]);
               if (forces.size() != n) {
                 throw pvdf::InputError("Locator.locate: known_force_N has " + std::to_string(forces.size()) +
                                        " values for " + std::to_string(n) + " rows of charges; give one or one per row");
               }
               for (std::size_t i = 0; i < n; ++i) {
                 if (!(forces[i] > 0 && forces[i] <= 1e4)) {
                   throw pvdf::InputError("Locator.locate: known_force_N[" + std::to_string(i) + "] = " + pvdf::format_g(forces[i]) +
                                          " must lie in (0, 1e4] N; give None where the force is unknown");
                 }
               }
             }
             LocationBatch batch;
             batch.items.resize(n);
             const double* q = q_rows.data();
             py::gil_scoped_release release;
             for (std::size_t i = 0; i < n; ++i) {
               batch.items[i] = forces.empty() ? loc.locate(q + i * ne) : loc.locate(q + i * ne, forces[i]);
             }
             return batch;
           },
           py::arg("charges_C"), py::arg("known_force_N") = py::none(),
           "Locates N presses: charges_C (C, finite) of shape (N, n_electrodes) (or (n_electrodes,) for one; (0, "
           "n_electrodes) gives an empty result); known_force_N (N): None (unknown), one value or one per row, each in "
           "(0, 1e4]. Returns Locations.")
      .def("predict", [](const Locator& loc, py::object x_m, py::object y_m, py::object force_N) {
             return per_press(loc, x_m, y_m, force_N, "Locator.predict", &Locator::predict);
           },
           py::arg("x_m"), py::arg("y_m"), py::arg("force_N") = 1.0,
           "The map's (calibrated) charges (C) for presses at (x_m, y_m) (m) with force_N (N): shape (N, n_electrodes), NaN off the map.")
      .def("charge_error", [](const Locator& loc, py::object x_m, py::object y_m, py::object force_N) {
             return per_press(loc, x_m, y_m, force_N, "Locator.charge_error", &Locator::charge_error);
           },
           py::arg("x_m"), py::arg("y_m"), py::arg("force_N") = 1.0,
           "The map's own error (C, 1-sigma) that the lookup adds to the charge noise for presses at (x_m, y_m) (m) with "
           "force_N (N): the node estimate and the error between nodes and force levels in quadrature (docs/lookup.md "
           "section 1.10), shape (N, n_electrodes), NaN off the map.")
      .def_property_readonly("n_electrodes", &Locator::n_electrodes)
      .def_property_readonly("electrode_names", &Locator::electrode_names)
      .def_property_readonly("noise_C", [](const Locator& l) { return to_array(l.noise_C()); }, "1-sigma noise per electrode (C)")
      .def_property_readonly("chi2_limit", &Locator::chi2_limit)
      .def_property_readonly("calibrated", &Locator::calibrated);
}

void bind_design_and_measurements(py::module_& m) {
  m.def("design", [](py::object map_arg, py::object force_N, py::object min_force_N, py::object max_force_N,
                     py::object noise_C, py::object target_m, py::object force_known, py::object adc_bits,
                     py::object full_scale_C, py::object check_ambiguity) {
          const std::string f = "design: ";
          const ChargeMap& map = arg::object<ChargeMap>(map_arg, f + "map", map_expected);
          pvdf::mapping::validate(map, f + "map");  // as Locator: a map assembled in Python may be inconsistent
          pvdf::mapping::DesignOptions o = design_options_arg(force_N, min_force_N, max_force_N, noise_C, target_m,
                                                             force_known, adc_bits, full_scale_C, f);
          o.check_ambiguity = arg::flag(check_ambiguity, f + "check_ambiguity");
          py::gil_scoped_release release;
          return pvdf::mapping::evaluate_design(map, o);
        },
        py::arg("map"), py::arg("force_N") = 1.0, py::arg("min_force_N") = 0.25, py::arg("max_force_N") = 4.0,
        py::arg("noise_C") = py::none(), py::arg("target_m") = 0.5e-3, py::arg("force_known") = false,
        py::arg("adc_bits") = 12, py::arg("full_scale_C") = 0.0, py::arg("check_ambiguity") = true,
        R"doc(Evaluates a layout from its charge map (what ``pvdfkit design`` does, with its defaults and checks):
Cramer-Rao position and force bounds, ambiguity, dead zones and the ADC, at presses of force_N (N, in
(0, 1e4]). min/max_force_N: the forces served (N, 0 < min < max); target_m: position-error target
(m, in (0, 1]); noise_C (C, each in (0, 1e-6)): one value or one per electrode (default: the map's);
adc_bits: 0 (ideal) or 2..32; full_scale_C: 0 (automatic) or up to 1e-3 C. Returns DesignSummary.)doc");

  m.def("rank_designs", [](py::object summaries_arg) {
          const std::string f = "rank_designs: summaries";
          if (!py::isinstance<py::sequence>(summaries_arg) || py::isinstance<py::str>(summaries_arg)) {
            throw pvdf::InputError(f + " must be a list of DesignSummary (what pvdfkit.design returns)");
          }
          std::vector<pvdf::mapping::DesignSummary> summaries;
          for (py::handle item : summaries_arg) {
            if (!py::isinstance<pvdf::mapping::DesignSummary>(item)) {
              throw pvdf::InputError(f + " item " + std::to_string(summaries.size()) +
                                     " is not a DesignSummary: give what pvdfkit.design returns");
            }
            summaries.push_back(item.cast<pvdf::mapping::DesignSummary>());
          }
          return pvdf::mapping::rank_designs(summaries);
        },
        py::arg("summaries"),
        R"doc(Orders layouts best first by ``pvdfkit design``'s rule (one rule, the library's): a layout that can
locate before one that cannot, then the larger usable fraction (figure_of_merit), then the larger
coverage, then the smaller median sigma_pos; equal layouts keep their order. summaries: a list of
DesignSummary (pvdfkit.design). Returns the list of indices, best first.)doc");

  m.def("read_measurements", [](py::object path_arg, py::object names_arg) {
          const std::string path = arg::path(path_arg, "read_measurements: path");
          const std::vector<std::string> electrode_names = arg::texts(names_arg, "read_measurements: electrode_names");
          if (electrode_names.empty()) {
            throw pvdf::InputError("read_measurements: electrode_names is empty; give the map's electrode names, e.g. m.electrode_names");
          }
          pvdf::check_csv_file(path, "read_measurements: path");  // rows, cells, NUL bytes: as compare and calibrate
          const auto rows = pvdf::mapping::read_measurements(path, electrode_names);
          std::vector<double> x, y, f, q;
          std::vector<std::int64_t> line;
          for (const auto& r : rows) {
            x.push_back(r.x_m);
            y.push_back(r.y_m);
            f.push_back(r.force_N);
            q.insert(q.end(), r.charge_C.begin(), r.charge_C.end());
            line.push_back(std::int64_t(r.line));
          }
          py::dict d;
          d["x_m"] = to_array(x);
          d["y_m"] = to_array(y);
          d["force_N"] = to_array(f);
          d["charge_C"] = to_array(q, {py::ssize_t(rows.size()), py::ssize_t(electrode_names.size())});
          d["line"] = to_array(line);
          return d;
        },
        py::arg("path"), py::arg("electrode_names"),
        "Reads a press CSV `x_m,y_m,force_N,charge_<name>_C...` (as `pvdfkit calibrate` and `compare` do): a dict of "
        "x_m, y_m (m), force_N (N), charge_C (N, n_electrodes) (C) in electrode_names order, and line (file line).");
}

}  // namespace

pvdf::mapping::DesignOptions design_options_arg(py::object force_N, py::object min_force_N, py::object max_force_N,
                                                py::object noise_C, py::object target_m, py::object force_known,
                                                py::object adc_bits, py::object full_scale_C, const std::string& f) {
  // Types here; the rules are the command's, in one function (check_design_options), whose
  // messages name each keyword after the function's name ("design: adc_bits = 1").
  pvdf::mapping::DesignOptions o;
  o.force_N = arg::number(force_N, f + "force_N", "(N)");
  o.min_force_N = arg::number(min_force_N, f + "min_force_N", "(N)");
  o.max_force_N = arg::number(max_force_N, f + "max_force_N", "(N)");
  if (!noise_C.is_none()) o.noise_C = arg::vector(noise_C, f + "noise_C", {false, true, "give 1-sigma charge noise in C, one value or one per electrode"});
  o.target_m = arg::number(target_m, f + "target_m", "(m)");
  o.force_known = arg::flag(force_known, f + "force_known");
  const long long int_max = std::numeric_limits<int>::max();
  o.adc_bits = int(arg::integer_in(adc_bits, f + "adc_bits", -int_max, int_max, "(0 = ideal)"));
  o.full_scale_C = arg::number(full_scale_C, f + "full_scale_C", "(C)");
  try {
    pvdf::mapping::check_design_options(o);  // named as the keywords: "adc_bits = 1"
  } catch (const pvdf::InputError& e) {
    throw pvdf::InputError(f + e.what());
  }
  return o;
}

void bind_maps(py::module_& m) {
  bind_charge_map(m);
  bind_locator(m);
  bind_design_and_measurements(m);
}

}  // namespace pvdf::python
