// Isocharge pictures (pvdf::plot; PNG, SVG or PDF by the file extension) and VTK export of charge maps.
#include "pvdf/mapping/pictures.hpp"

#include "pvdf/core/constants.hpp"
#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"
#include "pvdf/core/scene.hpp"
#include "pvdf/plot/plot.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <ostream>

namespace pvdf::mapping {

double picture_force_N(const ChargeMap& map, double requested_N) {
  if (requested_N > 0) return requested_N;
  double force = map.forces_N.front();
  for (double f : map.forces_N) {
    if (std::abs(std::log(f)) < std::abs(std::log(force))) force = f;
  }
  return force;
}

namespace {

constexpr double nan_value = std::numeric_limits<double>::quiet_NaN();

/// Steps of the map's own interpolant per map cell for pictures: at most 0.25 mm apart (and at
/// least 4 per cell, unless that passes ~1200 samples a side), so that contours follow the
/// interpolant, not chords across the map's cells.
int picture_refinement(const ChargeMap& map) {
  const double h_mm = std::max(std::abs(map.x_m.back() - map.x_m.front()) / double(std::max<std::size_t>(map.nx() - 1, 1)),
                               std::abs(map.y_m.back() - map.y_m.front()) / double(std::max<std::size_t>(map.ny() - 1, 1))) * 1e3;
  // At most ~1200 samples along the longer side (a fine, large map is already smooth enough;
  // plot refines the samples bicubically where they are still coarse on the page).
  const std::size_t cells = std::max<std::size_t>({map.nx() - 1, map.ny() - 1, 1});
  const int cap = std::max(1, int(1200 / cells));
  return std::min(std::clamp(int(std::ceil(h_mm / 0.25)), 4, 32), cap);
}

/// The (calibrated) charge of electrode k for presses of force F on a grid `refine` times finer
/// than the map's, in pC, sampled on the map's own interpolant (Locator::predict); NaN where the
/// map has no value. With half_width_m > 0 the grid covers [−w, w]² (clipped to the map) at the
/// same resolution.
plot::Grid charge_grid_pC(const Locator& locator, const ChargeMap& map, std::size_t k, double force_N, int refine,
                          double half_width_m = 0.0) {
  plot::Grid g;
  g.x0 = map.x_m.front() * 1e3;
  g.x1 = map.x_m.back() * 1e3;
  g.y0 = map.y_m.front() * 1e3;
  g.y1 = map.y_m.back() * 1e3;
  g.nx = (map.nx() - 1) * std::size_t(refine) + 1;
  g.ny = (map.ny() - 1) * std::size_t(refine) + 1;
  if (half_width_m > 0) {
    const double w = half_width_m * 1e3;
    const double hx = (g.x1 - g.x0) / double(g.nx - 1), hy = (g.y1 - g.y0) / double(g.ny - 1);
    g.x0 = std::max(g.x0, -w);
    g.x1 = std::min(g.x1, w);
    g.y0 = std::max(g.y0, -w);
    g.y1 = std::min(g.y1, w);
    g.nx = std::size_t(std::max(2.0, std::ceil((g.x1 - g.x0) / hx) + 1));
    g.ny = std::size_t(std::max(2.0, std::ceil((g.y1 - g.y0) / hy) + 1));
  }
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

/// The electrodes as they lie on the film — rectangles at their angle, circles as 96-gons,
/// polygons — read from the scene the map was computed for, with the name beside the outline's
/// upper right; a map without a readable scene (or whose scene names other electrodes) shows
/// 2 mm squares at the electrode centres, as maps have always been drawn.
void mark_electrodes(plot::Axes& ax, const ChargeMap& map) {
  std::vector<std::vector<std::array<double, 2>>> outlines(map.ne());
  try {
    const Scene scene = parse_scene(nlohmann::json::parse(map.scene_json), "the map's scene");
    if (scene.electrodes.size() == map.ne()) {
      for (std::size_t k = 0; k < map.ne(); ++k) {
        if (scene.electrodes[k].name != map.electrode_names[k]) {
          outlines.assign(map.ne(), {});
          break;
        }
        for (const auto& p : scene.electrodes[k].outline(96)) outlines[k].push_back({p[0] * 1e3, p[1] * 1e3});
      }
    }
  } catch (const std::exception&) {
    outlines.assign(map.ne(), {});  // drawn as squares below
  }
  for (std::size_t k = 0; k < map.ne(); ++k) {
    auto& v = outlines[k];
    if (v.size() < 3) {
      const double x = map.electrode_centers_m[k][0] * 1e3, y = map.electrode_centers_m[k][1] * 1e3;
      v = {{x - 1, y - 1}, {x + 1, y - 1}, {x + 1, y + 1}, {x - 1, y + 1}};
    }
    double x_max = -std::numeric_limits<double>::infinity(), y_max = x_max;
    for (const auto& p : v) x_max = std::max(x_max, p[0]), y_max = std::max(y_max, p[1]);
    ax.polygon(v, plot::Color{40, 40, 40}, plot::Color{0, 0, 0}, 1.0);
    ax.text(x_max + 0.5, y_max + 0.5, map.electrode_names[k], plot::Color{0, 0, 0}, 11);
  }
}

/// The box [x0, x1, y0, y1] (mm) of the nodes the map covers (mask = 1), within the box `within`:
/// the axes of a picture span where the data are, not the grid's masked corners beyond the film's
/// rim margin. `within` unchanged when the map has no mask or no covered node inside it.
std::array<double, 4> covered_box_mm(const ChargeMap& map, const std::array<double, 4>& within) {
  if (map.mask.size() != map.nx() * map.ny()) return within;
  std::array<double, 4> box{std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity(),
                            std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()};
  for (std::size_t j = 0; j < map.ny(); ++j) {
    for (std::size_t i = 0; i < map.nx(); ++i) {
      if (!map.mask[j * map.nx() + i]) continue;
      const double x = map.x_m[i] * 1e3, y = map.y_m[j] * 1e3;
      box = {std::min(box[0], x), std::max(box[1], x), std::min(box[2], y), std::max(box[3], y)};
    }
  }
  box = {std::max(box[0], within[0]), std::min(box[1], within[1]), std::max(box[2], within[2]), std::min(box[3], within[3])};
  return box[0] < box[1] && box[2] < box[3] ? box : within;
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

/// printf of one number, with a typographic minus sign (U+2212) for negative values.
std::string format_number(const char* fmt, double v) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, fmt, v);
  // "-0.00" (a tiny negative value rounded away) is written as 0.00.
  const bool negative_zero = buffer[0] == '-' && std::strspn(buffer + 1, "0.") > 0 && !std::strpbrk(buffer + 1, "123456789");
  std::string out;
  for (const char* c = buffer + (negative_zero ? 1 : 0); *c; ++c) {
    if (*c == '-' && (std::isdigit(static_cast<unsigned char>(c[1])) || c[1] == '.')) out += "\u2212";
    else out += *c;
  }
  return out;
}

}  // namespace

void write_isocharge_png(const Locator& locator, const ChargeMap& map, std::size_t electrode, double force_N,
                         const std::string& path, double half_width_m) {
  if (electrode >= map.ne()) throw InputError("isocharge picture: electrode index " + std::to_string(electrode) + " out of range");
  if (!(force_N > 0)) throw InputError("isocharge picture: force " + std::to_string(force_N) + " N must be > 0");
  if (!(half_width_m >= 0)) throw InputError("isocharge picture: half width " + std::to_string(half_width_m) + " m must be >= 0");
  const plot::Grid g = charge_grid_pC(locator, map, electrode, force_N, picture_refinement(map), half_width_m);
  // Contours between the 5th and 95th percentile of the field: the peak at the electrode
  // would otherwise take all the levels.
  std::vector<double> v;
  for (double x : g.values) {
    if (std::isfinite(x)) v.push_back(x);
  }
  if (v.empty()) throw InputError("isocharge picture: the map has no value to draw");
  std::sort(v.begin(), v.end());
  const double lo = v[v.size() / 20], hi = v[v.size() * 19 / 20];
  // The colour scale spans the same 5th–95th percentiles; the bar's end triangles mark the
  // clipping and its label gives the full range of the data.
  const std::string bar = "charge of " + map.electrode_names[electrode] + " (pC); colours clipped to the 5th–95th " +
                          "percentile, data " + format_number("%.3g", v.front()) + " to " + format_number("%.3g", v.back());
  plot::Figure fig(900, 800);
  auto& ax = fig.axes();
  ax.field(g, bar, false, lo, hi)
      .contour(g, nice_levels(lo, hi, 8), plot::Color{255, 255, 255}, 1.2, "%.3g pC")
      .title("Isocharge contours of electrode " + map.electrode_names[electrode] + " at " + format_number("%.3g", force_N) +
             " N (" + map.model + " map)")
      .xlabel("probe x (mm)")
      .ylabel("probe y (mm)")
      .equal_aspect();
  const auto box = covered_box_mm(map, {g.x0, g.x1, g.y0, g.y1});
  ax.xlim(box[0], box[1]).ylim(box[2], box[3]);
  mark_electrodes(ax, map);
  fig.save(path);
}

void write_intersection_png(const Locator& locator, const ChargeMap& map, const double* charges_C,
                            const Location& result, const std::string& path) {
  if (!result.has_position()) {
    throw InputError("intersection picture: the press has no position (" + flags_text(result.flags) + ")");
  }
  plot::Figure fig(1060, 760);
  auto& ax = fig.axes();
  for (std::size_t k = 0; k < map.ne(); ++k) {
    const plot::Grid g = charge_grid_pC(locator, map, k, result.force_N, picture_refinement(map));
    ax.contour(g, {charges_C[k] * 1e12}, plot::cycle_color(k), 2.5, "%.3g pC", 1.0,
               map.electrode_names[k] + ": " + format_number("%.3g", charges_C[k] * 1e12) + " pC");
  }
  ax.scatter({result.x_m * 1e3}, {result.y_m * 1e3}, "located: (" + format_number("%.2f", result.x_m * 1e3) + ", " +
                                                         format_number("%.2f", result.y_m * 1e3) + ") mm, " +
                                                         format_number("%.3g", result.force_N) + " N" +
                                                         (result.sigma_F_N == 0 ? " (given)" : ""),
             plot::Color{0, 0, 0}, plot::Marker::cross, 14);
  for (int a = 0; a < result.n_alternatives; ++a) {
    const auto& alt = result.alternatives[std::size_t(a)];
    ax.scatter({alt.x_m * 1e3}, {alt.y_m * 1e3}, "also fits (ambiguous): " + format_number("%.3g", alt.force_N) + " N",
               plot::Color{200, 0, 0}, plot::Marker::plus, 14);
  }
  mark_electrodes(ax, map);
  // The axes span the map's covered nodes (where contours can be), the legend sits beside the
  // panel, off the data.
  const auto box = covered_box_mm(map, {map.x_m.front() * 1e3, map.x_m.back() * 1e3, map.y_m.front() * 1e3,
                                        map.y_m.back() * 1e3});
  // A force given to the lookup (locate/isocharge --force-N) has no σ: name it as given, not located.
  const bool force_given = result.sigma_F_N == 0;
  ax.title(std::string("Isocharge contours Q$_k$ = q$_k$ of the given charges, at the ") +
           (force_given ? "given force" : "located force"))
      .xlabel("probe x (mm)")
      .ylabel("probe y (mm)")
      .xlim(box[0], box[1])
      .ylim(box[2], box[3])
      .equal_aspect()
      .grid_lines()
      .legend("outside right");
  fig.save(path);
}

std::string charge_vtk_field_name(const std::string& electrode, double force_N) {
  char level[32];
  std::snprintf(level, sizeof level, "%.6g", force_N);  // plain ASCII: a field name, not a label
  return "charge_" + electrode + "_C_at_" + level + "N";
}

// Legacy VTK in BINARY form (big-endian IEEE): VTK's ASCII reader cannot parse "nan", and
// the points without a value must stay NaN (ParaView then leaves them blank).
void write_charge_vtk(const ChargeMap& map, const std::string& path) {
  auto put_be64 = [](std::ostream& out, double v) {
    std::uint64_t bits = 0;
    std::memcpy(&bits, &v, sizeof bits);
    char bytes[8];
    for (int b = 0; b < 8; ++b) bytes[b] = char((bits >> (8 * (7 - b))) & 0xffu);
    out.write(bytes, 8);
  };
  write_file_atomically(path, [&](std::ostream& out) {
    out.precision(17);
    const double hx = (map.x_m.back() - map.x_m.front()) / double(map.nx() - 1);
    const double hy = (map.y_m.back() - map.y_m.front()) / double(map.ny() - 1);
    out << "# vtk DataFile Version 3.0\n"
        << "pvdfkit charge map (" << map.model << "), charges in C, coordinates in m\n"
        << "BINARY\nDATASET STRUCTURED_POINTS\n"
        << "DIMENSIONS " << map.nx() << ' ' << map.ny() << " 1\n"
        << "ORIGIN " << map.x_m.front() << ' ' << map.y_m.front() << " 0\n"
        << "SPACING " << hx << ' ' << hy << " 1\n"
        << "POINT_DATA " << map.nx() * map.ny() << '\n';
    out << "SCALARS mask unsigned_char 1\nLOOKUP_TABLE default\n";
    for (std::size_t p = 0; p < map.nx() * map.ny(); ++p) out.put(char(map.mask[p]));
    out << '\n';
    for (std::size_t f = 0; f < map.nf(); ++f) {
      for (std::size_t k = 0; k < map.ne(); ++k) {
        out << "SCALARS " << charge_vtk_field_name(map.electrode_names[k], map.forces_N[f]) << " double 1\nLOOKUP_TABLE default\n";
        for (std::size_t j = 0; j < map.ny(); ++j) {
          for (std::size_t i = 0; i < map.nx(); ++i) {
            const std::size_t p = map.point(f, j, i);
            put_be64(out, map.status[p] == std::uint8_t(PointStatus::ok) ? map.charge_C[p * map.ne() + k] : nan_value);
          }
        }
        out << '\n';
      }
    }
  });
}

void write_isocharge_overlay_png(const Locator& locator, const ChargeMap& map, double force_N, const std::string& path,
                                 double half_width_m) {
  if (!(force_N > 0)) throw InputError("isocharge picture: force " + std::to_string(force_N) + " N must be > 0");
  if (!(half_width_m >= 0)) throw InputError("isocharge picture: half width " + std::to_string(half_width_m) + " m must be >= 0");
  // The legend under the panel, entries side by side: the panel takes the figure's width and
  // no empty column is left beside it (a legend at the right would leave one under itself).
  plot::Figure fig(820, 860);
  auto& ax = fig.axes();
  double x0 = std::numeric_limits<double>::infinity(), x1 = -x0, y0 = x0, y1 = -x0;
  for (std::size_t k = 0; k < map.ne(); ++k) {
    const plot::Grid g = charge_grid_pC(locator, map, k, force_N, picture_refinement(map), half_width_m);
    x0 = std::min(x0, g.x0), x1 = std::max(x1, g.x1), y0 = std::min(y0, g.y0), y1 = std::max(y1, g.y1);
    std::vector<double> v;
    for (double x : g.values) {
      if (std::isfinite(x)) v.push_back(x);
    }
    if (v.empty()) throw InputError("isocharge picture: the map has no value to draw in the window");
    std::sort(v.begin(), v.end());
    // Fewer, rounder levels than the single-electrode picture: three families share the panel.
    const double lo = v[v.size() / 10], hi = v[v.size() * 9 / 10];
    ax.contour(g, nice_levels(lo, hi, 5), plot::cycle_color(k), 1.8, "%.3g pC", 1.0,
               "electrode " + map.electrode_names[k] + " (pC)");
  }
  mark_electrodes(ax, map);
  const auto box = covered_box_mm(map, {x0, x1, y0, y1});
  ax.title("Isocharge contours of all electrodes at " + format_number("%.3g", force_N) + " N (" + map.model + " map)")
      .xlabel("probe x (mm)")
      .ylabel("probe y (mm)")
      .equal_aspect()
      .grid_lines()
      .legend("outside below")
      .xlim(box[0], box[1])  // the drawn window (the zoom clipped to the map's covered nodes): no empty bands
      .ylim(box[2], box[3]);
  fig.save(path);
}

void write_rays_png(const RayAnalysis& analysis, const ChargeMap& map, std::size_t electrode,
                    const std::vector<double>& beta_deg, const std::vector<MeasuredPress>* measured,
                    double angle_tolerance_deg, const std::string& path) {
  if (electrode >= map.ne()) throw InputError("rays picture: electrode index " + std::to_string(electrode) + " out of range");
  plot::Figure fig(1000, 750);
  auto& ax = fig.axes();
  // Colours follow β along the sequential colour map (dark violet … yellow-green), so that ten
  // or more rays stay distinct and neighbouring angles look alike.
  double beta_lo = std::numeric_limits<double>::infinity(), beta_hi = -beta_lo;
  for (double beta : beta_deg) beta_lo = std::min(beta_lo, beta), beta_hi = std::max(beta_hi, beta);
  auto beta_colour = [&](double beta) {
    return plot::colormap(beta_hi > beta_lo ? 0.88 * (beta - beta_lo) / (beta_hi - beta_lo) : 0.0);
  };
  bool any = false;
  for (double beta : beta_deg) {
    const RayChargeFit* ray = nullptr;
    for (const auto& r : analysis.rays) {
      if (r.electrode == electrode && std::abs(r.beta_deg - beta) < 1e-6) ray = &r;
    }
    if (!ray || ray->d_m.empty()) continue;
    any = true;
    const plot::Color c = beta_colour(beta);
    std::vector<double> d_mm, q_pC;
    for (std::size_t i = 0; i < ray->d_m.size(); ++i) {
      if (ray->charge_C[i] > 0) {
        d_mm.push_back(ray->d_m[i] * 1e3);
        q_pC.push_back(ray->charge_C[i] * 1e12);
      }
    }
    std::string label = (measured ? "map, " : "") + format_number("β = %.0f°", beta);
    if (ray->fitted) {
      label += format_number(": C$_2$ = %.3f", ray->C2);
      std::vector<double> fd, fq;
      for (double d : d_mm) {
        fd.push_back(d);
        fq.push_back(ray->C1_C * 1e12 * std::pow(d, ray->C2));
      }
      ax.line(fd, fq, "", c, plot::LineStyle::solid, plot::Marker::none, 1.8);
    } else {
      label += " (not fitted)";
    }
    ax.scatter(d_mm, q_pC, label, c, measured ? plot::Marker::plus : plot::Marker::circle, measured ? 6.0 : 4.0);
    if (measured) {
      // Measured presses on this ray: bearing from the electrode within the tolerance.
      std::vector<double> md, mq;
      for (const auto& m : *measured) {
        const double dx = m.x_m - map.electrode_centers_m[electrode][0], dy = m.y_m - map.electrode_centers_m[electrode][1];
        double bearing = (std::atan2(dy, dx) - analysis.draw_angle_rad) * 180.0 / pi;
        bearing = std::fmod(bearing + 720.0, 360.0);
        double off = std::abs(bearing - beta);
        off = std::min(off, 360.0 - off);
        if (off <= angle_tolerance_deg && m.charge_C[electrode] > 0) {
          md.push_back(std::hypot(dx, dy) * 1e3);
          mq.push_back(m.charge_C[electrode] * 1e12);
        }
      }
      if (!md.empty()) ax.scatter(md, mq, format_number("CSV presses, β = %.0f°", beta), c, plot::Marker::square, 8.0);
    }
  }
  if (!any) throw InputError("rays picture: electrode " + map.electrode_names[electrode] + " has no sampled ray at the requested angles");
  ax.title("Charge of electrode " + map.electrode_names[electrode] + " against distance (" +
           format_number("%.3g", analysis.options.force_N) + " N, " + map.model + " map; lines: Q = C$_1$ d$^{C_2}$)")
      .xlabel("distance d from the electrode centre (mm)")
      .ylabel("charge Q (pC)")
      .log_x()
      .log_y()
      .grid_lines()
      .legend("upper right");
  fig.save(path);
}

void write_comparison_png(const Comparison& comparison, const std::string& path, const std::string& csv_name) {
  const std::string csv = csv_name.empty() ? std::string("CSV") : csv_name;
  plot::Figure fig(1400, 650, 1, 2);
  auto& left = fig.axes(0, 0);
  auto& right = fig.axes(0, 1);
  double lo = std::numeric_limits<double>::infinity(), hi = 0;
  const std::size_t ne = comparison.electrodes.size();
  for (std::size_t k = 0; k < ne; ++k) {
    std::vector<double> qm, qf, index, pct;
    for (std::size_t i = 0; i < comparison.presses.size(); ++i) {
      const auto& p = comparison.presses[i];
      if (!std::isfinite(p.difference_pct[k])) continue;
      qf.push_back(p.map_charge_C[k] * 1e12);
      qm.push_back(p.measured.charge_C[k] * 1e12);
      index.push_back(double(i + 1));
      pct.push_back(p.difference_pct[k]);
      for (double v : {qf.back(), qm.back()}) {
        if (v > 0) {
          lo = std::min(lo, v);
          hi = std::max(hi, v);
        }
      }
    }
    const auto& s = comparison.electrodes[k];
    left.scatter(qf, qm, s.name + format_number(": mean |diff| %.1f %%", s.mean_abs_difference_pct), plot::cycle_color(k),
                 plot::Marker::circle, 6);
    right.scatter(index, pct, s.name, plot::cycle_color(k), plot::Marker::square, 6);
  }
  if (hi > 0 && std::isfinite(lo)) {
    const double a = lo / 1.3, b = hi * 1.3;
    const double f = 1.0 + paper_mean_difference_pct / 100.0;
    left.line({a, b}, {a, b}, "CSV = map", plot::Color{0, 0, 0}, plot::LineStyle::solid);
    left.line({a, b}, {a * f, b * f}, "±18 % (seed 001 mean)", plot::Color{120, 120, 120}, plot::LineStyle::dashed);
    left.line({a, b}, {a / f, b / f}, "", plot::Color{120, 120, 120}, plot::LineStyle::dashed);
    left.xlim(a, b).ylim(a, b).log_x().log_y();
  }
  left.title("Charges of the CSV against the map's")
      .xlabel("map charge (pC)")
      .ylabel("charge in " + csv + " (pC)")
      .grid_lines()
      .legend("upper left");
  right.hline(0.0, plot::Color{0, 0, 0}, plot::LineStyle::solid)
      .hline(paper_mean_difference_pct, plot::Color{120, 120, 120}, plot::LineStyle::dashed, "±18 % (seed 001 mean)")
      .hline(-paper_mean_difference_pct, plot::Color{120, 120, 120}, plot::LineStyle::dashed)
      .title(format_number("Difference per press (mean |diff| %.1f %%)", comparison.mean_abs_difference_pct))
      .xlabel("press number (CSV data row)")
      .ylabel("100·(CSV − map)/map (%)")
      .grid_lines()
      .legend("upper right");
  fig.save(path);
}

}  // namespace pvdf::mapping
