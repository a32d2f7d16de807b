// The time left of many items solved in blocks on a few threads, when the items differ in cost
// by which kind of work each needs (a map's positions: the cheap model, or the clamp layer, the
// rim model or a direct solve near the clamp) and that kind is known only once the item is done,
// but is predicted by a number known beforehand (the position's distance to the clamp).
#pragma once

#include <cstddef>
#include <vector>

namespace pvdf {

/// Predicts the seconds left of planned items from the blocks done so far.
///
/// The model (docs/design.md §6):
/// - cost: an item that needed n_c units of work kind c costs Σ_c n_c k_c CPU-seconds; the k_c ≥ 0
///   are fitted by least squares to the CPU seconds of the blocks done (a small ridge pulls them
///   toward the mean cost per unit of work, so that one block already gives an answer);
/// - work of an item still to do: its expected number of units (set_units; default 1: e.g. the
///   force levels a map position will solve) × the work of each kind per unit of the items done
///   whose feature lies in the same bin (bins of `bin_width` in the feature), else in the nearest
///   bin that has items done — so items that do three units each (a map's force-scaling checks) do
///   not make the one-unit items to come look three times as dear. A unit may need more than one
///   piece of work (a map position's sweep solve and a rim-model solve tried on top of it): all of
///   it is counted, since work left out would be charged to the kinds that are counted;
/// - wall time: the CPU seconds left over the throughput `threads` × e, with e the CPU seconds
///   per wall second of the blocks done (their CPU over their own wall durations), which holds the
///   load of the machine as it was.
/// NaN until a block is done. Not thread-safe (the caller serializes).
class ItemCostEta {
 public:
  /// `n_kinds`: kinds of work an item may need; `bin_width`: of the feature (> 0); `threads`:
  /// blocks solved at once.
  ItemCostEta(std::size_t n_kinds, double bin_width, int threads);
  /// The items to do (their features); returns the id of the first (ids are consecutive). Items
  /// may be planned while others are being solved (a later phase of the same work).
  std::size_t plan(const std::vector<double>& features);
  /// The expected units of work (> 0; e.g. solves) of planned item `id` not yet done (default 1).
  void set_units(std::size_t id, double units);
  /// A block started at wall time `start_s` is done at `end_s`: its items (ids from plan), the
  /// work each needed ([item][kind], counts), and the CPU seconds it took.
  void block_done(const std::vector<std::size_t>& items, const std::vector<std::vector<double>>& work,
                  double cpu_s, double start_s, double end_s);
  /// Seconds left at wall time `t_s` (NaN until a block is done).
  double seconds_left(double t_s) const;
  /// The fitted CPU seconds per unit of each kind of work (empty until a block is done).
  std::vector<double> cost_per_kind() const { return cost_; }
  /// The CPU seconds per item done of the work of `kinds` alone: Σ over those kinds of the fitted
  /// cost × the items' work of that kind, over the items done (NaN until a block is done). E.g. a
  /// map's sweep and clamp-layer solves per position, which another layout of the film needs too.
  double cpu_s_per_item(const std::vector<std::size_t>& kinds) const;
  /// The CPU seconds per wall second of all threads: `threads` × the blocks' CPU over their own
  /// wall durations (NaN until a block is done).
  double cpu_per_wall_s() const;

 private:
  void fit();
  std::size_t bin_of(double feature) const;
  std::size_t n_kinds_;
  double bin_width_;
  std::vector<double> feature_;
  std::vector<double> units_;  ///< expected units of each item (set_units)
  std::vector<char> done_;
  // per feature bin: items done and their summed work per kind
  std::vector<std::size_t> bin_items_;
  std::vector<std::vector<double>> bin_work_;
  std::vector<double> bin_units_;  ///< summed units (set_units) of the items done in each bin
  // per block done: work per kind and CPU seconds (the least-squares rows)
  std::vector<std::vector<double>> block_work_;
  std::vector<double> block_cpu_s_;
  std::vector<double> cost_;
  double cpu_done_s_ = 0, wall_done_s_ = 0;
  int threads_ = 1;
  double last_end_s_ = 0;
};

}  // namespace pvdf
