// Scan and force CSV files (formats in docs/restore.md).
#include "pvdf/restore/scan_io.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ostream>
#include <sstream>

namespace pvdf::restore {

Scan read_scan_csv(const std::string& path, double speed_m_per_s) {
  const CsvTable t = read_csv(path);
  Scan scan;
  scan.source = path;
  const bool has_x = t.has_column("x_m");
  if (!has_x && !t.has_column("t_s")) {
    throw InputError(path + ": has neither an x_m nor a t_s column; the header must be x_m,m1_V,m2_V (or t_s,m1_V,m2_V "
                            "with the scan speed given)");
  }
  if (!has_x && !(speed_m_per_s > 0)) {
    throw InputError(path + ": has a t_s column but no scan speed was given (seed 000: 0.01-0.1 m/s)");
  }
  const std::size_t cx = has_x ? t.column("x_m") : t.column("t_s");
  const std::size_t c1 = t.column("m1_V");
  const std::size_t c2 = t.column("m2_V");
  const bool has_ref = t.has_column("fx_ref_N") && t.has_column("fz_ref_N");
  if (t.rows.size() < 16) {
    throw InputError(path + ": has " + std::to_string(t.rows.size()) + " data rows; a scan needs at least 16 samples");
  }
  for (const auto& row : t.rows) {
    scan.x_m.push_back(has_x ? row[cx] : row[cx] * speed_m_per_s);
    scan.m1_V.push_back(row[c1]);
    scan.m2_V.push_back(row[c2]);
    if (has_ref) {
      scan.fx_N.push_back(row[t.column("fx_ref_N")]);
      scan.fz_N.push_back(row[t.column("fz_ref_N")]);
    }
  }
  // Reference step: the median step (robust to the one bad step being reported).
  std::vector<double> steps;
  for (std::size_t i = 1; i < scan.x_m.size(); ++i) steps.push_back(scan.x_m[i] - scan.x_m[i - 1]);
  std::nth_element(steps.begin(), steps.begin() + static_cast<long>(steps.size() / 2), steps.end());
  const double dx = steps[steps.size() / 2];
  if (!(dx > 0)) throw InputError(path + ": positions do not increase; x_m (or t_s) must increase down the file");
  for (std::size_t i = 1; i < scan.x_m.size(); ++i) {
    const double step = scan.x_m[i] - scan.x_m[i - 1];
    if (std::abs(step - dx) > 0.01 * dx) {
      std::ostringstream msg;
      msg << path << ":" << t.line_numbers[i] << ": position step " << step << " m differs from the median step " << dx
          << " m by more than 1 %; a scan must be uniformly sampled (resample it first)";
      throw InputError(msg.str());
    }
  }
  return scan;
}

void write_scan_csv(const std::string& path, const Scan& scan, const std::string& comment) {
  const bool ref = scan.fx_N.size() == scan.size() && scan.fz_N.size() == scan.size();
  write_file_atomically(path, [&](std::ostream& out) {
    if (!comment.empty()) out << "# " << comment << '\n';
    out << (ref ? "x_m,m1_V,m2_V,fx_ref_N,fz_ref_N\n" : "x_m,m1_V,m2_V\n");
    char buf[160];
    for (std::size_t i = 0; i < scan.size(); ++i) {
      if (ref) {
        std::snprintf(buf, sizeof buf, "%.17g,%.17g,%.17g,%.17g,%.17g\n", scan.x_m[i], scan.m1_V[i], scan.m2_V[i],
                      scan.fx_N[i], scan.fz_N[i]);
      } else {
        std::snprintf(buf, sizeof buf, "%.17g,%.17g,%.17g\n", scan.x_m[i], scan.m1_V[i], scan.m2_V[i]);
      }
      out << buf;
    }
  });
}

double RestoredForces::peak_fz_N_per_m() const {
  double peak = 0;
  for (const double f : fz_N_per_m) peak = std::max(peak, f);
  return peak;
}

double RestoredForces::total_fx_N() const {
  double total = 0;
  for (const double f : fx_N) total += f;
  return total;
}

double RestoredForces::total_fz_N() const {
  double total = 0;
  for (const double f : fz_N) total += f;
  return total;
}

void write_forces_csv(const std::string& path, const RestoredForces& f, const std::string& comment) {
  write_file_atomically(path, [&](std::ostream& out) {
    if (!comment.empty()) out << "# " << comment << '\n';
    out << "x_m,fx_N,fz_N,mu,mu_valid,fx_N_per_m,fz_N_per_m\n";
    char buf[240];
    const bool per_m = f.fx_N_per_m.size() == f.x_m.size() && f.fz_N_per_m.size() == f.x_m.size();
    for (std::size_t i = 0; i < f.x_m.size(); ++i) {
      std::snprintf(buf, sizeof buf, "%.17g,%.17g,%.17g,%.17g,%d,%.17g,%.17g\n", f.x_m[i], f.fx_N[i], f.fz_N[i], f.mu[i],
                    f.mu_valid[i], per_m ? f.fx_N_per_m[i] : 0.0, per_m ? f.fz_N_per_m[i] : 0.0);
      out << buf;
    }
  });
}

}  // namespace pvdf::restore
