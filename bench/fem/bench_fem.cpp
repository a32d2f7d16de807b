// bench_fem — speed against error of pvdf::fem beside CalculiX (ccx, M3D4 membranes) on the
// seed-001 film (a = 45 mm, h = 25 µm, 1 N dead vertical probe load on r < 1 mm, clamped rim),
// in the same run, one thread each. Two cases:
//   iso   — isotropic E = 2 GPa, ν = 0.3: the reference is the independent axisymmetric oracle
//           (tests/fem/oracles, Green–Lagrange membrane, ~1e-7), so both tools get true errors;
//   ortho — seed 001 Table 1 with reciprocal ν21, draw along x: the reference is the finest
//           pvdfkit level, cross-checked against the finest CalculiX level (difference printed).
// Outputs: centre deflection, and the mean 2nd Piola–Kirchhoff membrane force [N11, N22, N12]
// over each electrode square A, B, C (default scene), error = ‖N − N_ref‖ / ‖N_ref‖.
//
// The ProbeSweep path (fixed mesh, warm starts; what maps use) adds rows: setup, cold and warm
// load case (--no-sweep leaves them out).
//
// Usage: bench_fem [--quick] [--out DIR] [--no-ccx] [--no-pvdf] [--no-sweep] [--bending]
//   --quick   coarse levels only (~1–2 min); the default runs finer levels (several minutes)
//   --out     work folder for decks, the PNG and the markdown table (default bench_fem_out)
//   --bending pvdfkit with bending (CalculiX M3D4 and the oracle are pure membranes)
#include "axisymmetric_plate.hpp"
#include "ccx_peer.hpp"

#include "pvdf/core/io.hpp"
#include "pvdf/plot/plot.hpp"
#include "pvdf/core/scene.hpp"

#ifdef PVDF_BENCH_HAVE_FEM
#include "pvdf/fem/probe_sweep.hpp"
#include "pvdf/fem/solver.hpp"
#endif

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

namespace {

using pvdf::bench::CcxMaterial;
using Force3 = std::array<double, 3>;

struct Row {
  std::string tool, variant, level;
  std::size_t dofs = 0;
  double wall_s = 0;
  double deflection_m = 0;
  std::array<Force3, 3> electrode{};  // A, B, C
  double rim_N = 0;
  bool ok = false;
  bool reference = false;  // this row is the reference of its case
  std::string note;
  // errors, filled later
  double err_w = NAN;
  std::array<double, 3> err_e{NAN, NAN, NAN};
  double err_max() const { return std::max({err_w, err_e[0], err_e[1], err_e[2]}); }
};

double rel_err(const Force3& x, const Force3& ref) {
  double num = 0, den = 0;
  for (int i = 0; i < 3; ++i) {
    num += (x[i] - ref[i]) * (x[i] - ref[i]);
    den += ref[i] * ref[i];
  }
  return std::sqrt(num / den);
}

// Oracle electrode mean of [Nxx, Nyy, Nxy] over a square (global = material axes, draw along x).
Force3 oracle_square_mean(const pvdf::fem::oracles::AxisymmetricSolution& s, std::array<double, 2> c, double side) {
  Force3 sum{0, 0, 0};
  const int n = 40;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const double x = c[0] + side * ((i + 0.5) / n - 0.5), y = c[1] + side * ((j + 0.5) / n - 0.5);
      const double r = std::hypot(x, y), ct = x / r, st = y / r;
      const double Nr = s.radial_force_N_per_m(r), Nt = s.hoop_force_N_per_m(r);
      sum[0] += Nr * ct * ct + Nt * st * st;
      sum[1] += Nr * st * st + Nt * ct * ct;
      sum[2] += (Nr - Nt) * st * ct;
    }
  for (auto& v : sum) v /= n * n;
  return sum;
}

