// A randomized family of scanner scenes for studying the restoration on data it was not tuned on:
// its own forward model (Flamant kernels differentiated numerically, finite electrodes, contact
// patches, strips at their own depths, noise 20-60 dB, ADC, speeds, edge shapes, textures) and the
// measurements that score a restoration (mu and position at each edge, force L2 error).
#pragma once

#include "pvdf/restore/apply.hpp"
#include "pvdf/restore/filter.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace pvdf::restore::family {

/// How the strip's response to a line load is modelled (all plane-strain Flamant underneath).
enum class KernelModel {
  point_strip,     ///< the electrode is a point in x
  wide_electrode,  ///< charge averaged over the electrode width (width_m)
  contact_patch    ///< the load is spread over a Hertz (semi-elliptic) patch of half-width patch_m
};

/// Shape of a raised edge along x (all carry the same total force and have their centroid at x_m).
enum class EdgeShape { impulse, gaussian, rectangle };

/// One raised edge of a test surface.
struct FamilyEdge {
  double x_m = 0, fx_N = 0, fz_N = 0;
  EdgeShape shape = EdgeShape::impulse;
  double width_m = 0;  ///< FWHM (gaussian) or full width (rectangle)
};

/// A ridged texture: Hann ridges every period_m on [x_start_m, x_end_m], normal force fz_N each, friction mu.
struct FamilyTexture {
  double x_start_m = 0, x_end_m = 0, period_m = 0, ridge_width_m = 0, fz_N = 0, mu = 0;
};

/// The scanner of one scene: two strips at their own depths and offsets, an acquisition chain.
struct FamilyScanner {
  KernelModel model = KernelModel::point_strip;
  double depth_m[2] = {1e-3, 1e-3};
  double offset_m[2] = {0, 1.5e-3};
  double k_C_per_N[2][3] = {{23e-12, 3e-12, -33e-12}, {-33e-12, 23e-12, 3e-12}};
  double width_m = 1e-3;    ///< electrode width along x (wide_electrode)
  double length_m = 0.02;   ///< electrode length = contact line length
  double patch_m = 0;       ///< contact half-width (contact_patch)
  double poisson_ratio = 0.5;
  double speed_m_per_s = 0.05;
  double sample_rate_Hz = 10000;
  double snr_dB = 40;       ///< 20 log10(peak signal of the first identification scan / noise rms)
  int adc_bits = 12;
  double adc_headroom = 2;  ///< ADC range = headroom x the peak of the first identification scan
  int moving_average = 8;
  double sample_spacing_m() const { return speed_m_per_s / sample_rate_Hz; }
};

/// One scene: a scanner, two identification edges (known forces, sharp), a test surface with three
/// raised edges of known mu and optionally a texture, scanned over [x_start_m, x_end_m].
struct FamilyScene {
  std::uint64_t seed = 0;
  FamilyScanner scanner;
  double x_start_m = -0.04, x_end_m = 0.04;
  std::vector<FamilyEdge> identification;  ///< two edges at known positions and forces
  int identification_passes = 4;           ///< scans of each identification edge (independent noise)
  std::vector<FamilyEdge> edges;           ///< three test edges
  std::vector<FamilyTexture> textures;
  std::string describe() const;
};

/// Draws a scene from the family: depths 0.6-1.6 mm (each strip its own), horizontal+vertical or two
/// horizontal strips at different depths, piezo constants +-20 %, kernel model, contact patch 0.05-0.3 mm,
/// electrode width 0.5-1.5 mm, offsets, SNR 20-60 dB, moving average 1-12, speed 25-80 mm/s, edge shapes,
/// test-edge mu 0.1-0.9 and f_z 0.4-1.5 N, a texture in half of the scenes. Deterministic in `seed`.
FamilyScene draw_scene(std::uint64_t seed);

/// The edges' (fx, fz) on the scene's grid: force per sample (N), shapes integrated over each sample.
void sampled_forces(const FamilyScene& scene, const std::vector<FamilyEdge>& edges,
                    const std::vector<FamilyTexture>& textures, const std::vector<double>& x_m,
                    std::vector<double>& fx_N, std::vector<double>& fz_N);

/// Scans a surface with the scene's scanner: signals from the sampled forces convolved with the model's
/// kernels, then noise (from snr_dB, fixed per scanner), ADC and moving average. `noise_seed` picks the
/// noise realization. The scan carries the per-sample reference forces.
Scan scan_surface(const FamilyScene& scene, const std::vector<FamilyEdge>& edges,
                  const std::vector<FamilyTexture>& textures, std::uint64_t noise_seed);

/// The identification scans of the scene (identification_passes per edge) with their known forces and positions.
std::vector<IdentificationScan> identification_scans(const FamilyScene& scene);
/// The test scan (three edges and the texture).
Scan test_scan(const FamilyScene& scene);

/// What a restoration got right at one edge.
struct EdgeScore {
  double mu_error = 0;        ///< |f_x/f_z at the f_z peak - true mu|
  double position_error_m = 0;///< |centroid of the f_z main lobe (f_z > half peak) - true x|
  double peak_N_per_m = 0;
};

/// Scores the restored forces at each edge (peak searched within +-search_m of the true position).
std::vector<EdgeScore> score_edges(const RestoredForces& r, const std::vector<FamilyEdge>& edges,
                                   double search_m = 1e-3);

/// Relative L2 error of (f_x, f_z) against the truth blurred by the filter's target, over the samples
/// within `margin_m` of an edge or texture; each channel's mean over those samples removed.
double force_l2_error(const RestoredForces& r, const Scan& scan, double resolution_m);

}  // namespace pvdf::restore::family
