// The charge map in memory: point status names, allocation, and the full check of shapes, axes,
// values and finiteness. No file format here: the HDF5 map file is mapping/format (map_io.cpp).
#include "pvdf/mapping/map.hpp"
#include "pvdf/mapping/map_attributes.hpp"

#include "pvdf/core/error.hpp"

#include <cmath>
#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace pvdf::mapping {

std::string status_name(PointStatus status) {
  switch (status) {
    case PointStatus::ok: return "ok";
    case PointStatus::not_converged: return "not_converged";
    case PointStatus::outside: return "outside";
    case PointStatus::not_computed: return "not_computed";
  }
  return "unknown";
}

void ChargeMap::allocate() {
  const std::size_t n_points = nf() * ny() * nx();
  charge_C.assign(n_points * ne(), 0.0);
  deflection_at_load_m.assign(n_points, 0.0);
  status.assign(n_points, static_cast<std::uint8_t>(PointStatus::not_computed));
  if (mask.size() != nx() * ny()) mask.assign(nx() * ny(), 1);
  if (noise_C.size() != ne()) noise_C.assign(ne(), 1e-13);
  if (electrode_centers_m.size() != ne()) electrode_centers_m.assign(ne(), {0.0, 0.0});
}

namespace {

std::string num(double v) {
  std::ostringstream os;
  os.precision(10);
  os << v;
  return os.str();
}

[[noreturn]] void bad(const std::string& source, const std::string& what) { throw InputError(source + ": " + what); }

const std::string regenerate = "; regenerate the map with `pvdfkit map` or repair the file";

void check_axis(const std::vector<double>& axis, const std::string& name, const std::string& source) {
  if (axis.size() < 2) bad(source, name + " has " + std::to_string(axis.size()) + " values; at least 2 are needed" + regenerate);
  for (std::size_t i = 0; i < axis.size(); ++i) {
    if (!std::isfinite(axis[i])) bad(source, name + "[" + std::to_string(i) + "] is not finite" + regenerate);
  }
  const double h = (axis.back() - axis.front()) / double(axis.size() - 1);
  if (!(h > 0)) bad(source, name + " must be ascending (first " + num(axis.front()) + ", last " + num(axis.back()) + ")" + regenerate);
  for (std::size_t i = 1; i < axis.size(); ++i) {
    const double d = axis[i] - axis[i - 1];
    if (std::abs(d - h) > 1e-6 * h) {
      bad(source, name + " must be equally spaced: step " + std::to_string(i) + " is " + num(d) + " m, mean " + num(h) +
                      " m" + regenerate);
    }
  }
}

}  // namespace

double ChargeMap::largest_charge_C() const {
  double largest = 0;
  for (const double q : charge_C)
    if (std::abs(q) > largest) largest = std::abs(q);
  return largest;
}