pvdf::Scene make_scene(bool isotropic) {
  pvdf::Scene scene = pvdf::default_scene();
  if (isotropic) {
    scene.material.E1_Pa = scene.material.E2_Pa = 2e9;
    scene.material.nu12 = 0.3;
    scene.material.G12_Pa = 2e9 / (2 * 1.3);
    scene.material.isotropic = true;
  }
  return scene;
}

Row run_ccx_level(const pvdf::Scene& scene, bool isotropic, int n, const std::string& dir) {
  Row row;
  row.tool = "CalculiX M3D4";
  row.variant = isotropic ? "iso" : "ortho";
  row.level = "n=" + std::to_string(n);
  const double a = scene.membrane.outline.radius_m, c = scene.probe.radius_m, h = scene.membrane.thickness_m;
  const auto mesh = pvdf::bench::make_polar_mesh(a, c, n);
  CcxMaterial mat;
  mat.isotropic = isotropic;
  mat.E_Pa = 2e9;
  mat.nu = 0.3;
  mat.ortho = scene.material;
  const std::string job = row.variant + "_n" + std::to_string(n);
  pvdf::bench::write_ccx_deck(dir + "/" + job + ".inp", mesh, mat, h, scene.loads.at(0).force_N);
  const auto r = pvdf::bench::run_ccx(dir, job, mesh);
  row.wall_s = r.wall_s;
  row.dofs = r.n_dofs;
  if (!r.ok) {
    row.note = r.message;
    return row;
  }
  row.ok = true;
  row.deflection_m = std::abs(r.centre_deflection_m);
  row.rim_N = r.rim_reaction_N;
  const Eigen::Matrix3d Q = scene.material.stiffness();
  for (std::size_t k = 0; k < 3 && k < scene.electrodes.size(); ++k)
    row.electrode[k] = pvdf::bench::electrode_mean_force(mesh, r.displacement_m, Q, h, scene.material.draw_angle_rad,
                                                         scene.electrodes[k].center_m, scene.electrodes[k].size_m[0]);
  if (std::abs(row.rim_N - 1.0) > 1e-3) row.note = "rim reaction off";
  return row;
}

#ifdef PVDF_BENCH_HAVE_FEM
Row run_pvdf_level(const pvdf::Scene& scene, bool isotropic, int refinements, bool bending) {
  Row row;
  row.tool = "pvdfkit";
  row.variant = isotropic ? "iso" : "ortho";
  row.level = "ref=" + std::to_string(refinements);
  pvdf::fem::Options o;
  o.model = pvdf::fem::Model::large_rotation;
  o.include_bending = bending;
  o.adaptive = false;
  if (refinements < 0) {
    // A deliberately coarse mesh (3× the default sizes) to reach into CalculiX's error range.
    row.level = "coarse";
    o.coarse_size_m = scene.membrane.outline.radius_m / 2;
    o.probe_size_m = 1.5 * scene.probe.radius_m;
    o.electrode_size_m = 0.75 * scene.electrodes.at(0).size_m[0];
  } else {
    o.initial_global_refinements = refinements;
  }
  const auto t0 = std::chrono::steady_clock::now();
  const auto res = pvdf::fem::solve(scene, o);
  row.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  row.dofs = res.summary.n_dofs;
  if (!pvdf::fem::usable(res.summary.status)) {
    row.note = pvdf::fem::status_name(res.summary.status) + ": " + res.summary.message;
    return row;
  }
  row.ok = true;
  row.deflection_m = std::abs(res.deflection_at_load_m);
  row.rim_N = std::abs(res.rim_reaction_N);
  for (std::size_t k = 0; k < 3 && k < res.electrodes.size(); ++k)
    row.electrode[k] = res.electrodes[k].mean_membrane_force_material_N_per_m;
  return row;
}

