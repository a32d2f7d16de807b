// Charge-map generation with the FEM solver: every grid position × force level → the
// charge of every electrode, the deflection at the load and a status. Fast by design (warm
// starts along rows, F^(2/3) force scaling where checked, mirror symmetry), MPI/thread scale-out,
// checkpoints. Target pvdf_mapping_fem (needs pvdf_fem); docs/map-generation.md.
#pragma once

#include "pvdf/core/scene.hpp"
#include "pvdf/mapping/locator.hpp"
#include "pvdf/mapping/map.hpp"

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace pvdf::mesh {
struct FilmMesh;  // pvdf/mesh/film_mesh.hpp
}

namespace pvdf::mapping {

/// Where the rim model (bending kept, mesh graded toward the clamp) solves a node.
enum class RimModel {
  by_estimate,  ///< where the cheap model's estimated model error exceeds half the tolerance
  never,
  always
};
/// What happens to a node whose estimate still exceeds the tolerance after the sweep.
enum class DirectSolves {
  by_estimate,  ///< solved again by the adaptive solver at that press alone (node model 2)
  never         ///< the sweep's values kept, flagged tolerance_not_met
};
/// The mesh each probe is solved on.
enum class ProbeRefinement {
  footprint,  ///< the sweep mesh refined around the probe's own footprint
  none        ///< the sweep mesh alone
};
/// The names the command line and the checkpoint hash use ("by-estimate", "never", ...).
std::string option_name(RimModel value);
std::string option_name(DirectSolves value);
std::string option_name(ProbeRefinement value);
/// Parses a name; throws pvdf::InputError "`flag` `text`: use …" (the choices) otherwise.
RimModel parse_rim_model(const std::string& text, const std::string& flag);
DirectSolves parse_direct_solves(const std::string& text, const std::string& flag);
ProbeRefinement parse_probe_refinement(const std::string& text, const std::string& flag);

/// Where a map generation solves (docs/map-generation.md §10).
enum class Placement {
  /// Every grid node is solved (the stored error is each node's own estimate; the lookup adds
  /// its interpolation-error estimate, docs/lookup.md §1.10).
  uniform,
  /// A coarse level (2^adaptive_levels × the spacing) is solved everywhere; then, level by level,
  /// the next level's nodes are solved only in cells whose estimated interpolation error exceeds
  /// its share of the tolerance. The other nodes are filled from the coarser level's interpolant
  /// (provenance::interpolated), and every node stores its total error (node + between nodes +
  /// between force levels; ChargeMap::charge_error_is_total).
  adaptive
};

/// Settings of a map generation (public members with defaults).
struct MapOptions {
  /// Grid spacing in x and y (m). Grid nodes sit at integer multiples of it (the origin is a
  /// node), so a mirror-symmetric scene gives a mirror-symmetric grid. With adaptive placement
  /// the finest spacing at which a solve is placed (the stored grid has this spacing).
  double spacing_m = 0.002;
  /// Uniform or adaptive placement of the solves (see Placement). Uniform by default: measured on
  /// seed 001 (docs/map-generation.md §10), adaptive placement has not yet saved a solve and its
  /// stored totals over-state the error between nodes 10–25×, so it is opt-in until its estimator is sharper.
  Placement placement = Placement::uniform;
  /// Adaptive placement: levels of refinement below the coarse level (coarse spacing =
  /// 2^adaptive_levels × spacing_m), 1..5. The force-scaling check positions are then the coarse
  /// level's nodes (scaling_check_stride is set to 2^adaptive_levels).
  int adaptive_levels = 2;
  /// Force levels (N), > 0; sorted ascending and de-duplicated in the map.
  std::vector<double> forces_N{1.0};
  /// Optional rectangle {xmin, xmax, ymin, ymax} (m) limiting the mapped positions; default:
  /// the film's bounding box. Positions outside the film minus the rim margin are always masked.
  std::optional<std::array<double, 4>> region_m;
  /// Probe centres closer than this to the rim are not mapped (m); 0 = twice the probe radius.
  double rim_margin_m = 0.0;
  /// Kinematics: "auto" | "linear" | "von-karman" | "large-rotation"; "" = the scene's.
  std::string model = "auto";
  /// Requested relative error of the charges (0 = the scene's model.tolerance). Also the
  /// acceptance threshold of the force-scaling check.
  double tolerance = 0.01;
  /// Use Q ∝ F^(2/3), w ∝ F^(1/3) from the largest level for the other levels where the check
  /// passes (all levels solved on a coarse lattice of check positions; a position is scaled
  /// only when every check position at the corners of its lattice cell passed).
  bool use_force_scaling = true;
  /// Lattice step of the force-scaling check positions, in grid steps (>= 1).
  int scaling_check_stride = 4;
  /// Copy results to mirror-image positions when the scene is mirror-symmetric about x and/or y.
  bool use_symmetry = true;
  /// Probe positions at which the solver setup evaluates its error estimate to size the sweep
  /// mesh (0..4, pvdf::fem::SweepOptions::n_setup_checks); 0 = keep the first mesh. Every node
  /// carries its own estimate either way (/estimated_charge_error_C).
  int n_setup_checks = 3;
  /// Where the rim model (bending kept, mesh graded toward the clamp) solves a node.
  RimModel rim_model = RimModel::by_estimate;
  /// Nodes whose estimate still exceeds the tolerance after the sweep (and the rim model):
  /// by_estimate solves each again with the adaptive solver at that press alone (its own
  /// goal-oriented mesh; with model auto as `pvdfkit solve` decides bending and the clamp layer,
  /// else bending kept; node model 2), never keeps the sweep's values flagged
  /// tolerance_not_met.
  DirectSolves direct_solves = DirectSolves::by_estimate;
  /// footprint: each probe is solved on the sweep mesh refined around its own footprint
  /// (pvdf::fem::SweepOptions::probe_size_m); none: on the sweep mesh alone (faster, but its
  /// charges then carry the footprint's discretization error, which the estimate does not see).
  ProbeRefinement probe_refinement = ProbeRefinement::footprint;
  /// Worker threads in this process (one ProbeSweep each); 0 = hardware concurrency.
  int threads = 0;
  /// Checkpoint file ("" = none). Completed rows are saved periodically (atomically); an
  /// existing checkpoint for the same scene and options is resumed when `resume` is true; a
  /// checkpoint for different scene/options is refused (pvdf::InputError).
  std::string checkpoint_path;
  bool resume = true;
  /// Minimum time between checkpoint writes (s); 0 = after every completed row.
  double checkpoint_interval_s = 30.0;
  /// Split the positions over the ranks of MPI_COMM_WORLD (MPI must be initialized, e.g. by
  /// MpiSession). Every rank must call generate_map with the same arguments; rank 0 returns
  /// the complete map, the other ranks return a map holding only their own rows.
  bool distributed = false;
  /// Test hook: stop (as if killed) after this many solved positions in this process
  /// (0 = never); the map then holds not_computed points and the checkpoint is written.
  std::size_t stop_after_positions = 0;
  /// When non-null and set (e.g. by a SIGINT/SIGTERM handler), workers stop after their
  /// current solve like the stop hook: completed rows are checkpointed, the rest not_computed.
  const std::atomic<bool>* cancel = nullptr;
  /// Called (from one thread) as positions complete: (done, total) over this process.
  std::function<void(std::size_t done, std::size_t total)> progress;
  /// Called (from one thread) after each completed row with the seconds this process still needs
  /// for the positions it knows of (pvdf::ItemCostEta: a position's cost predicted from its distance
  /// to the clamp, by the kinds of solve — cheap model, clamp layer, rim model, direct — that the
  /// positions done at that distance needed, at the CPU rate measured so far). NaN until known.
  std::function<void(double seconds_left)> time_left;
  /// Called with time_left: the wall seconds per position of the solves any layout of the film
  /// needs — the sweep solves and the clamp-layer solves, at the CPU seconds per solve of each kind
  /// fitted so far (pvdf::ItemCostEta::cost_per_kind) times their count per position done — at the
  /// CPU rate of the rows done × the threads. This scene's rim-model and direct solves are left out:
  /// they belong to where its electrodes meet the clamp. `pvdfkit design` predicts the maps still to
  /// come with it (docs/design.md §6). NaN until known.
  std::function<void(double seconds_per_position)> common_seconds_per_position;
  /// Called from the thread that called generate_map: when the rows start, with a function (safe
  /// to call from any thread while the map runs) that returns time_left's estimate as of the call,
  /// the rows in flight counted at their time so far (pvdf::ItemCostEta::block_started); and with
  /// an empty function before generate_map returns or throws. A caller's heartbeat refreshes its
  /// ETA with it between rows. Do not call it while holding a lock the other callbacks take.
  std::function<void(std::function<double()> seconds_left_now)> time_left_now;
  /// 1-σ charge noise per channel written into the map (C); empty = 0.05 pC each.
  std::vector<double> noise_C;
  /// Free text stored in the map.
  std::string description;
  /// Start the FEM sweep mesh from this mesh (`pvdfkit map --mesh FILE.msh`; refined to the sweep's
  /// sizes, never coarsened) instead of the built-in one. Null = built-in mesh.
  std::shared_ptr<const pvdf::mesh::FilmMesh> mesh;
};

/// Per-point provenance flags, stored as uint8 [nf][ny][nx] in the map file's `/provenance`.
namespace provenance {
inline constexpr std::uint8_t solved = 0;    ///< solved by the FEM at this position and force
inline constexpr std::uint8_t scaled = 1;    ///< from the largest level by Q ∝ F^(2/3), w ∝ F^(1/3)
inline constexpr std::uint8_t mirrored = 2;  ///< copied from the mirror-image position (electrodes permuted)
/// The node's estimated charge error exceeds the tolerance even with the rim model and the direct solve (values usable,
/// /estimated_charge_error_C says by how much).
inline constexpr std::uint8_t tolerance_not_met = 4;
/// Not solved (adaptive placement): filled from the interpolant of the coarser level's nodes, whose
/// estimated error there met its share of the tolerance; its stored error is that interpolation
/// error plus the largest node estimate of the coarser cell's corners.
inline constexpr std::uint8_t interpolated = 8;
}  // namespace provenance

/// What a generation did.
struct MapReport {
  std::size_t n_positions = 0;    ///< grid positions inside the mask
  std::size_t n_points = 0;       ///< n_positions × force levels
  std::size_t n_solved = 0;       ///< points solved by the FEM (this process, or all ranks on rank 0)
  std::size_t n_scaled = 0;       ///< points obtained by force scaling
  std::size_t n_mirrored = 0;     ///< points copied from a mirror image
  std::size_t n_resumed = 0;      ///< points taken from the checkpoint
  std::size_t n_failed = 0;       ///< points with status not_converged
  std::size_t n_not_computed = 0; ///< mapped points left not_computed (stop hook)
  std::size_t n_scaling_checks = 0;        ///< check positions (all levels solved)
  std::size_t n_scaling_checks_failed = 0; ///< of which the scaled prediction missed the tolerance
  double max_scaling_check_error = 0;      ///< worst relative error of the scaled prediction
  bool mirror_x = false;          ///< symmetric under y → −y (mirror about the x axis) and used
  bool mirror_y = false;          ///< symmetric under x → −x (mirror about the y axis) and used
  std::string symmetry_reason;    ///< why (or why not) symmetry was used
  std::string model;              ///< kinematics used ("von-karman", ...)
  std::string model_reason;
  /// Largest per-node estimates of the map: max_k error_k / max_k |Q_k|, and |dw| / |w|.
  double estimated_relative_error = 1;
  double estimated_deflection_relative_error = 1;
  std::size_t n_dofs = 0;         ///< sweep mesh of the cheap model
  std::size_t rim_n_dofs = 0;     ///< rim-graded mesh of the rim model (0 = none)
  std::size_t n_rim_model = 0;    ///< map points solved by the rim model (mirror images included)
  /// Map points solved with the clamp's bending layer as a boundary condition (docs/fem.md §3.4;
  /// mirror images included): near-clamp nodes whose condition estimate met its share of the tolerance.
  std::size_t n_clamp_layer = 0;
  std::size_t clamp_layer_solves = 0;  ///< clamp-layer condition solves (this process), kept or not
  double clamp_layer_s = 0;            ///< thread-seconds spent in them (this process)
  bool clamp_layer_condition = false;  ///< near-clamp nodes tried the condition (off: PVDF_CLAMP_LAYER=rim-graded)
  std::size_t n_tolerance_not_met = 0;  ///< map points whose estimate exceeds the tolerance
  std::size_t n_direct = 0;       ///< map points solved by a direct adaptive solve (mirror images included)
  std::size_t direct_solves = 0;  ///< direct adaptive solves (this process), kept or not
  double direct_s = 0;            ///< thread-seconds spent in them (this process)
  std::size_t rim_solves = 0;     ///< rim-model solves (this process)
  double rim_s = 0;               ///< thread-seconds spent in rim-model solves (this process)
  double estimate_s = 0;          ///< thread-seconds spent in the error estimates (this process; all ranks under MPI)
  double probe_size_m = 0;        ///< cell size under each probe's footprint (0 = probes solved on the sweep mesh alone)
  double probe_mesh_s = 0;        ///< thread-seconds building the footprint-refined probe meshes and moving states (this process)
  double probe_mesh_dofs = 0;     ///< mean DOFs of the footprint-refined probe meshes of the cheap model (largest over threads)
  std::string placement = "uniform";  ///< "uniform" | "adaptive"
  /// Adaptive placement, per level from the coarsest: spacing (m), grid positions solved at that
  /// level (mirror images included) and FEM solves made (this process; all ranks on rank 0).
  std::vector<double> level_spacing_m;
  std::vector<std::size_t> level_positions;
  std::vector<std::size_t> level_solves;
  std::size_t n_interpolated = 0; ///< map points filled from a coarser level (adaptive placement)
  /// Largest stated total error of the map (max_k error_k / max_k |Q_k| over ok points; adaptive
  /// placement: node + between nodes + between force levels).
  double estimated_total_relative_error = 0;
  /// What the lookup will carry at a press (lookup_error_summary: the stored totals of an adaptive
  /// map, or a uniform map's node estimates with the lookup's own estimate between nodes and force
  /// levels), relative to the press's largest charge: median, 90th percentile and largest over the
  /// map; NaN when stopped early or no lookup can be built. The total a map states for its users,
  /// whatever the placement.
  LookupErrorSummary lookup_total_relative_error;
  double solve_cpu_s = 0;         ///< CPU-seconds of the FEM solves (all threads; all ranks under MPI)
  double placement_s = 0;         ///< wall seconds deciding the placement and filling (adaptive)
  int ranks = 1;                  ///< MPI ranks
  int threads = 1;                ///< threads per rank
  double setup_s = 0;             ///< ProbeSweep setup (max over threads of this process)
  double wall_s = 0;              ///< whole generation
  double per_position_s = 0;      ///< wall_s / solved positions (this process)
  bool stopped_early = false;     ///< the stop hook fired
  std::string checkpoint_hash;    ///< hash of scene + options that ties a checkpoint to this run
  std::string first_failure;      ///< first failed point and the solver's message ("" = none)
  /// [nf][ny][nx] provenance flags (see namespace provenance).
  std::vector<std::uint8_t> provenance;
  /// [nf][ny][nx] which model solved each point (pvdf::fem::SweepModel: 0 cheap, 1 rim; 2 direct adaptive solve;
  /// 3 the cheap model with the clamp-layer condition).
  std::vector<std::uint8_t> node_model;
};

/// Generates the charge map of `scene` (its loads are ignored; the probe radius is the scene's).
/// Bad input (spacing ≤ 0, forces ≤ 0, empty region, mismatching checkpoint) throws
/// pvdf::InputError; a point whose solve fails is status not_converged (NaN values), never a
/// guess. With `distributed`, collective over MPI_COMM_WORLD.
ChargeMap generate_map(const pvdf::Scene& scene, const MapOptions& options, MapReport* report = nullptr);

/// The positions generate_map would solve for a fresh run of `scene` with `options` (the grid
/// inside the film and its margin, one of each mirror pair; a checkpoint is not read): the
/// progress total of a study that runs several maps (`pvdfkit design`) before any of them starts.
/// Adaptive placement solves fewer, this many at most. Milliseconds; no solve. Throws
/// pvdf::InputError like generate_map.
std::size_t planned_positions(const pvdf::Scene& scene, const MapOptions& options);

/// Writes a generated map atomically (pvdf::mapping::write_map) with the extra dataset
/// `/provenance` (uint8 [nf][ny][nx], flags above; empty = not written).
/// `node_model` (same shape, empty = not written) becomes `/model`: 0 = the map's model attribute
/// as chosen by the sweep (bending per its model_reason), 1 = the same kinematics with bending on a
/// mesh graded toward the clamped rim.
void write_generated_map(const std::string& path, const ChargeMap& map, const std::vector<std::uint8_t>& provenance,
                         const std::vector<std::uint8_t>& node_model = {});

/// Deletes a checkpoint and its per-rank files (`<path>.rank<N>`), e.g. after the map was written.
void remove_checkpoint_files(const std::string& checkpoint_path);

/// Reads `/provenance` of a map file; empty when the file has none. Throws pvdf::InputError.
std::vector<std::uint8_t> read_provenance(const std::string& path);

/// Process-wide MPI for `distributed` generation: initializes MPI (also without mpirun:
/// singleton start) unless already initialized, finalizes at destruction if it initialized it.
class MpiSession {
 public:
  MpiSession();
  ~MpiSession();
  MpiSession(const MpiSession&) = delete;
  MpiSession& operator=(const MpiSession&) = delete;
  int rank() const { return rank_; }
  int size() const { return size_; }
  /// True when the process was started by an MPI launcher (mpirun/srun environment seen).
  static bool launched_by_mpirun();

 private:
  int rank_ = 0;
  int size_ = 1;
  bool owns_ = false;
};

}  // namespace pvdf::mapping