void validate(const ChargeMap& m, const std::string& source) {
  check_axis(m.x_m, "/grid/x_m", source);
  check_axis(m.y_m, "/grid/y_m", source);
  if (m.mask.size() != m.nx() * m.ny()) {
    bad(source, "/grid/mask has " + std::to_string(m.mask.size()) + " values but [ny][nx] = " +
                    std::to_string(m.ny() * m.nx()) + " are required" + regenerate);
  }
  for (std::size_t i = 0; i < m.mask.size(); ++i) {
    if (m.mask[i] > 1) bad(source, "/grid/mask[" + std::to_string(i) + "] = " + std::to_string(m.mask[i]) + " must be 0 or 1" + regenerate);
  }
  if (m.forces_N.empty()) bad(source, "/forces_N is empty; at least one force level is needed" + regenerate);
  for (std::size_t f = 0; f < m.nf(); ++f) {
    if (!std::isfinite(m.forces_N[f]) || !(m.forces_N[f] > 0)) {
      bad(source, "/forces_N[" + std::to_string(f) + "] = " + num(m.forces_N[f]) + " must be finite and > 0" + regenerate);
    }
    if (f > 0 && !(m.forces_N[f] > m.forces_N[f - 1])) {
      bad(source, "/forces_N[" + std::to_string(f) + "] = " + num(m.forces_N[f]) + " must be > /forces_N[" +
                      std::to_string(f - 1) + "] = " + num(m.forces_N[f - 1]) + " (ascending)" + regenerate);
    }
  }
  if (m.ne() < 1) bad(source, "/electrodes/names is empty; a map needs at least one electrode" + regenerate);
  std::set<std::string> names;
  for (const auto& n : m.electrode_names) {
    if (n.empty()) bad(source, "/electrodes/names holds an empty name" + regenerate);
    if (n.find_first_of(",\n\r\" ") != std::string::npos) bad(source, "/electrodes/names: '" + n + "' contains a comma, quote or space" + regenerate);
    if (!names.insert(n).second) bad(source, "/electrodes/names: '" + n + "' appears twice" + regenerate);
  }
  if (m.electrode_centers_m.size() != m.ne()) {
    bad(source, "/electrodes/center_m has " + std::to_string(m.electrode_centers_m.size()) + " rows but there are " +
                    std::to_string(m.ne()) + " electrodes" + regenerate);
  }
  for (std::size_t k = 0; k < m.ne(); ++k) {
    if (!std::isfinite(m.electrode_centers_m[k][0]) || !std::isfinite(m.electrode_centers_m[k][1])) {
      bad(source, "/electrodes/center_m[" + std::to_string(k) + "] is not finite" + regenerate);
    }
  }
  if (m.noise_C.size() != m.ne()) {
    bad(source, "/electrodes/noise_C has " + std::to_string(m.noise_C.size()) + " values but there are " +
                    std::to_string(m.ne()) + " electrodes" + regenerate);
  }
  for (std::size_t k = 0; k < m.ne(); ++k) {
    if (!std::isfinite(m.noise_C[k]) || !(m.noise_C[k] > 0)) {
      bad(source, "/electrodes/noise_C[" + std::to_string(k) + "] = " + num(m.noise_C[k]) + " must be finite and > 0" + regenerate);
    }
  }
  const std::size_t n_points = m.nf() * m.ny() * m.nx();
  auto shape = [&](std::size_t got, std::size_t want, const std::string& name, const std::string& dims) {
    if (got != want) {
      bad(source, name + " has " + std::to_string(got) + " values but " + dims + " = " + std::to_string(want) +
                      " are required" + regenerate);
    }
  };
  shape(m.status.size(), n_points, "/status", "[nf][ny][nx]");
  shape(m.deflection_at_load_m.size(), n_points, "/deflection_at_load_m", "[nf][ny][nx]");
  shape(m.charge_C.size(), n_points * m.ne(), "/charge_C", "[nf][ny][nx][ne]");
  const bool has_dx = !m.dcharge_dx_C_per_m.empty(), has_dy = !m.dcharge_dy_C_per_m.empty();
  if (has_dx != has_dy) bad(source, "/derivatives must hold both dcharge_dx_C_per_m and dcharge_dy_C_per_m or neither" + regenerate);
  if (has_dx) {
    shape(m.dcharge_dx_C_per_m.size(), n_points * m.ne(), "/derivatives/dcharge_dx_C_per_m", "[nf][ny][nx][ne]");
    shape(m.dcharge_dy_C_per_m.size(), n_points * m.ne(), "/derivatives/dcharge_dy_C_per_m", "[nf][ny][nx][ne]");
  }
  const bool has_err = !m.estimated_charge_error_C.empty();
  if (has_err) shape(m.estimated_charge_error_C.size(), n_points * m.ne(), "/estimated_charge_error_C", "[nf][ny][nx][ne]");
  std::size_t n_ok = 0;
  for (std::size_t f = 0; f < m.nf(); ++f) {
    for (std::size_t j = 0; j < m.ny(); ++j) {
      for (std::size_t i = 0; i < m.nx(); ++i) {
        const std::size_t p = m.point(f, j, i);
        const int s = m.status[p];
        const std::string at = "[" + std::to_string(f) + "][" + std::to_string(j) + "][" + std::to_string(i) + "]";
        if (s > 3) bad(source, "/status" + at + " = " + std::to_string(s) + " is not one of 0 ok, 1 not_converged, 2 outside, 3 not_computed" + regenerate);
        if (s == 0 && m.mask[j * m.nx() + i] == 0) {
          bad(source, "/status" + at + " = 0 (ok) at a point where /grid/mask = 0 (outside)" + regenerate);
        }
        if (s != 0) continue;
        ++n_ok;
        if (!std::isfinite(m.deflection_at_load_m[p])) bad(source, "/deflection_at_load_m" + at + " is not finite at an ok point" + regenerate);
        for (std::size_t k = 0; k < m.ne(); ++k) {
          if (!std::isfinite(m.charge_C[p * m.ne() + k])) {
            bad(source, "/charge_C" + at + "[" + std::to_string(k) + "] is not finite at an ok point" + regenerate);
          }
          if (has_dx && (!std::isfinite(m.dcharge_dx_C_per_m[p * m.ne() + k]) || !std::isfinite(m.dcharge_dy_C_per_m[p * m.ne() + k]))) {
            bad(source, "/derivatives" + at + "[" + std::to_string(k) + "] is not finite at an ok point" + regenerate);
          }
          if (has_err && !(std::isfinite(m.estimated_charge_error_C[p * m.ne() + k]) && m.estimated_charge_error_C[p * m.ne() + k] >= 0)) {
            bad(source, "/estimated_charge_error_C" + at + "[" + std::to_string(k) + "] = " +
                            num(m.estimated_charge_error_C[p * m.ne() + k]) + " must be finite and >= 0 at an ok point" + regenerate);
          }
        }
      }
    }
  }
  if (n_ok == 0) bad(source, "/status has no ok point; the map holds no usable charge" + regenerate);
  if (!std::isfinite(m.tolerance) || m.tolerance < 0) bad(source, "attribute tolerance = " + num(m.tolerance) + " must be finite and >= 0" + regenerate);
  if (!std::isfinite(m.rim_margin_m) || m.rim_margin_m < 0) bad(source, "attribute rim_margin_m = " + num(m.rim_margin_m) + " must be finite and >= 0" + regenerate);
  for (const auto& [name, member] : optional_number_attributes) {
    const double value = m.*member;
    if (!std::isnan(value) && !(std::isfinite(value) && value >= 0)) {
      bad(source, std::string("attribute ") + name + " = " + num(value) + " must be finite and >= 0 (or absent: unknown)" + regenerate);
    }
  }
  if (m.charge_error_is_total() && !has_err) {
    bad(source, "attribute estimated_total_relative_error is set but /estimated_charge_error_C is absent" + regenerate);
  }
  if (m.calibration) {
    const auto& c = *m.calibration;
    if (c.gain.size() != m.ne() || c.offset_C.size() != m.ne()) {
      bad(source, "/calibration/gain and /calibration/offset_C must hold " + std::to_string(m.ne()) + " values (one per electrode)" + regenerate);
    }
    for (std::size_t k = 0; k < m.ne(); ++k) {
      if (!std::isfinite(c.gain[k]) || !(std::abs(c.gain[k]) > 0)) {
        bad(source, "/calibration/gain[" + std::to_string(k) + "] = " + num(c.gain[k]) + " must be finite and non-zero; re-run pvdfkit calibrate");
      }
      if (!std::isfinite(c.offset_C[k])) bad(source, "/calibration/offset_C[" + std::to_string(k) + "] is not finite; re-run pvdfkit calibrate");
    }
  }
}

}  // namespace pvdf::mapping