// The ProbeSweep path (fixed sweep mesh, kept factorization pattern, warm starts): one row for
// the setup (mesh, DOFs, three check solves against direct solves), one for a cold load case
// (continuation from the flat film) and one for a warm load case (the centred probe warm-started
// from the converged state of a probe 1 mm away, what a map does between grid neighbours).
std::vector<Row> run_pvdf_sweep(const pvdf::Scene& scene, bool isotropic, bool bending) {
  std::vector<Row> rows(3);
  for (Row& r : rows) {
    r.tool = "pvdfkit";
    r.variant = isotropic ? "iso" : "ortho";
  }
  rows[0].level = "sweep setup";
  rows[1].level = "sweep cold";
  rows[2].level = "sweep warm";
  pvdf::fem::SweepOptions so;
  so.solver.model = pvdf::fem::Model::large_rotation;
  so.solver.include_bending = bending;
  auto t0 = std::chrono::steady_clock::now();
  pvdf::fem::ProbeSweep sweep(scene, so);
  rows[0].wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  rows[0].dofs = sweep.setup().n_dofs;  // printed only with a load case (ok rows)
  rows[0].note = "setup only (no load case); estimated charge error " +
                 std::to_string(sweep.setup().estimated_relative_error);
  const double x = scene.loads.at(0).position_m[0], y = scene.loads.at(0).position_m[1];
  const double F = scene.loads.at(0).force_N;
  pvdf::fem::SweepState neighbour;
  const auto n = sweep.solve(x + 1e-3, y, F, nullptr, &neighbour);
  const pvdf::fem::ProbeSolution cold = sweep.solve(x, y, F);
  const pvdf::fem::ProbeSolution warm = sweep.solve(x, y, F, &neighbour);
  for (int i = 1; i < 3; ++i) {
    const auto& p = i == 1 ? cold : warm;
    Row& r = rows[i];
    r.dofs = sweep.setup().n_dofs;
    r.wall_s = p.wall_s;
    if (!pvdf::fem::usable(p.status) || !pvdf::fem::usable(n.status)) {
      r.note = pvdf::fem::status_name(p.status) + ": " + p.message;
      continue;
    }
    r.ok = true;
    r.deflection_m = std::abs(p.deflection_at_load_m);
    r.rim_N = std::abs(p.rim_reaction_N);
    for (std::size_t k = 0; k < 3 && k < p.mean_membrane_force_material_N_per_m.size(); ++k)
      r.electrode[k] = p.mean_membrane_force_material_N_per_m[k];
    r.note = std::to_string(p.newton_iterations) + " Newton iterations";
  }
  return rows;
}
#endif

// Time of `rows` (one tool, one variant) at error `e`: log–log interpolation between levels, or
// extrapolation of the power law through the two most accurate levels when `e` is below the
// range (`extrapolated` set). NaN when fewer than two levels or `e` above the range.
double time_at_error(const std::vector<const Row*>& rows, double e, bool& extrapolated) {
  extrapolated = false;
  std::vector<std::pair<double, double>> pts;  // (log err, log time)
  for (const Row* r : rows)
    if (r->ok && r->err_max() > 0) pts.emplace_back(std::log(r->err_max()), std::log(r->wall_s));
  std::sort(pts.begin(), pts.end());
  if (pts.size() < 2) return NAN;
  const double le = std::log(e);
  for (std::size_t i = 0; i + 1 < pts.size(); ++i)
    if (le >= pts[i].first && le <= pts[i + 1].first) {
      const double t = (le - pts[i].first) / (pts[i + 1].first - pts[i].first + 1e-300);
      return std::exp(pts[i].second + t * (pts[i + 1].second - pts[i].second));
    }
  if (le < pts[0].first && pts[1].first > pts[0].first) {
    extrapolated = true;
    const double slope = (pts[1].second - pts[0].second) / (pts[1].first - pts[0].first);
    return std::exp(pts[0].second + slope * (le - pts[0].first));
  }
  return NAN;
}

/// One number for the table; a dash where there is none.
std::string fmt(const char* f, double v) { return std::isfinite(v) ? pvdf::format_printf(f, v) : "—"; }

struct BenchArgs {
  bool quick = false, use_ccx = true, use_pvdf = true, bending = false, use_sweep = true;
  std::string out = "bench_fem_out";
};

