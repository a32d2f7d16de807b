// The two halves of `pvdfkit design` share these: cmd_design.cpp ranks typed layouts (its flags,
// files, text and figures around mapping::run_design_study), cmd_design_optimize.cpp searches
// layouts (--optimize, docs/design.md section 7). The command's options, one candidate layout, the
// map source chosen by the flags, and the printing steps both call.
#pragma once

#include "pvdf/mapping/design.hpp"
#include "pvdf/mapping/design_study.hpp"
#include "pvdf/mapping/map.hpp"

#include <nlohmann/json.hpp>

#include <optional>
#include <string>
#include <vector>

namespace pvdf::app::design {

struct DesignCommandOptions {
  std::vector<std::string> scenes;
  std::vector<std::string> maps;
  std::string vary;
  std::string noise = "5e-14";
  double target_mm = 0.5;
  double force_N = 1.0;
  std::string force_range = "0.25,4";
  bool force_known = false;
  double spacing_m = 0;  // 0: 1 mm synthetic, 3 mm FEM
  bool synthetic = false;
  int refine_best = 0;
  double refine_spacing_m = 0;  // 0: half the preview spacing
  double tolerance = 0;         // 0: the scene's
  int threads = 0;
  int adc_bits = 12;
  double full_scale_C = 0;
  double ambiguity_min_distance_m = 0;
  bool json = false;
  std::string out_dir = "design-out";
  bool no_plots = false;
  bool include_map_error = false;
  bool quiet = false;
  // --optimize (docs/design.md §7)
  bool optimize = false;
  std::string atlas_path;
  int electrodes_min = 3, electrodes_max = 6;
  double size_min_m = 0.001, size_max_m = 0.004;
  bool square = false, no_rotation = false;
  double min_gap_m = 0.0005, clamp_margin_m = 0.001;
  long long seed = 1;     // signed here, so that a negative value is refused, not wrapped
  long long budget = 300;
  int search_stride = 1;
  bool verify = false;
};

/// One candidate layout and what the analysis found (the library's: mapping/studies/design_study.hpp).
using Candidate = pvdf::mapping::DesignCandidate;

/// m as mm ("0.0850 mm"), "unbounded" for +inf (never "inf" or "nan" as a result).
std::string mm(double m);
/// A fraction as a percentage ("38.6 %"), "unbounded" for +inf.
std::string pct(double f);

/// The study's map source chosen by the flags: the synthetic stand-in (--synthetic) or FEM maps
/// written to --out-dir/maps/ (mapping::fem_design_maps; a progress bar per phase unless --quiet,
/// labelled `progress_label` when given). Without map generation in this build, making a FEM map
/// throws InputError.
pvdf::mapping::DesignMapSource design_maps(const DesignCommandOptions& o, std::vector<pvdf::mapping::MemorySample>* memory,
                                           const std::string& progress_label = {});
/// The analysis options from the command's flags, each checked against its rule.
pvdf::mapping::DesignOptions design_options(const DesignCommandOptions& o);
/// The figures' noise label: "σ = 0.05 pC, 12-bit ADC" (per electrode "0.05/0.1" when they differ).
std::string noise_label(const pvdf::mapping::DesignOptions& d, const DesignCommandOptions& o);
/// design_position.png and design_force.png of the (at most 8) first of `ranked`; paths appended to `written`.
void write_map_figures(const std::vector<const Candidate*>& ranked, const DesignCommandOptions& o,
                       const std::string& noise_text, std::vector<std::string>& written);

/// `pvdfkit design --optimize` (cmd_design_optimize.cpp): the exit code.
int run_optimize(const DesignCommandOptions& o);

}  // namespace pvdf::app::design
