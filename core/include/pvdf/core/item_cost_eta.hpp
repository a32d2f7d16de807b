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
///   are fitted by least squares to the CPU seconds of the items done where each item's own CPU
///   seconds are known (block_done's `item_cpu_s`), else of the blocks done (a small ridge pulls
///   them toward the mean cost per unit of work, so that one block already gives an answer; a
///   prior, set_prior, enters as one block of that many units of its kind done at its cost). Items
///   separate kinds that blocks cannot: the first rows of a map, next to the clamp, hold a
///   clamp-layer solve at every position and a rim-model solve at one, in the same proportion in
///   every row, and the block fit then shares the rim-model's cost with the clamp layer;
/// - work of an item still to do: its expected number of units (set_units; default 1: e.g. the
///   force levels a map position will solve) × the work of each kind per unit of the items done
///   whose feature lies in the same bin (bins of `bin_width` in the feature), else in the nearest
///   bin that has items done — so items that do three units each (a map's force-scaling checks) do
///   not make the one-unit items to come look three times as dear. A unit may need more than one
///   piece of work (a map position's sweep solve and a rim-model solve tried on top of it): all of
///   it is counted, since work left out would be charged to the kinds that are counted. Kind 0 is
///   the work every unit needs (one each: a map's sweep solve); the other kinds grow toward a small
///   feature (the clamp), so an item whose bin lies beyond every bin done (farther from the clamp
///   than any item done) is given kind 0 alone, not the extra work of the nearest bin done;
/// - wall time: the CPU seconds left over the throughput `threads` × e, with e the CPU seconds
///   per wall second of the blocks done (their CPU over their own wall durations), which holds the
///   load of the machine as it was (before any block: the prior's, set_prior);
/// - blocks in flight (block_started): their items are not counted with the items to do; each
///   holds its thread for its predicted wall time less the time it has run, and at least
///   `overrun_share` × the time it has run (a block that outruns its prediction is likely to be
///   dearer still: it is not counted as done); the time left is the larger of the longest of
///   them and (their remainders + the items to do) spread over the threads; with the blocks queued
///   (queue_blocks), each thread takes the next block queued when it is free, at its predicted
///   time, and the time left is when the last thread ends. Without block_started, the time left is
///   counted down from the last block's end.
/// NaN until a block is done or a prior is set. Not thread-safe (the caller serializes).
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
  /// work each needed ([item][kind], counts), the CPU seconds the block took (its throughput), and,
  /// when known, each item's own CPU seconds (the cost fit's rows; empty: the block is one row).
  void block_done(const std::vector<std::size_t>& items, const std::vector<std::vector<double>>& work,
                  double cpu_s, double start_s, double end_s, const std::vector<double>& item_cpu_s = {});
  /// Item `id` of a block in flight is done at wall time `end_s`, before its block: the work it
  /// needed ([kind], counts) and its own CPU seconds (a row of the cost fit). The time left then
  /// knows its cost at once (a map's first rows, next to the clamp, take a minute each: their
  /// positions say which kinds of work the clamp needs long before the row ends), and the block
  /// in flight holds its thread for its items not yet done, counted from `end_s`. block_done later
  /// counts the block's throughput and its other items only.
  void item_done(std::size_t id, const std::vector<double>& work, double item_cpu_s, double end_s);
  /// The blocks the items will be solved in, in the order the threads take them (each thread the
  /// next when it is free): the time left then follows that schedule (a dear block taken last runs
  /// alone). Items in no block queued are spread over the threads.
  void queue_blocks(const std::vector<std::vector<std::size_t>>& blocks);
  /// A block of planned items (ids from plan) starts at wall time `start_s` on one thread.
  void block_started(const std::vector<std::size_t>& items, double start_s);
  /// A prior for kind `kind`: `cpu_s_per_unit` as if one block of `weight_units` units of it had
  /// been done at that cost (e.g. the setup checks' CPU seconds per solve, the number of checks), and the CPU
  /// seconds per wall second of one thread until a block is done (`cpu_per_wall_s_per_thread`).
  void set_prior(std::size_t kind, double cpu_s_per_unit, double weight_units, double cpu_per_wall_s_per_thread);
  /// Seconds left at wall time `t_s` (NaN until a block is done or a prior is set).
  double seconds_left(double t_s) const;
  /// The share of its elapsed time a block in flight that has outrun its prediction is still
  /// expected to take.
  static constexpr double overrun_share = 0.5;
  /// The fitted CPU seconds per unit of each kind of work (empty until a block is done).
  std::vector<double> cost_per_kind() const { return cost_; }
  /// The CPU seconds per planned item of the work of `kinds` alone: Σ over those kinds of the
  /// fitted cost × the items' work of that kind (as done, or as predicted for the items to do),
  /// over all planned items (NaN until a block is done or a prior is set). E.g. a map's sweep and
  /// clamp-layer solves per position, which another layout of the same film needs too: over the
  /// planned positions, not over those done, which (rows near the clamp first) are not a sample.
  double cpu_s_per_item(const std::vector<std::size_t>& kinds) const;
  /// The CPU seconds per wall second of all threads: `threads` × the blocks' CPU over their own
  /// wall durations (before any block: the prior's; NaN without either).
  double cpu_per_wall_s() const;
  /// Planned items, and an item's feature and expected units (diagnostics, e.g. a trace to replay).
  std::size_t size() const { return feature_.size(); }
  double feature(std::size_t id) const { return id < feature_.size() ? feature_[id] : 0.0; }
  double units(std::size_t id) const { return id < units_.size() ? units_[id] : 0.0; }

 private:
  void fit();
  /// Marks item `id` done with its `work` (into its bin and `sum`); false if it was done already.
  bool mark_done(std::size_t id, const std::vector<double>& work, std::vector<double>& sum, std::vector<double>& own);
  std::size_t bin_of(double feature) const;
  /// Predicted work per kind of item `id` (as if not done), added × `scale` to `out`.
  void add_predicted_work(std::size_t id, double scale, std::vector<double>& out) const;
  double predicted_cpu_s(std::size_t id) const;  ///< Σ_c cost × add_predicted_work
  std::size_t n_kinds_;
  double bin_width_;
  std::vector<double> feature_;
  std::vector<double> units_;  ///< expected units of each item (set_units)
  std::vector<char> done_;
  // per feature bin: items done and their summed work per kind
  std::vector<std::size_t> bin_items_;
  std::vector<std::vector<double>> bin_work_;
  std::vector<double> bin_units_;  ///< summed units (set_units) of the items done in each bin
  // the least-squares rows: work per kind and CPU seconds of each item done with its own CPU
  // seconds, or of each block done without them
  std::vector<std::vector<double>> row_work_;
  std::vector<double> row_cpu_s_;
  std::size_t blocks_done_ = 0;
  std::vector<double> cost_;
  double cpu_done_s_ = 0, wall_done_s_ = 0;
  int threads_ = 1;
  double last_end_s_ = 0;
  struct InFlight {
    std::vector<std::size_t> items;
    double start_s = 0;
    double last_item_s = -1;  ///< when its latest item was done (item_done; < 0: none)
  };
  std::vector<InFlight> in_flight_;
  std::vector<std::vector<std::size_t>> queued_;  ///< queue_blocks', in order
  bool tracking_ = false;  ///< block_started was called: the blocks in flight are known
  std::vector<double> prior_cost_, prior_weight_;
  double prior_rate_ = 0;  ///< CPU-s per wall-s of one thread before any block (0: none)
};

}  // namespace pvdf