// The command line; returns an exit code when the run should stop here (help, bad argument, no
// work folder), -1 to go on.
int parse_args(int argc, char** argv, BenchArgs& args) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--quick") args.quick = true;
    else if (a == "--no-ccx") args.use_ccx = false;
    else if (a == "--no-pvdf") args.use_pvdf = false;
    else if (a == "--bending") args.bending = true;
    else if (a == "--no-sweep") args.use_sweep = false;
    else if (a == "--out" && i + 1 < argc) args.out = argv[++i];
    else if (a == "--help" || a == "-h") {
      std::cout << "usage: bench_fem [--quick] [--out DIR] [--no-ccx] [--no-pvdf] [--no-sweep] [--bending]\n";
      return 0;
    } else {
      std::cerr << "error: bench_fem: unknown argument '" << a << "'; see --help\n";
      return 2;
    }
  }
  if (std::system(("mkdir -p '" + args.out + "'").c_str()) != 0) {
    std::cerr << "error: cannot create " << args.out << "\n";
    return 2;
  }
  if (args.use_ccx && std::system("command -v ccx > /dev/null 2>&1") != 0) {
    std::cerr << "note: ccx not found (apt-get install calculix-ccx); CalculiX rows skipped\n";
    args.use_ccx = false;
  }
  return -1;
}

// The rows of one case: CalculiX levels, pvdfkit levels and (optionally) the sweep rows.
void run_levels(const pvdf::Scene& scene, bool iso, const BenchArgs& args, std::vector<Row>& rows) {
  const std::vector<int> ccx_levels = args.quick ? std::vector<int>{4, 8} : std::vector<int>{4, 8, 16, 24};
  if (args.use_ccx)
    for (int n : ccx_levels) {
      rows.push_back(run_ccx_level(scene, iso, n, args.out));
      std::cerr << "  ccx " << rows.back().variant << " " << rows.back().level << " " << rows.back().wall_s << " s\n";
    }
#ifdef PVDF_BENCH_HAVE_FEM
  const std::vector<int> pvdf_levels = args.quick ? std::vector<int>{-1, 0} : std::vector<int>{-1, 0, 1};
  if (args.use_pvdf) {
    for (int l : pvdf_levels) {
      rows.push_back(run_pvdf_level(scene, iso, l, args.bending));
      std::cerr << "  pvdfkit " << rows.back().variant << " " << rows.back().level << " " << rows.back().wall_s
                << " s " << rows.back().note << "\n";
    }
    if (args.use_sweep)
      for (const Row& r : run_pvdf_sweep(scene, iso, args.bending)) {
        rows.push_back(r);
        std::cerr << "  pvdfkit " << r.variant << " " << r.level << " " << r.wall_s << " s " << r.note << "\n";
      }
  }
#else
  if (args.use_pvdf) {
    Row r;
    r.tool = "pvdfkit";
    r.variant = iso ? "iso" : "ortho";
    r.level = "—";
    r.note = "not available (pvdf::fem not built)";
    rows.push_back(r);
  }
#endif
}

// The iso reference: the axisymmetric oracle.
void oracle_reference(const pvdf::Scene& scene, bool bending, double& w_ref, std::array<Force3, 3>& e_ref,
                      std::ostringstream& notes) {
  pvdf::fem::oracles::AxisymmetricProblem p;
  p.radius_m = scene.membrane.outline.radius_m;
  p.thickness_m = scene.membrane.thickness_m;
  p.youngs_modulus_Pa = 2e9;
  p.poisson_ratio = 0.3;
  p.force_N = scene.loads.at(0).force_N;
  p.load_radius_m = scene.probe.radius_m;
  p.kinematics = pvdf::fem::oracles::Kinematics::green_lagrange;
  p.bending = bending;
  const auto s = pvdf::fem::oracles::solve_axisymmetric(p, {bending ? 300 : 400});
  if (!s.converged) throw std::runtime_error("oracle did not converge");
  w_ref = s.centre_deflection_m();
  for (int k = 0; k < 3; ++k) e_ref[k] = oracle_square_mean(s, scene.electrodes[k].center_m, scene.electrodes[k].size_m[0]);
  notes << "iso reference: axisymmetric oracle (Green–Lagrange " << (bending ? "membrane + bending" : "membrane")
        << ", 400 Hermite elements): w0 = " << fmt("%.6f", 1e3 * w_ref) << " mm, electrode A mean [N11, N22, N12] = ["
        << fmt("%.3f", e_ref[0][0]) << ", " << fmt("%.3f", e_ref[0][1]) << ", " << fmt("%.3f", e_ref[0][2]) << "] N/m\n";
}

