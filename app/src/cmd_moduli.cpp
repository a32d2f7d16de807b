// `pvdfkit moduli`: off-axis engineering constants of the film against angle from the draw
// direction (seed 001 eqs 3–5, corrected, computed by compliance rotation; Fig. 2).
#include "command.hpp"

#include "pvdf/core/constants.hpp"
#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"
#include "pvdf/core/material.hpp"
#include "pvdf/plot/plot.hpp"
#include "pvdf/core/scene.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>

namespace {

using pvdf::pi;

struct ModuliOptions {
  std::string scene_path;
  std::string angles = "0:5:90";
  bool json = false;
  bool csv = false;
  std::string plot_path;
};

void write_plot(const std::string& path, const pvdf::Material& material, const std::vector<double>& angles_deg) {
  // Smooth curves on a fine grid over the requested span.
  const double lo = angles_deg.front(), hi = angles_deg.back();
  const int n = 361;
  std::vector<double> a, ex, ey, gxy, nuxy, nuyx, nuxy_printed;
  for (int i = 0; i < n; ++i) {
    const double deg = lo + (hi - lo) * i / (n - 1);
    const auto m = pvdf::off_axis_moduli(material, deg * pi / 180);
    const auto p = pvdf::off_axis_moduli_printed(material, deg * pi / 180, material.nu21(), false);
    a.push_back(deg);
    ex.push_back(m.Ex_Pa / 1e9);
    ey.push_back(m.Ey_Pa / 1e9);
    gxy.push_back(m.Gxy_Pa / 1e9);
    nuxy.push_back(m.nuxy);
    nuyx.push_back(m.nuyx);
    nuxy_printed.push_back(p.nuxy);
  }
  pvdf::plot::Figure fig(1400, 600, 1, 2);
  char constants[96];
  std::snprintf(constants, sizeof constants, "$E_1$ = %.2f GPa, $E_2$ = %.2f GPa", material.E1_Pa / 1e9,
                material.E2_Pa / 1e9);
  fig.suptitle(std::string("PVDF film off-axis constants (") + constants + ")");
  auto& left = fig.axes(0, 0);
  left.line(a, ex, "$E_x$ (seed 001 Fig. 2)")
      .line(a, ey, "$E_y$ (seed 001 Fig. 2)")
      .line(a, gxy, "$G_{xy}$", std::nullopt, pvdf::plot::LineStyle::dashed)
      .title("Moduli against angle from the draw direction")
      .xlabel("angle β from the draw direction (°)")
      .ylabel("modulus (GPa)")
      .xlim(lo, hi)
      .ylim(0.0, 1.3 * std::max(material.E1_Pa, material.E2_Pa) / 1e9)
      .grid_lines()
      .legend("upper right");
  auto& right = fig.axes(0, 1);
  right.line(a, nuxy, "$\\nu_{xy}$ (tensor rotation)")
      .line(a, nuyx, "$\\nu_{yx}$ (tensor rotation)")
      .line(a, nuxy_printed, "$\\nu_{xy}$ by eq. 5 as printed (sign error)", std::nullopt, pvdf::plot::LineStyle::dotted)
      .title("Poisson ratios")
      .xlabel("angle β from the draw direction (°)")
      .ylabel("Poisson's ratio (−)")
      .xlim(lo, hi)
      .ylim(std::min(0.0, *std::min_element(nuxy_printed.begin(), nuxy_printed.end())),
            1.35 * std::max({*std::max_element(nuxy_printed.begin(), nuxy_printed.end()),
                             *std::max_element(nuxy.begin(), nuxy.end()),
                             *std::max_element(nuyx.begin(), nuyx.end())}))
      .grid_lines()
      .legend("upper right");
  fig.save(path);
}

int run_moduli(const ModuliOptions& o) {
  const pvdf::Scene scene = o.scene_path.empty() ? pvdf::default_scene() : pvdf::load_scene(o.scene_path);
  for (const auto& w : scene.warnings) pvdf::app::warn(w);
  if (o.json && o.csv) throw pvdf::InputError("--json and --csv: choose one output format");
  const auto angles = pvdf::parse_range(o.angles, "--angles-deg", 100000);
  std::vector<pvdf::OffAxisModuli> rows;
  for (double a : angles) rows.push_back(pvdf::off_axis_moduli(scene.material, a * pi / 180));

  if (o.json) {
    nlohmann::json out = nlohmann::json::array();
    for (std::size_t i = 0; i < rows.size(); ++i) {
      out.push_back({{"angle_deg", angles[i]}, {"Ex_Pa", rows[i].Ex_Pa}, {"Ey_Pa", rows[i].Ey_Pa},
                     {"Gxy_Pa", rows[i].Gxy_Pa}, {"nuxy", rows[i].nuxy}, {"nuyx", rows[i].nuyx}});
    }
    std::cout << out.dump(2) << '\n';
  } else if (o.csv) {
    std::printf("angle_deg,Ex_Pa,Ey_Pa,Gxy_Pa,nuxy,nuyx\n");
    for (std::size_t i = 0; i < rows.size(); ++i) {
      std::printf("%.17g,%.17g,%.17g,%.17g,%.17g,%.17g\n", angles[i], rows[i].Ex_Pa, rows[i].Ey_Pa,
                  rows[i].Gxy_Pa, rows[i].nuxy, rows[i].nuyx);
    }
  } else {
    const auto& m = scene.material;
    std::printf("PVDF off-axis constants (%s): E1 = %.3g GPa, E2 = %.3g GPa, G12 = %.3g GPa, nu12 = %.3g, "
                "nu21 = nu12*E2/E1 = %.4g\n",
                scene.source.c_str(), m.E1_Pa / 1e9, m.E2_Pa / 1e9, m.G12_Pa / 1e9, m.nu12, m.nu21());
    std::printf("%10s %10s %10s %10s %8s %8s\n", "angle_deg", "Ex_GPa", "Ey_GPa", "Gxy_GPa", "nuxy", "nuyx");
    for (std::size_t i = 0; i < rows.size(); ++i) {
      std::printf("%10.2f %10.4f %10.4f %10.4f %8.4f %8.4f\n", angles[i], rows[i].Ex_Pa / 1e9,
                  rows[i].Ey_Pa / 1e9, rows[i].Gxy_Pa / 1e9, rows[i].nuxy, rows[i].nuyx);
    }
  }
  if (!o.plot_path.empty()) {
    write_plot(o.plot_path, scene.material, angles);
    if (!o.json && !o.csv) std::printf("plot written to %s\n", o.plot_path.c_str());
  }
  return pvdf::exit_code::success;
}

}  // namespace

PVDF_COMMAND(10, [](CLI::App& root) {
  auto* sub = root.add_subcommand("moduli", "Off-axis moduli E_x, E_y, G_xy, nu_xy, nu_yx of the film against angle "
                                            "from the draw direction (seed 001 eqs 3-5, Fig. 2)");
  auto o = std::make_shared<ModuliOptions>();
  sub->add_option("--scene", o->scene_path, "Scene file (JSON) whose material to use (default the built-in seed-001 PVDF)");
  sub->add_option("--angles-deg", o->angles, "Angles from the draw direction START:STEP:STOP (deg) (default 0:5:90)");
  sub->add_flag("--json", o->json, "Print a JSON array of {angle_deg, Ex_Pa, Ey_Pa, Gxy_Pa, nuxy, nuyx}");
  sub->add_flag("--csv", o->csv, "Print CSV with the same columns");
  sub->add_option("--plot", o->plot_path, "Write the moduli against angle (seed 001 Fig. 2) as .png, .svg or .pdf")
      ->check(pvdf::app::figure_file());
  return pvdf::app::Subcommand{sub, [o] { return run_moduli(*o); }};
});
