// Per-electrode gain/offset calibration of a map against measured presses.
#include "pvdf/mapping/calibration.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/measured.hpp"
#include "pvdf/core/io.hpp"

#include <algorithm>
#include <cmath>
#include <functional>

namespace pvdf::mapping {

std::vector<Measurement> read_measurements(const std::string& path, const std::vector<std::string>& names) {
  // The one reader of measured CSVs, asked for every channel of every press; other columns are notes.
  const MeasuredTable t = read_measured(path, names, MeasuredRules{true, true});
  std::vector<Measurement> out(t.n_rows());
  for (std::size_t i = 0; i < t.n_rows(); ++i) {
    out[i].x_m = t.x_m[i];
    out[i].y_m = t.y_m[i];
    out[i].force_N = t.force_N[i];
    out[i].line = t.line[i];
    out[i].charge_C.assign(names.size(), 0.0);
  }
  for (const auto& c : t.observed) {
    if (c.electrode < 0) continue;  // a deflection column: not part of a charge comparison
    for (std::size_t i = 0; i < t.n_rows(); ++i) out[i].charge_C[std::size_t(c.electrode)] = c.value[i];
  }
  return out;
}

namespace {

struct LineFit {
  double gain = 1, offset = 0;
  bool ok = false;
};

/// Least squares m ≈ g p + o over the indices in `use`.
LineFit fit_line(const std::vector<double>& p, const std::vector<double>& m, const std::vector<std::size_t>& use) {
  double n = 0, sp = 0, sm = 0, spp = 0, spm = 0;
  for (std::size_t i : use) {
    n += 1;
    sp += p[i];
    sm += m[i];
    spp += p[i] * p[i];
    spm += p[i] * m[i];
  }
  LineFit f;
  const double det = n * spp - sp * sp;
  if (n < 2 || !(det > 1e-12 * n * spp)) return f;
  f.gain = (n * spm - sp * sm) / det;
  f.offset = (sm - f.gain * sp) / n;
  f.ok = std::isfinite(f.gain) && std::isfinite(f.offset) && std::abs(f.gain) > 0;
  return f;
}

nlohmann::json errors_json(const CalibrationErrors& e, const std::vector<std::string>& names, std::size_t n) {
  nlohmann::json j;
  for (std::size_t k = 0; k < names.size(); ++k) j["rms_charge_C"][names[k]] = e.rms_charge_C[k];
  j["rms_position_m"] = e.rms_position_m;
  j["rms_force_relative"] = e.rms_force_relative;
  j["median_position_m"] = e.median_position_m;
  j["median_force_relative"] = e.median_force_relative;
  j["n_located"] = e.n_located;
  j["n_presses"] = n;
  return j;
}

}  // namespace

nlohmann::json CalibrationReport::to_json() const {
  nlohmann::json j;
  const auto& names = electrode_names;
  j["n_presses"] = n_presses;
  j["electrodes"] = names;
  j["gain"] = calibration.gain;
  j["offset_C"] = calibration.offset_C;
  j["before"] = errors_json(before, names, n_presses);
  j["after_in_sample"] = errors_json(after_in_sample, names, n_presses);
  j["after_leave_one_out"] = errors_json(after_leave_one_out, names, n_presses);
  return j;
}

CalibrationReport fit_calibration(const ChargeMap& map, const std::vector<Measurement>& presses,
                                  const LocatorOptions& options, const std::string& source) {
  LocatorOptions raw_options = options;
  raw_options.use_calibration = false;
  const Locator raw(map, raw_options);
  const std::size_t ne = map.ne();
  // Map predictions at the known presses.
  std::vector<std::size_t> inside;
  std::vector<std::vector<double>> predicted(ne, std::vector<double>(presses.size(), 0.0));
  std::vector<std::vector<double>> measured(ne, std::vector<double>(presses.size(), 0.0));
  std::array<double, max_electrodes> q{};
  for (std::size_t i = 0; i < presses.size(); ++i) {
    if (presses[i].charge_C.size() != ne) throw InputError(source + ": press " + std::to_string(i) + " has the wrong number of charges");
    if (!raw.predict(presses[i].x_m, presses[i].y_m, presses[i].force_N, q.data())) continue;
    inside.push_back(i);
    for (std::size_t k = 0; k < ne; ++k) {
      predicted[k][i] = q[k];
      measured[k][i] = presses[i].charge_C[k];
    }
  }
  if (inside.size() < 3) {
    throw InputError(source + ": only " + std::to_string(inside.size()) +
                     " press(es) lie inside the map; calibration needs at least 3 presses at known positions inside it");
  }
  CalibrationReport report;
  report.n_presses = inside.size();
  report.electrode_names = map.electrode_names;
  report.calibration.source = source;
  for (std::size_t k = 0; k < ne; ++k) {
    const LineFit f = fit_line(predicted[k], measured[k], inside);
    if (!f.ok) {
      throw InputError(source + ": electrode " + map.electrode_names[k] +
                       ": the presses give (nearly) the same predicted charge, so gain and offset cannot be separated; "
                       "press at positions with different charges");
    }
    report.calibration.gain.push_back(f.gain);
    report.calibration.offset_C.push_back(f.offset);
  }

  // Evaluate a variant: charges predicted by gain/offset (per press, per electrode), and the
  // presses located after undoing the calibration on the measured charges.
  auto evaluate = [&](const std::function<LineFit(std::size_t, std::size_t)>& calibration_for) {
    CalibrationErrors e;
    e.rms_charge_C.assign(ne, 0.0);
    double pos2 = 0, force2 = 0;
    std::vector<double> positions, forces;
    for (std::size_t i : inside) {
      std::array<double, max_electrodes> corrected{};
      for (std::size_t k = 0; k < ne; ++k) {
        const LineFit f = calibration_for(k, i);
        const double r = measured[k][i] - (f.gain * predicted[k][i] + f.offset);
        e.rms_charge_C[k] += r * r;
        corrected[k] = (measured[k][i] - f.offset) / f.gain;
      }
      const Location known = raw.locate(corrected.data(), presses[i].force_N);
      const Location free = raw.locate(corrected.data());
      if (known.has_position()) {
        ++e.n_located;
        const double d2 = std::pow(known.x_m - presses[i].x_m, 2) + std::pow(known.y_m - presses[i].y_m, 2);
        pos2 += d2;
        positions.push_back(std::sqrt(d2));
      }
      if (free.has_position()) {
        const double rel = (free.force_N - presses[i].force_N) / presses[i].force_N;
        force2 += rel * rel;
        forces.push_back(std::abs(rel));
      }
    }
    const double n = double(inside.size());
    for (auto& v : e.rms_charge_C) v = std::sqrt(v / n);
    e.rms_position_m = e.n_located > 0 ? std::sqrt(pos2 / e.n_located) : 0.0;
    e.rms_force_relative = forces.empty() ? 0.0 : std::sqrt(force2 / double(forces.size()));
    auto median = [](std::vector<double> v) {
      if (v.empty()) return 0.0;
      std::sort(v.begin(), v.end());
      return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
    };
    e.median_position_m = median(positions);
    e.median_force_relative = median(forces);
    return e;
  };
  report.before = evaluate([](std::size_t, std::size_t) { return LineFit{1.0, 0.0, true}; });
  report.after_in_sample = evaluate([&](std::size_t k, std::size_t) {
    return LineFit{report.calibration.gain[k], report.calibration.offset_C[k], true};
  });
  report.after_leave_one_out = evaluate([&](std::size_t k, std::size_t i) {
    std::vector<std::size_t> others;
    for (std::size_t j : inside) {
      if (j != i) others.push_back(j);
    }
    const LineFit f = fit_line(predicted[k], measured[k], others);
    return f.ok ? f : LineFit{1.0, 0.0, true};
  });
  report.calibration.report_json = report.to_json().dump();
  return report;
}

}  // namespace pvdf::mapping