// The ortho reference: the finest pvdfkit mesh level of the case (rows from `first` on), else the
// finest CalculiX level; the two finest levels are cross-checked.
void finest_level_reference(std::vector<Row>& rows, std::size_t first, double& w_ref, std::array<Force3, 3>& e_ref,
                            std::ostringstream& notes) {
  Row* best = nullptr;
  for (std::size_t i = first; i < rows.size(); ++i)  // the finest mesh level, not a sweep row
    if (rows[i].ok && rows[i].tool == "pvdfkit" && rows[i].level.rfind("sweep", 0) != 0) best = &rows[i];
  Row* best_ccx = nullptr;
  for (std::size_t i = first; i < rows.size(); ++i)
    if (rows[i].ok && rows[i].tool != "pvdfkit") best_ccx = &rows[i];
  Row* ref = best ? best : best_ccx;
  if (!ref) return;
  ref->reference = true;
  w_ref = ref->deflection_m;
  e_ref = ref->electrode;
  notes << "ortho reference: " << ref->tool << " " << ref->level << " (the finest " << ref->tool
        << " level): w0 = " << fmt("%.6f", 1e3 * w_ref) << " mm\n";
  if (best && best_ccx)
    notes << "ortho cross-check, finest CalculiX (" << best_ccx->level << ") vs finest pvdfkit: w0 differs by "
          << fmt("%.2e", std::abs(best_ccx->deflection_m - w_ref) / w_ref) << ", electrodes A/B/C by "
          << fmt("%.2e", rel_err(best_ccx->electrode[0], e_ref[0])) << " / "
          << fmt("%.2e", rel_err(best_ccx->electrode[1], e_ref[1])) << " / "
          << fmt("%.2e", rel_err(best_ccx->electrode[2], e_ref[2])) << "\n";
}

// The markdown table: every row with its errors and, for pvdfkit, its time ratio against
// CalculiX at equal error.
std::string markdown_table(const std::vector<Row>& rows) {
  std::ostringstream md;
  md << "| tool | case | level | DOFs | wall_s | rim F (N) | err w0 | err A | err B | err C | t_pvdf / t_ccx at equal error |\n"
     << "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const Row& r : rows) {
    std::string ratio = "—";
    if (r.ok && r.tool == "pvdfkit") {
      std::vector<const Row*> peers;
      for (const Row& q : rows)
        if (q.tool != "pvdfkit" && q.variant == r.variant) peers.push_back(&q);
      bool extrapolated = false;
      const double t = time_at_error(peers, r.err_max(), extrapolated);
      if (std::isfinite(t) && r.err_max() > 0)
        ratio = fmt("%.3g", r.wall_s / t) + (extrapolated ? " (ccx extrapolated)" : "");
    }
    md << "| " << r.tool << " | " << r.variant << " | " << r.level << " | " << (r.ok ? std::to_string(r.dofs) : "—")
       << " | " << (r.ok || r.wall_s > 0 ? fmt("%.2f", r.wall_s) : "—") << " | " << (r.ok ? fmt("%.5f", r.rim_N) : "—") << " | ";
    if (r.reference)
      md << "(reference) | | | | — |\n";
    else
      md << fmt("%.2e", r.err_w) << " | " << fmt("%.2e", r.err_e[0]) << " | " << fmt("%.2e", r.err_e[1]) << " | "
         << fmt("%.2e", r.err_e[2]) << " | " << (r.ok ? ratio : r.note) << " |\n";
  }
  return md.str();
}

