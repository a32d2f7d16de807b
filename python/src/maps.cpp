// Charge maps (HDF5 through the C++ reader and writer), the lookup over numpy arrays of charges,
// synthetic stand-in maps, calibration presses and the layout evaluation.
#include "bindings.hpp"
#include "results.hpp"

#include "pvdf/core/error.hpp"
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

/// A property of ChargeMap holding a flattened array shown with shape `shape(map)`.
template <class T, class Shape>
void array_property(py::class_<ChargeMap>& c, const char* name, std::vector<T> ChargeMap::*member, Shape shape,
                    const char* doc) {
  c.def_property(
      name, [=](const ChargeMap& m) { return to_array(m.*member, shape(m)); },
      [=](ChargeMap& m, const py::array_t<T, py::array::c_style | py::array::forcecast>& a) {
        (m.*member).assign(a.data(), a.data() + a.size());
      },
      doc);
}

/// One noise value for every electrode (scalar) or one per electrode.
std::vector<double> noise_list(const std::optional<DoubleArray>& a) {
  return a ? to_vector(*a, "noise_C") : std::vector<double>{};
}

void bind_charge_map(py::module_& m) {
  py::class_<ChargeMap> c(m, "ChargeMap", R"doc(A charge map: every electrode's charge for a probe at every grid position and force level.

Arrays (SI units): x_m (nx,), y_m (ny,), forces_N (nf,), mask (ny, nx) uint8 (1 = mapped),
charge_C (nf, ny, nx, n_electrodes) (C), deflection_at_load_m (nf, ny, nx) (m), status
(nf, ny, nx) uint8 (0 ok, 1 not_converged, 2 outside, 3 not_computed), electrode_centers_m
(n_electrodes, 2), noise_C (n_electrodes,) (C, 1-sigma). Every array attribute can be assigned
(any array-like of the right size); pvdfkit.write_map checks shapes and values as the C++ writer does.)doc");
  c.def(py::init<>(), "An empty map: set the axes, electrodes and results, then write_map.")
      .def_readwrite("scene_json", &ChargeMap::scene_json)
      .def_readwrite("pvdfkit_version", &ChargeMap::pvdfkit_version)
      .def_readwrite("model", &ChargeMap::model)
      .def_readwrite("tolerance", &ChargeMap::tolerance)
      .def_readwrite("estimated_relative_error", &ChargeMap::estimated_relative_error, "of the charges (NaN = unknown)")
      .def_readwrite("estimated_deflection_relative_error", &ChargeMap::estimated_deflection_relative_error)
      .def_readwrite("rim_margin_m", &ChargeMap::rim_margin_m)
      .def_readwrite("description", &ChargeMap::description)
      .def_readwrite("electrode_names", &ChargeMap::electrode_names)
      .def_property_readonly("nx", &ChargeMap::nx)
      .def_property_readonly("ny", &ChargeMap::ny)
      .def_property_readonly("nf", &ChargeMap::nf)
      .def_property_readonly("n_electrodes", &ChargeMap::ne)
      .def_property(
          "electrode_centers_m", [](const ChargeMap& m) { return to_array(m.electrode_centers_m); },
          [](ChargeMap& m, const DoubleArray& a) { m.electrode_centers_m = to_points(a, "ChargeMap.electrode_centers_m"); },
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
  array_property(c, "x_m", &ChargeMap::x_m, [](const ChargeMap& m) { return std::vector<py::ssize_t>{py::ssize_t(m.nx())}; }, "grid x (m), shape (nx,)");
  array_property(c, "y_m", &ChargeMap::y_m, [](const ChargeMap& m) { return std::vector<py::ssize_t>{py::ssize_t(m.ny())}; }, "grid y (m), shape (ny,)");
  array_property(c, "forces_N", &ChargeMap::forces_N, [](const ChargeMap& m) { return std::vector<py::ssize_t>{py::ssize_t(m.nf())}; }, "force levels (N), shape (nf,)");
  array_property(c, "noise_C", &ChargeMap::noise_C, [](const ChargeMap& m) { return std::vector<py::ssize_t>{py::ssize_t(m.noise_C.size())}; }, "1-sigma charge noise per electrode (C)");
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
  array_property(c, "mask", &ChargeMap::mask, [=](const ChargeMap& m) { return grid_s(m, m.mask.size()); }, "1 = mapped position, uint8 shape (ny, nx)");
  array_property(c, "charge_C", &ChargeMap::charge_C, [=](const ChargeMap& m) { return charges_s(m, m.charge_C.size()); }, "charges (C), shape (nf, ny, nx, n_electrodes)");
  array_property(c, "deflection_at_load_m", &ChargeMap::deflection_at_load_m, [=](const ChargeMap& m) { return points_s(m, m.deflection_at_load_m.size()); }, "w at the probe (m), shape (nf, ny, nx)");
  array_property(c, "status", &ChargeMap::status, [=](const ChargeMap& m) { return points_s(m, m.status.size()); }, "point status, uint8 shape (nf, ny, nx): 0 ok, 1 not_converged, 2 outside, 3 not_computed");

  m.def("read_map", &pvdf::mapping::read_map, py::arg("path"), "Reads and validates an HDF5 charge map (InputError naming the dataset at fault).");
  m.def("write_map", &pvdf::mapping::write_map, py::arg("path"), py::arg("map"), "Validates and writes a map atomically (HDF5).");
  m.def("validate_map", [](const ChargeMap& map, const std::string& source) { pvdf::mapping::validate(map, source); },
        py::arg("map"), py::arg("source") = "map", "Checks shapes, axes and values; InputError naming the dataset at fault.");
  m.def("synthetic_map", [](const pvdf::Scene& scene, double spacing_m, double force_N, double noise_C) {
          return pvdf::mapping::synthetic_map_for_scene(scene, spacing_m, force_N, noise_C);
        },
        py::arg("scene"), py::arg("spacing_m") = 0.001, py::arg("force_N") = 1.0, py::arg("noise_C") = 0.05e-12,
        "The analytic stand-in map of a scene's layout (seconds, not an FEM prediction): grid step spacing_m (m), "
        "one force level force_N (N), noise_C (C) on every channel.");
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
  m.def("flags_text", &pvdf::mapping::flags_text, py::arg("flags"), "'ok' or the set flag names joined by '|'.");

  py::class_<Locator>(m, "Locator", R"doc(The lookup: from the charges of a pressed sensor to where and how hard it was pressed.

Built once from a ChargeMap (coarse table + smooth interpolant), then ``locate`` takes an
(N, n_electrodes) array of charges (C) and returns Locations (arrays of length N, with 1-sigma
values and flags). Thread-safe in C++; the GIL is released while locating.)doc")
      .def(py::init([](const ChargeMap& map, const std::optional<DoubleArray>& noise_C, bool use_calibration,
                       double known_force_N, double min_force_N, double max_force_N, double chi2_limit, int max_starts,
                       int max_iterations, double no_press_snr) {
             pvdf::mapping::LocatorOptions o;
             o.noise_C = noise_list(noise_C);
             o.use_calibration = use_calibration;
             o.known_force_N = known_force_N;
             o.min_force_N = min_force_N;
             o.max_force_N = max_force_N;
             o.chi2_limit = chi2_limit;
             o.max_starts = max_starts;
             o.max_iterations = max_iterations;
             o.no_press_snr = no_press_snr;
             py::gil_scoped_release release;
             return std::make_unique<Locator>(map, o);
           }),
           py::arg("map"), py::arg("noise_C") = py::none(), py::arg("use_calibration") = true, py::arg("known_force_N") = 0.0,
           py::arg("min_force_N") = 0.0, py::arg("max_force_N") = 0.0, py::arg("chi2_limit") = 0.0, py::arg("max_starts") = 6,
           py::arg("max_iterations") = 40, py::arg("no_press_snr") = 3.0,
           "noise_C: 1-sigma charge noise (C), one value or one per electrode (default: the map's); known_force_N: fit "
           "(x, y) only at this force (N, 0 = unknown); min/max_force_N: plausible force range (N, 0 = from the map's "
           "levels); chi2_limit: 0 = automatic.")
      .def("locate", [](const Locator& loc, const DoubleArray& charges_C, const std::optional<DoubleArray>& known_force_N) {
             const std::size_t ne = loc.n_electrodes();
             const bool one = charges_C.ndim() == 1 && std::size_t(charges_C.shape(0)) == ne;
             if (!one && !(charges_C.ndim() == 2 && std::size_t(charges_C.shape(1)) == ne)) {
               throw pvdf::InputError("Locator.locate: charges_C has shape " + shape_text(charges_C) + "; expected (N, " +
                                      std::to_string(ne) + ") charges in C, one column per electrode");
             }
             const std::size_t n = std::size_t(charges_C.size()) / ne;
             std::vector<double> forces;
             if (known_force_N) {
               forces = to_vector(*known_force_N, "Locator.locate: known_force_N");
               if (forces.size() == 1) forces.assign(n, forces[0]);
               if (forces.size() != n) {
                 throw pvdf::InputError("Locator.locate: known_force_N has " + std::to_string(forces.size()) +
                                        " values for " + std::to_string(n) + " rows of charges; give one or one per row");
               }
             }
             LocationBatch batch;
             batch.items.resize(n);
             const double* q = charges_C.data();
             py::gil_scoped_release release;
             for (std::size_t i = 0; i < n; ++i) {
               batch.items[i] = forces.empty() ? loc.locate(q + i * ne) : loc.locate(q + i * ne, forces[i]);
             }
             return batch;
           },
           py::arg("charges_C"), py::arg("known_force_N") = py::none(),
           "Locates N presses: charges_C (C) of shape (N, n_electrodes) (or (n_electrodes,) for one); known_force_N "
           "(N): None (unknown), one value or one per row. Returns Locations.")
      .def("predict", [](const Locator& loc, const DoubleArray& x_m, const DoubleArray& y_m, const DoubleArray& force_N) {
             const auto xs = to_vector(x_m, "x_m"), ys = to_vector(y_m, "y_m");
             auto fs = to_vector(force_N, "force_N");
             if (xs.size() != ys.size()) throw pvdf::InputError("Locator.predict: x_m and y_m differ in length");
             if (fs.size() == 1) fs.assign(xs.size(), fs[0]);
             if (fs.size() != xs.size()) throw pvdf::InputError("Locator.predict: force_N needs one value or one per position");
             const std::size_t ne = loc.n_electrodes();
             py::array_t<double> out({py::ssize_t(xs.size()), py::ssize_t(ne)});
             double* p = out.mutable_data();
             for (std::size_t i = 0; i < xs.size(); ++i, p += ne) {
               if (!loc.predict(xs[i], ys[i], fs[i], p)) std::fill(p, p + ne, std::numeric_limits<double>::quiet_NaN());
             }
             return out;
           },
           py::arg("x_m"), py::arg("y_m"), py::arg("force_N") = 1.0,
           "The map's (calibrated) charges (C) for presses at (x_m, y_m) (m) with force_N (N): shape (N, n_electrodes), NaN off the map.")
      .def_property_readonly("n_electrodes", &Locator::n_electrodes)
      .def_property_readonly("electrode_names", &Locator::electrode_names)
      .def_property_readonly("noise_C", [](const Locator& l) { return to_array(l.noise_C()); }, "1-sigma noise per electrode (C)")
      .def_property_readonly("chi2_limit", &Locator::chi2_limit)
      .def_property_readonly("calibrated", &Locator::calibrated);
}

void bind_design_and_measurements(py::module_& m) {
  m.def("design", [](const ChargeMap& map, double force_N, double min_force_N, double max_force_N,
                     const std::optional<DoubleArray>& noise_C, double target_m, bool force_known, int adc_bits,
                     double full_scale_C, bool check_ambiguity) {
          pvdf::mapping::DesignOptions o;
          o.force_N = force_N;
          o.min_force_N = min_force_N;
          o.max_force_N = max_force_N;
          o.noise_C = noise_list(noise_C);
          o.target_m = target_m;
          o.force_known = force_known;
          o.adc_bits = adc_bits;
          o.full_scale_C = full_scale_C;
          o.check_ambiguity = check_ambiguity;
          py::gil_scoped_release release;
          return pvdf::mapping::evaluate_design(map, o);
        },
        py::arg("map"), py::arg("force_N") = 1.0, py::arg("min_force_N") = 0.25, py::arg("max_force_N") = 4.0,
        py::arg("noise_C") = py::none(), py::arg("target_m") = 0.5e-3, py::arg("force_known") = false,
        py::arg("adc_bits") = 12, py::arg("full_scale_C") = 0.0, py::arg("check_ambiguity") = true,
        R"doc(Evaluates a layout from its charge map (what ``pvdfkit design`` does): Cramer-Rao position and force
bounds, ambiguity, dead zones and the ADC, at presses of force_N (N). target_m: position-error
target (m); noise_C (C): one value or one per electrode (default: the map's). Returns DesignSummary.)doc");

  m.def("read_measurements", [](const std::string& path, const std::vector<std::string>& electrode_names) {
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

void bind_maps(py::module_& m) {
  bind_charge_map(m);
  bind_locator(m);
  bind_design_and_measurements(m);
}

}  // namespace pvdf::python
