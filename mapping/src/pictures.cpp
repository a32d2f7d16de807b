// Isocharge pictures (pvdf::plot) and VTK export of charge maps.
#include "pvdf/mapping/pictures.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"
#include "pvdf/core/plot.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <ostream>

namespace pvdf::mapping {

namespace {

constexpr double nan_value = std::numeric_limits<double>::quiet_NaN();

/// The (calibrated) charge of electrode k for presses of force F on a grid `refine` times finer
/// than the map's, in pC; NaN where the map has no value.
plot::Grid charge_grid_pC(const Locator& locator, const ChargeMap& map, std::size_t k, double force_N, int refine) {
  plot::Grid g;
  g.x0 = map.x_m.front() * 1e3;
  g.x1 = map.x_m.back() * 1e3;
  g.y0 = map.y_m.front() * 1e3;
  g.y1 = map.y_m.back() * 1e3;
  g.nx = (map.nx() - 1) * std::size_t(refine) + 1;
  g.ny = (map.ny() - 1) * std::size_t(refine) + 1;
  g.values.assign(g.nx * g.ny, nan_value);
  std::array<double, max_electrodes> q{};
  for (std::size_t j = 0; j < g.ny; ++j) {
    for (std::size_t i = 0; i < g.nx; ++i) {
      const double x = (g.x0 + (g.x1 - g.x0) * double(i) / double(g.nx - 1)) * 1e-3;
      const double y = (g.y0 + (g.y1 - g.y0) * double(j) / double(g.ny - 1)) * 1e-3;
      if (locator.predict(x, y, force_N, q.data())) g.values[j * g.nx + i] = q[k] * 1e12;
    }
  }
  return g;
}

void mark_electrodes(plot::Axes& ax, const ChargeMap& map) {
  for (std::size_t k = 0; k < map.ne(); ++k) {
    const double x = map.electrode_centers_m[k][0] * 1e3, y = map.electrode_centers_m[k][1] * 1e3;
    ax.polygon({{x - 1, y - 1}, {x + 1, y - 1}, {x + 1, y + 1}, {x - 1, y + 1}}, plot::Color{40, 40, 40},
               plot::Color{0, 0, 0}, 1.0);
    ax.text(x + 1.5, y + 1.5, map.electrode_names[k], plot::Color{0, 0, 0}, 11);
  }
}

/// "Nice" contour levels spanning [lo, hi] (pC).
std::vector<double> nice_levels(double lo, double hi, int target) {
  std::vector<double> levels;
  if (!(hi > lo)) return levels;
  const double raw = (hi - lo) / target;
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  double step = mag;
  for (double m : {1.0, 2.0, 5.0, 10.0}) {
    if (m * mag >= raw) {
      step = m * mag;
      break;
    }
  }
  for (double v = std::ceil(lo / step) * step; v <= hi; v += step) levels.push_back(v);
  return levels;
}

std::string format_number(const char* fmt, double v) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, fmt, v);
  return buffer;
}

}  // namespace

void write_isocharge_png(const Locator& locator, const ChargeMap& map, std::size_t electrode, double force_N,
                         const std::string& path) {
  if (electrode >= map.ne()) throw InputError("isocharge picture: electrode index " + std::to_string(electrode) + " out of range");
  if (!(force_N > 0)) throw InputError("isocharge picture: force " + std::to_string(force_N) + " N must be > 0");
  const plot::Grid g = charge_grid_pC(locator, map, electrode, force_N, 2);
  // Contours between the 5th and 95th percentile of the field: the peak at the electrode
  // would otherwise take all the levels.
  std::vector<double> v;
  for (double x : g.values) {
    if (std::isfinite(x)) v.push_back(x);
  }
  if (v.empty()) throw InputError("isocharge picture: the map has no value to draw");
  std::sort(v.begin(), v.end());
  const double lo = v[v.size() / 20], hi = v[v.size() * 19 / 20];
  plot::Figure fig(900, 800);
  auto& ax = fig.axes();
  ax.field(g, "charge of " + map.electrode_names[electrode] + " (pC)", false, lo, hi)
      .contour(g, nice_levels(lo, hi, 8), plot::Color{255, 255, 255}, 1.2, "%.3g pC")
      .title("Isocharge contours of electrode " + map.electrode_names[electrode] + " at " + format_number("%.3g", force_N) +
             " N (" + map.model + " map)")
      .xlabel("probe x (mm)")
      .ylabel("probe y (mm)")
      .equal_aspect();
  mark_electrodes(ax, map);
  fig.save_png(path);
}