// Speed against error: one line per tool and case, the sweep rows as points.
void speed_error_figure(const std::vector<Row>& rows, const std::string& path) {
  pvdf::plot::Figure fig(1000, 700);
  auto& ax = fig.axes();
  std::size_t colour = 0;
  for (const std::string tool : {"CalculiX M3D4", "pvdfkit"})
    for (const std::string variant : {"iso", "ortho"}) {
      std::vector<double> x, y;
      for (const Row& r : rows)
        if (r.ok && r.tool == tool && r.variant == variant && r.err_max() > 0 && r.level.rfind("sweep", 0) != 0) {
          x.push_back(r.wall_s);
          y.push_back(r.err_max());
        }
      if (x.empty()) continue;
      ax.line(x, y, tool + " (" + variant + ")", pvdf::plot::cycle_color(colour++),
              variant == "iso" ? pvdf::plot::LineStyle::solid : pvdf::plot::LineStyle::dashed,
              tool == "pvdfkit" ? pvdf::plot::Marker::circle : pvdf::plot::Marker::square);
    }
  for (const std::string level : {"sweep cold", "sweep warm"})
    for (const std::string variant : {"iso", "ortho"}) {
      std::vector<double> x, y;
      for (const Row& r : rows)
        if (r.ok && r.level == level && r.variant == variant && r.err_max() > 0) {
          x.push_back(r.wall_s);
          y.push_back(r.err_max());
        }
      if (x.empty()) continue;
      ax.scatter(x, y, "pvdfkit ProbeSweep, " + level.substr(6) + " load case (" + variant + ")",
                 pvdf::plot::cycle_color(colour++), level == "sweep warm" ? pvdf::plot::Marker::triangle
                                                                         : pvdf::plot::Marker::cross);
    }
  ax.log_x().log_y().grid_lines().legend("best");  // placed where it covers the fewest points
  ax.xlabel("wall time, 1 thread (s)").ylabel("max relative error (w0, electrode forces)");
  ax.title("seed-001 film, 1 N probe: speed against error");
  fig.save_png(path);
}

}  // namespace

int main(int argc, char** argv) {
  try {
    BenchArgs args;
    const int stop = parse_args(argc, argv, args);
    if (stop >= 0) return stop;
    std::vector<Row> rows;
    std::ostringstream notes;

    for (const bool iso : {true, false}) {
      const pvdf::Scene scene = make_scene(iso);
      const std::size_t first = rows.size();
      run_levels(scene, iso, args, rows);
      // Reference.
      double w_ref = NAN;
      std::array<Force3, 3> e_ref{};
      if (iso) {
        oracle_reference(scene, args.bending, w_ref, e_ref, notes);
      } else {
        finest_level_reference(rows, first, w_ref, e_ref, notes);
      }
      for (std::size_t i = first; i < rows.size(); ++i) {
        Row& r = rows[i];
        if (!r.ok || !std::isfinite(w_ref)) continue;
        r.err_w = std::abs(r.deflection_m - w_ref) / w_ref;
        for (int k = 0; k < 3; ++k) r.err_e[k] = rel_err(r.electrode[k], e_ref[k]);
      }
    }

    // The table.
    const std::string md = markdown_table(rows);
    std::cout << md << "\n" << notes.str();
    pvdf::write_file_atomically(args.out + "/bench_fem_table.md", [&](std::ostream& os) { os << md << "\n" << notes.str(); });

    speed_error_figure(rows, args.out + "/bench_fem.png");
    std::cout << "\nwrote " << args.out << "/bench_fem_table.md and " << args.out << "/bench_fem.png\n";
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
}
