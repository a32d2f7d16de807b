// generate_atlas (pvdf/mapping/atlas.hpp, docs/atlas.md §1): the map generator's probe grid (nodes
// at integer multiples of the spacing inside the film minus the rim margin), swept row by row with
// warm starts (along the row at each force level; a row's first position warm from the level below),
// one AtlasSweep per thread, rows handed out in order.
#include "pvdf/mapping/atlas.hpp"

#include "pvdf/core/constants.hpp"
#include "pvdf/core/error.hpp"
#include "pvdf/fem/solver.hpp"
#include "pvdf/version.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <exception>
#include <filesystem>
#include <limits>
#include <mutex>
#include <sstream>
#include <thread>

namespace pvdf::mapping {

namespace {

std::string num(double v) {
  std::ostringstream os;
  os.precision(6);
  os << v;
  return os.str();
}

// Mirror symmetry of the film (docs/atlas.md §3): a circle, rectangle or ellipse centred at the
// origin with the material's draw direction along x or y is its own mirror image about both axes,
// so the press at (−x, y) is the mirror image of the press at (x, y) (and likewise in y). Polygons
// are not examined (no symmetry used).
bool film_mirror_symmetric(const pvdf::Scene& scene) {
  if (scene.membrane.outline.shape == pvdf::FilmOutline::Shape::polygon) return false;
  const double quarter = std::remainder(scene.material.draw_angle_rad, 0.5 * pvdf::pi);
  return std::abs(quarter) <= 1e-12;
}

// Everything a resumed run must share with the run that wrote the checkpoint: every setting that
// changes a value (not the thread count: each row depends only on its warm start, §3).
std::string checkpoint_key(const std::string& scene_json, const AtlasOptions& o, const std::vector<double>& forces,
                           double tolerance, double margin) {
  nlohmann::json k;
  k["checkpoint"] = "pvdfkit-atlas-checkpoint 1";
  k["pvdfkit_version"] = pvdf::version_string;
  k["scene"] = scene_json;
  k["spacing_m"] = o.spacing_m;
  k["forces_N"] = forces;
  k["tolerance"] = tolerance;
  k["rim_margin_m"] = margin;
  k["cell_m"] = o.cell_m;
  k["fe_size_m"] = o.fe_size_m;
  k["keep_out_m"] = o.keep_out_m;
  k["n_setup_checks"] = o.n_setup_checks;
  return k.dump();
}

// Sizes the per-press arrays for the atlas's grid, forces, cells and reference electrodes: every
// press `outside`, every value NaN.
void allocate_presses(ChargeAtlas& a) {
  const std::size_t np = a.nf() * a.ny() * a.nx(), nc = a.n_cells(), nr = a.nr();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  a.status.assign(np, std::uint8_t(PointStatus::outside));
  a.moments.assign(np * nc * 3, nan);
  a.deflection_at_load_m.assign(np, nan);
  a.estimated_relative_error.assign(np, nan);
  a.reference_charge_C.assign(np * nr, nan);
  a.reference_charge_error_C.assign(np * nr, nan);
}

// The per-press data of the rows marked in `rows` (each completed: no thread writes them any more),
// every other served press not_computed: what a checkpoint holds.
ChargeAtlas completed_rows(const ChargeAtlas& a, const std::vector<std::uint8_t>& rows) {
  ChargeAtlas c;
  c.scene_json = a.scene_json;
  c.pvdfkit_version = a.pvdfkit_version;
  c.film_json = a.film_json;
  c.material_json = a.material_json;
  c.probe_json = a.probe_json;
  c.thickness_m = a.thickness_m;
  c.model = a.model;
  c.model_reason = a.model_reason;
  c.error_estimator = a.error_estimator;
  c.integration_error_rule = a.integration_error_rule;
  c.tolerance = a.tolerance;
  c.rim_margin_m = a.rim_margin_m;
  c.keep_out_m = a.keep_out_m;
  c.fe_size_m = a.fe_size_m;
  c.n_dofs = a.n_dofs;
  c.description = a.description + " (checkpoint: completed rows only)";
  c.checkpoint_key = a.checkpoint_key;
  c.spacing_m = a.spacing_m;
  c.x_m = a.x_m;
  c.y_m = a.y_m;
  c.mask = a.mask;
  c.forces_N = a.forces_N;
  c.grid = a.grid;
  c.geometry = a.geometry;
  c.reference_names = a.reference_names;
  const std::size_t nx = a.nx(), ny = a.ny(), nf = a.nf(), nr = a.nr(), nc = a.n_cells();
  allocate_presses(c);
  for (std::size_t f = 0; f < nf; ++f)
    for (std::size_t j = 0; j < ny; ++j)
      for (std::size_t i = 0; i < nx; ++i) {
        const std::size_t p = a.point(f, j, i);
        if (!a.mask[j * nx + i]) continue;
        if (!rows[j]) {
          c.status[p] = std::uint8_t(PointStatus::not_computed);
          continue;
        }
        c.status[p] = a.status[p];
        c.deflection_at_load_m[p] = a.deflection_at_load_m[p];
        c.estimated_relative_error[p] = a.estimated_relative_error[p];
        std::copy_n(a.moments.begin() + long(p * nc * 3), nc * 3, c.moments.begin() + long(p * nc * 3));
        std::copy_n(a.reference_charge_C.begin() + long(p * nr), nr, c.reference_charge_C.begin() + long(p * nr));
        std::copy_n(a.reference_charge_error_C.begin() + long(p * nr), nr, c.reference_charge_error_C.begin() + long(p * nr));
      }
  return c;
}

}  // namespace

// The provenance strings check_atlas_fits_scene compares: one home for what "the same film" means.
void fill_film_provenance(ChargeAtlas& atlas, const pvdf::Scene& scene) {
  nlohmann::json j = pvdf::scene_to_json(scene);
  nlohmann::json film = j["membrane"];
  film.erase("thickness_m");
  atlas.film_json = film.dump();
  atlas.material_json = j["material"].dump();
  atlas.probe_json = j["probe"].dump();
  atlas.thickness_m = scene.membrane.thickness_m;
}

ChargeAtlas generate_atlas(const pvdf::Scene& scene, const AtlasOptions& o, AtlasReport* report) {
  const auto t_start = std::chrono::steady_clock::now();
  ChargeAtlas atlas;
  if (!(o.spacing_m > 0) || !std::isfinite(o.spacing_m)) {
    throw pvdf::InputError("atlas: spacing " + num(o.spacing_m) + " m must be > 0 (e.g. 0.002)");
  }
  if (o.forces_N.empty()) throw pvdf::InputError("atlas: no force level; give at least one (e.g. 1 N)");
  std::vector<double> forces = o.forces_N;
  std::sort(forces.begin(), forces.end());
  for (double f : forces) {
    if (!(f > 0) || !std::isfinite(f)) throw pvdf::InputError("atlas: force level " + num(f) + " N must be > 0");
  }
  const double tolerance = o.tolerance > 0 ? o.tolerance : scene.model.tolerance;
  if (!(tolerance > 0 && tolerance < 1)) throw pvdf::InputError("atlas: tolerance " + num(tolerance) + " must be in (0, 1)");
  if (!(o.rim_margin_m >= 0)) throw pvdf::InputError("atlas: rim margin " + num(o.rim_margin_m) + " m must be >= 0");
  const double margin = o.rim_margin_m > 0 ? o.rim_margin_m : 2 * scene.probe.radius_m;

  // 1. The probe grid, as the map generator lays it out.
  const double s = o.spacing_m;
  const auto box = scene.membrane.outline.bounding_box_m();
  const long i0 = long(std::ceil(box[0] / s - 1e-9)), j0 = long(std::ceil(box[2] / s - 1e-9));
  const long i1 = long(std::floor(box[1] / s + 1e-9)), j1 = long(std::floor(box[3] / s + 1e-9));
  if (i1 - i0 < 1 || j1 - j0 < 1) throw pvdf::InputError("atlas: spacing " + num(s) + " m leaves fewer than 2 x 2 grid nodes; reduce it");
  for (long i = i0; i <= i1; ++i) atlas.x_m.push_back(double(i) * s);
  for (long j = j0; j <= j1; ++j) atlas.y_m.push_back(double(j) * s);
  const std::size_t nx = atlas.nx(), ny = atlas.ny(), nf = forces.size();
  if (double(nx) * double(ny) * double(nf) > 2e6) throw pvdf::InputError("atlas: spacing " + num(s) + " m gives too many presses; use a larger one");
  atlas.mask.assign(nx * ny, 0);
  std::size_t n_positions = 0;
  for (std::size_t j = 0; j < ny; ++j)
    for (std::size_t i = 0; i < nx; ++i)
      if (scene.membrane.outline.contains({atlas.x_m[i], atlas.y_m[j]}, margin)) {
        atlas.mask[j * nx + i] = 1;
        ++n_positions;
      }
  // Mirror images: solved only at x >= 0 (and y >= 0), the rest copied (step 4).
  const bool symmetric = film_mirror_symmetric(scene);
  const bool mirror_x = symmetric && i0 == -i1, mirror_y = symmetric && j0 == -j1;
  auto canonical = [&](std::size_t i, std::size_t j) {
    return (!mirror_x || atlas.x_m[i] >= 0) && (!mirror_y || atlas.y_m[j] >= 0);
  };
  atlas.forces_N = forces;
  atlas.spacing_m = s;
  atlas.rim_margin_m = margin;
  atlas.tolerance = tolerance;

  // 2. One sweep per thread; the first here, so that bad input fails before the threads start.
  pvdf::fem::AtlasSweepOptions so;
  so.solver = pvdf::fem::options_from_scene(scene);
  so.solver.tolerance = tolerance;
  so.forces_N = forces;
  so.rim_margin_m = margin;
  so.n_setup_checks = o.n_setup_checks;
  so.cell_m = o.cell_m;
  so.fe_size_m = o.fe_size_m;
  so.keep_out_m = o.keep_out_m;
  int threads = o.threads > 0 ? o.threads : int(std::max(1u, std::thread::hardware_concurrency()));
  threads = std::max(1, std::min<int>(threads, int(ny)));
  std::vector<std::unique_ptr<pvdf::fem::AtlasSweep>> sweeps;
  sweeps.push_back(std::make_unique<pvdf::fem::AtlasSweep>(scene, so));
  const pvdf::fem::AtlasSweep& first = *sweeps.front();
  const pvdf::fem::SweepSetup setup = first.setup();
  atlas.grid = first.grid();
  atlas.geometry = first.cell_geometry();
  atlas.fe_size_m = first.fe_size_m();
  atlas.keep_out_m = first.keep_out_m();
  atlas.n_dofs = setup.n_dofs;
  atlas.model = pvdf::fem::model_name(setup.model);
  atlas.model_reason = first.model_reason();
  atlas.error_estimator =
      "per press: the sweep's adjoint-weighted residual estimates (discretization + bending left out, by magnitude) of the "
      "charges of the reference electrodes Q1..Q4 (the quadrants of the film less its keep-out band along the clamp); "
      "estimated_relative_error = max_k err_k / max_k |Q_k|";
  atlas.integration_error_rule =
      "per electrode and press: sum over the atlas cells the electrode covers partly of |linear - constant reconstruction| "
      "of its share (fully covered cells are exact)";
  for (const auto& e : first.reference_electrodes()) atlas.reference_names.push_back(e.name);
  const std::size_t nr = atlas.nr(), nc = atlas.n_cells();
  atlas.scene_json = scene.original.is_null() ? pvdf::scene_to_json(scene).dump() : scene.original.dump();
  atlas.pvdfkit_version = pvdf::version_string;
  atlas.description = o.description.empty() ? "pvdfkit atlas" : o.description;
  fill_film_provenance(atlas, scene);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::size_t n_points = nf * ny * nx;
  allocate_presses(atlas);
  for (std::size_t f = 0; f < nf; ++f)
    for (std::size_t p = 0; p < nx * ny; ++p)
      if (atlas.mask[p]) atlas.status[f * nx * ny + p] = std::uint8_t(PointStatus::not_computed);
  for (int t = 1; t < threads; ++t) sweeps.push_back(std::make_unique<pvdf::fem::AtlasSweep>(scene, so));
  const double setup_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();

  // 3. Rows, each position all levels; results written to disjoint slots of the atlas.
  std::size_t n_canonical = 0;
  for (std::size_t j = 0; j < ny; ++j)
    for (std::size_t i = 0; i < nx; ++i) n_canonical += atlas.mask[j * nx + i] && canonical(i, j);
  std::vector<std::size_t> row_first(ny, nx);
  for (std::size_t j = 0; j < ny; ++j)
    for (std::size_t i = 0; i < nx && row_first[j] == nx; ++i)
      if (atlas.mask[j * nx + i] && canonical(i, j)) row_first[j] = i;
  // row_complete[j]: every canonical position of row j solved at every level (a row without one
  // counts as complete). Set under report_mutex once the row's last press is stored; a checkpoint
  // holds exactly these rows.
  std::vector<std::uint8_t> row_complete(ny, 0);
  for (std::size_t j = 0; j < ny; ++j) row_complete[j] = row_first[j] >= nx;
  atlas.checkpoint_key = checkpoint_key(atlas.scene_json, o, forces, tolerance, margin);
  std::size_t n_resumed = 0;
  std::string first_failure;
  if (!o.checkpoint_path.empty() && o.resume && std::filesystem::exists(o.checkpoint_path)) {
    ChargeAtlas saved;
    const std::string fix = "; delete it, pass --no-resume, or give another --checkpoint";
    try {
      saved = read_atlas(o.checkpoint_path);
    } catch (const pvdf::InputError& e) {
      throw pvdf::InputError("atlas checkpoint " + o.checkpoint_path + " cannot be read (" + e.what() + ")" + fix);
    }
    if (saved.checkpoint_key != atlas.checkpoint_key) {
      throw pvdf::InputError("atlas checkpoint " + o.checkpoint_path +
                             " was written for another scene, grid, force levels, tolerance or version" + fix);
    }
    if (saved.nx() != nx || saved.ny() != ny || saved.nf() != nf || saved.nr() != nr || saved.n_cells() != nc ||
        saved.n_dofs != atlas.n_dofs || saved.mask != atlas.mask) {
      throw pvdf::InputError("atlas checkpoint " + o.checkpoint_path + " has another probe grid, cell grid or mesh" + fix);
    }
    for (std::size_t j = 0; j < ny; ++j) {
      if (row_complete[j]) continue;
      bool complete = true;
      for (std::size_t f = 0; f < nf && complete; ++f)
        for (std::size_t i = 0; i < nx && complete; ++i) {
          if (!atlas.mask[j * nx + i] || !canonical(i, j)) continue;
          const std::size_t p = atlas.point(f, j, i);
          const auto st = saved.status[p];
          if (st == std::uint8_t(PointStatus::ok)) {
            for (std::size_t v = 0; v < nc * 3 && complete; ++v) complete = std::isfinite(saved.moments[p * nc * 3 + v]);
            if (!complete) {
              throw pvdf::InputError("atlas checkpoint " + o.checkpoint_path + ": a press marked ok holds a non-finite moment" + fix);
            }
          } else if (st != std::uint8_t(PointStatus::not_converged)) {
            complete = false;
          }
        }
      if (!complete) continue;
      row_complete[j] = 1;
      for (std::size_t f = 0; f < nf; ++f)
        for (std::size_t i = 0; i < nx; ++i) {
          if (!atlas.mask[j * nx + i] || !canonical(i, j)) continue;
          const std::size_t p = atlas.point(f, j, i);
          if (f == 0) ++n_resumed;
          atlas.status[p] = saved.status[p];
          atlas.deflection_at_load_m[p] = saved.deflection_at_load_m[p];
          atlas.estimated_relative_error[p] = saved.estimated_relative_error[p];
          std::copy_n(saved.moments.begin() + long(p * nc * 3), nc * 3, atlas.moments.begin() + long(p * nc * 3));
          std::copy_n(saved.reference_charge_C.begin() + long(p * nr), nr, atlas.reference_charge_C.begin() + long(p * nr));
          std::copy_n(saved.reference_charge_error_C.begin() + long(p * nr), nr,
                      atlas.reference_charge_error_C.begin() + long(p * nr));
          if (saved.status[p] == std::uint8_t(PointStatus::not_converged) && first_failure.empty())
            first_failure = "(" + num(atlas.x_m[i]) + ", " + num(atlas.y_m[j]) + ") m, " + num(forces[f]) +
                            " N: did not converge (in the resumed checkpoint)";
        }
    }
  }
  std::atomic<std::size_t> next_row{0}, done{n_resumed};
  std::atomic<bool> stopped{false};
  std::mutex report_mutex, checkpoint_mutex;
  std::exception_ptr error;
  auto last_checkpoint = std::chrono::steady_clock::now();
  auto stop_now = [&] {
    if (stopped) return true;
    if ((o.cancel && o.cancel->load()) || (o.stop_after_positions > 0 && done - n_resumed >= o.stop_after_positions)) stopped = true;
    return stopped.load();
  };
  // Writes the completed rows (atomically: write_atlas renames a finished temporary file).
  auto write_checkpoint = [&](bool force) {
    if (o.checkpoint_path.empty()) return;
    std::unique_lock<std::mutex> writing(checkpoint_mutex, std::try_to_lock);
    if (!writing.owns_lock() && !force) return;
    if (!writing.owns_lock()) writing.lock();
    std::vector<std::uint8_t> rows;
    {
      std::lock_guard<std::mutex> lock(report_mutex);
      const double since = std::chrono::duration<double>(std::chrono::steady_clock::now() - last_checkpoint).count();
      if (!force && since < o.checkpoint_interval_s) return;
      rows = row_complete;
    }
    write_atlas(o.checkpoint_path, completed_rows(atlas, rows));
    std::lock_guard<std::mutex> lock(report_mutex);
    last_checkpoint = std::chrono::steady_clock::now();
  };
  // One press, all levels, at (i, j), warm from along[f] (or the level below); stores the result
  // and leaves the converged states in along. `fresh`: the warm start first makes the sweep forget
  // its earlier solves (SweepState::fresh_history), so the press depends on nothing else. `count`:
  // a press of a row not taken from the checkpoint (progress and --stop-after-positions count it).
  auto press_at = [&](pvdf::fem::AtlasSweep& sweep, std::size_t i, std::size_t j, std::vector<pvdf::fem::SweepState>& along,
                      bool fresh, bool count) {
    for (std::size_t f = 0; f < nf; ++f) {
      pvdf::fem::SweepState* warm = !along[f].dofs.empty() ? &along[f] : (f > 0 && !along[f - 1].dofs.empty() ? &along[f - 1] : nullptr);
      if (warm && fresh) warm->fresh_history = true;
      pvdf::fem::SweepState next;
      const pvdf::fem::AtlasPress press = sweep.solve(atlas.x_m[i], atlas.y_m[j], forces[f], warm, &next);
      if (warm) warm->fresh_history = false;
      const std::size_t p = atlas.point(f, j, i);
      const auto& sol = press.solution;
      if (!pvdf::fem::usable(sol.status)) {
        atlas.status[p] = std::uint8_t(PointStatus::not_converged);
        std::lock_guard<std::mutex> lock(report_mutex);
        if (first_failure.empty())
          first_failure = "(" + num(atlas.x_m[i]) + ", " + num(atlas.y_m[j]) + ") m, " + num(forces[f]) + " N: " + sol.message;
        along[f] = {};
        continue;
      }
      atlas.status[p] = std::uint8_t(PointStatus::ok);
      std::copy(press.moments.begin(), press.moments.end(), atlas.moments.begin() + long(p * nc * 3));
      atlas.deflection_at_load_m[p] = sol.deflection_at_load_m;
      atlas.estimated_relative_error[p] = sol.estimated_relative_error;
      for (std::size_t k = 0; k < nr && k < sol.charge_C.size(); ++k) {
        atlas.reference_charge_C[p * nr + k] = sol.charge_C[k];
        atlas.reference_charge_error_C[p * nr + k] = k < sol.charge_error_C.size() ? sol.charge_error_C[k] : nan;
      }
      along[f] = std::move(next);
    }
    if (!count) return;
    const std::size_t d = ++done;
    if (o.progress) {
      std::lock_guard<std::mutex> lock(report_mutex);
      o.progress(d, n_canonical);
    }
  };
  if (o.progress && n_resumed > 0) o.progress(n_resumed, n_canonical);
  // 3a. The rows' first positions as one chain on the first sweep, before the threads: from the row
  // nearest y = 0 (solved from the flat film) outward both ways, each warm from its neighbour row's
  // (a cold solve on the atlas's fine mesh is a long continuation: on seed 001 a row start cost as
  // much as a whole row of warm presses). Each chain press and each row's next press forget the
  // sweep's history, so the atlas does not depend on the number of threads, nor on a resume: a
  // resumed run walks the chain as far as the farthest row still to do each way (the chain's
  // presses in completed rows give the values the checkpoint holds; they are not counted again).
  std::vector<std::vector<pvdf::fem::SweepState>> row_start(ny, std::vector<pvdf::fem::SweepState>(nf));
  {
    std::size_t centre = ny;
    for (std::size_t j = 0; j < ny; ++j)
      if (row_first[j] < nx && (centre == ny || std::abs(atlas.y_m[j]) < std::abs(atlas.y_m[centre]))) centre = j;
    if (centre < ny && std::find(row_complete.begin(), row_complete.end(), 0) != row_complete.end()) {
      std::vector<pvdf::fem::SweepState> along(nf);
      if (!stop_now()) {
        press_at(*sweeps.front(), row_first[centre], centre, along, true, !row_complete[centre]);
        row_start[centre] = along;
      }
      for (int dir : {+1, -1}) {
        long last = -1;  // the farthest row still to do this way
        for (long j = long(centre) + dir; j >= 0 && j < long(ny); j += dir)
          if (!row_complete[std::size_t(j)]) last = j;
        along = row_start[centre];
        for (long j = long(centre) + dir; last >= 0 && j >= 0 && j < long(ny) && j != last + dir && !stop_now(); j += dir) {
          if (row_first[std::size_t(j)] >= nx) continue;
          press_at(*sweeps.front(), row_first[std::size_t(j)], std::size_t(j), along, true, !row_complete[std::size_t(j)]);
          row_start[std::size_t(j)] = along;
        }
      }
    }
  }
  auto work = [&](pvdf::fem::AtlasSweep& sweep) {
    try {
      for (std::size_t j = next_row++; j < ny; j = next_row++) {
        if (row_complete[j]) continue;  // taken from the checkpoint (or no position): not written by anyone now
        if (stop_now()) break;
        std::vector<pvdf::fem::SweepState> along = std::move(row_start[j]);  // last state of the row at each level
        bool fresh = true, abandoned = false;
        for (std::size_t i = row_first[j] + 1; i < nx; ++i) {
          if (!atlas.mask[j * nx + i] || !canonical(i, j)) continue;
          if (stop_now()) {
            abandoned = true;  // a partial row is not checkpointed: a resume solves it again from its start
            break;
          }
          press_at(sweep, i, j, along, fresh, true);
          fresh = false;
        }
        if (abandoned) break;
        {
          std::lock_guard<std::mutex> lock(report_mutex);
          row_complete[j] = 1;
        }
        write_checkpoint(false);
      }
    } catch (...) {
      std::lock_guard<std::mutex> lock(report_mutex);
      if (!error) error = std::current_exception();
      next_row = ny;
    }
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t) pool.emplace_back(work, std::ref(*sweeps[std::size_t(t)]));
  work(*sweeps.front());
  for (auto& th : pool) th.join();
  if (error) std::rethrow_exception(error);
  if (stopped)
    write_checkpoint(true);  // the partial atlas is returned as it is (report.stopped_early)
  else
    atlas.checkpoint_key.clear();

  // 4. Mirror images (a completed run only): cell (ci, cj) of the image is cell (ncx−1−ci, cj) of the source under x → −x
  // (m1 changes sign), likewise in y; the reference quadrants are permuted (Q1 ↔ Q2, Q3 ↔ Q4 under
  // x → −x; Q1 ↔ Q4, Q2 ↔ Q3 under y → −y). The atlas grid is centred on the origin (atlas_grid_for).
  const std::size_t cx = atlas.grid.nx, cy = atlas.grid.ny;
  for (std::size_t f = 0; f < nf && !stopped; ++f)
    for (std::size_t j = 0; j < ny; ++j)
      for (std::size_t i = 0; i < nx; ++i) {
        if (!atlas.mask[j * nx + i] || canonical(i, j)) continue;
        const bool fx = mirror_x && atlas.x_m[i] < 0, fy = mirror_y && atlas.y_m[j] < 0;
        const std::size_t si = fx ? nx - 1 - i : i, sj = fy ? ny - 1 - j : j;
        const std::size_t p = atlas.point(f, j, i), sp = atlas.point(f, sj, si);
        atlas.status[p] = atlas.status[sp];
        atlas.deflection_at_load_m[p] = atlas.deflection_at_load_m[sp];
        atlas.estimated_relative_error[p] = atlas.estimated_relative_error[sp];
        for (std::size_t k = 0; k < nr; ++k) {
          std::size_t sk = k;
          if (nr == 4 && fx) sk = std::size_t(std::array<int, 4>{1, 0, 3, 2}[sk]);
          if (nr == 4 && fy) sk = std::size_t(std::array<int, 4>{3, 2, 1, 0}[sk]);
          atlas.reference_charge_C[p * nr + k] = atlas.reference_charge_C[sp * nr + sk];
          atlas.reference_charge_error_C[p * nr + k] = atlas.reference_charge_error_C[sp * nr + sk];
        }
        for (std::size_t cj = 0; cj < cy; ++cj)
          for (std::size_t ci = 0; ci < cx; ++ci) {
            const std::size_t sc = (fy ? cy - 1 - cj : cj) * cx + (fx ? cx - 1 - ci : ci), c = cj * cx + ci;
            const double* src = &atlas.moments[(sp * nc + sc) * 3];
            double* dst = &atlas.moments[(p * nc + c) * 3];
            dst[0] = src[0];
            dst[1] = fx ? -src[1] : src[1];
            dst[2] = fy ? -src[2] : src[2];
          }
      }

  if (report) {
    AtlasReport r;
    r.n_positions = n_positions;
    r.n_points = n_positions * nf;
    for (std::size_t p = 0; p < n_points; ++p) {
      if (atlas.status[p] == std::uint8_t(PointStatus::not_converged)) ++r.n_failed;
      if (atlas.status[p] == std::uint8_t(PointStatus::ok)) {
        const double e = atlas.estimated_relative_error[p];
        if (std::isfinite(e)) r.estimated_relative_error = std::max(r.estimated_relative_error, e);
        if (!(e <= tolerance)) ++r.n_tolerance_not_met;
      }
    }
    r.first_failure = first_failure;
    r.n_solved_positions = stopped ? done.load() : n_canonical;
    r.n_resumed_positions = n_resumed;
    r.stopped_early = stopped;
    for (const auto& s : sweeps) r.n_rim_solves += std::size_t(s->timing().rim_solves);
    r.mirror_x = mirror_x;
    r.mirror_y = mirror_y;
    r.setup_s = setup_s;
    r.threads = threads;
    r.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
    *report = r;
  }
  return atlas;
}

}  // namespace pvdf::mapping