void write_intersection_png(const Locator& locator, const ChargeMap& map, const double* charges_C,
                            const Location& result, const std::string& path) {
  if (!result.has_position()) {
    throw InputError("intersection picture: the press has no position (" + flags_text(result.flags) + ")");
  }
  plot::Figure fig(900, 800);
  auto& ax = fig.axes();
  for (std::size_t k = 0; k < map.ne(); ++k) {
    const plot::Grid g = charge_grid_pC(locator, map, k, result.force_N, 2);
    ax.contour(g, {charges_C[k] * 1e12}, plot::cycle_color(k), 2.5, "%.3g pC", 1.0,
               map.electrode_names[k] + ": " + format_number("%.3g", charges_C[k] * 1e12) + " pC");
  }
  ax.scatter({result.x_m * 1e3}, {result.y_m * 1e3}, "located: (" + format_number("%.2f", result.x_m * 1e3) + ", " +
                                                         format_number("%.2f", result.y_m * 1e3) + ") mm, " +
                                                         format_number("%.3g", result.force_N) + " N",
             plot::Color{0, 0, 0}, plot::Marker::cross, 14);
  for (int a = 0; a < result.n_alternatives; ++a) {
    const auto& alt = result.alternatives[std::size_t(a)];
    ax.scatter({alt.x_m * 1e3}, {alt.y_m * 1e3}, "also fits (ambiguous): " + format_number("%.3g", alt.force_N) + " N",
               plot::Color{200, 0, 0}, plot::Marker::plus, 14);
  }
  mark_electrodes(ax, map);
  const double R = std::max(std::abs(map.x_m.front()), std::abs(map.x_m.back())) * 1e3;
  ax.title("Isocharge contours of the measured charges at the located force")
      .xlabel("probe x (mm)")
      .ylabel("probe y (mm)")
      .xlim(-R, R)
      .ylim(-R, R)
      .equal_aspect()
      .grid_lines()
      .legend("lower right");
  fig.save_png(path);
}

void write_charge_vtk(const ChargeMap& map, const std::string& path) {
  write_file_atomically(path, [&](std::ostream& out) {
    out.precision(9);
    const double hx = (map.x_m.back() - map.x_m.front()) / double(map.nx() - 1);
    const double hy = (map.y_m.back() - map.y_m.front()) / double(map.ny() - 1);
    out << "# vtk DataFile Version 3.0\n"
        << "pvdfkit charge map (" << map.model << "), charges in pC, coordinates in m\n"
        << "ASCII\nDATASET STRUCTURED_POINTS\n"
        << "DIMENSIONS " << map.nx() << ' ' << map.ny() << " 1\n"
        << "ORIGIN " << map.x_m.front() << ' ' << map.y_m.front() << " 0\n"
        << "SPACING " << hx << ' ' << hy << " 1\n"
        << "POINT_DATA " << map.nx() * map.ny() << '\n';
    out << "SCALARS mask unsigned_char 1\nLOOKUP_TABLE default\n";
    for (std::size_t p = 0; p < map.nx() * map.ny(); ++p) out << int(map.mask[p]) << '\n';
    for (std::size_t f = 0; f < map.nf(); ++f) {
      for (std::size_t k = 0; k < map.ne(); ++k) {
        out << "SCALARS charge_" << map.electrode_names[k] << "_pC_F" << f << " double 1\nLOOKUP_TABLE default\n";
        for (std::size_t j = 0; j < map.ny(); ++j) {
          for (std::size_t i = 0; i < map.nx(); ++i) {
            const std::size_t p = map.point(f, j, i);
            if (map.status[p] == std::uint8_t(PointStatus::ok)) {
              out << map.charge_C[p * map.ne() + k] * 1e12 << '\n';
            } else {
              out << "nan\n";
            }
          }
        }
      }
    }
  });
}

}  // namespace pvdf::mapping
