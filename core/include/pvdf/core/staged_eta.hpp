// The time left of work done in stages one after another (the maps of a `design` run): each stage
// a setup followed by items solved at the stage's own rate.
#pragma once

#include <cstddef>
#include <vector>

namespace pvdf {

/// Predicts the seconds left of staged work from what was measured so far, stage by stage.
///
/// Per stage k it keeps when the stage started, its first and latest item counts and times. Its
/// item rate r_k is measured between its first and latest report (so the setup before the first
/// report does not count); its setup s_k = (first report − start) − items of the first report / r_k.
/// The time left is
///   current stage: its setup still to run (while no item is reported, the mean measured setup
///                  minus the time since its start) + items left / rate;
///   stages to come: mean measured setup + planned items × seconds per item,
/// with the seconds per item those the stages seen stated for an item of any stage
/// (stage_item_seconds: a map's cost per position of the solves every layout needs, leaving out
/// what made that map's own positions dear), their mean weighted by their items done, else
/// 1 / the pooled rate of the stages seen (their items over the time between their first and last
/// reports); the current stage's items at its own rate once measured, else as a stage to come; a
/// stage that states its own time left (stage_seconds_left) is taken at its word while it is
/// current, except before its first items when a stage before it stated seconds per item (its own
/// estimate then is a prior from its setup, the earlier stages' a measurement under the load as it
/// is). NaN until one rate or seconds per item is known.
/// Times are seconds on any monotone clock the caller chooses.
class StagedEta {
 public:
  /// `planned_items`: the items each stage is expected to have, in the order the stages run.
  explicit StagedEta(std::vector<std::size_t> planned_items);
  /// Stage `index` starts its setup at `t_s`.
  void start_stage(std::size_t index, double t_s);
  /// Stage `index` has `done` of `total` items at `t_s` (`total` replaces the planned count). A
  /// report of 0 items before any other only sets the total: the stage is measured from its first
  /// items.
  void items_done(std::size_t index, std::size_t done, std::size_t total, double t_s);
  /// The stage's own estimate of its seconds left at `t_s` (e.g. a map's, which knows which of its
  /// positions are dear): used for the current stage in place of items left / rate, counted down
  /// from `t_s`. NaN clears it.
  void stage_seconds_left(std::size_t index, double seconds, double t_s);
  /// The wall seconds an item of any stage is expected to take, as stage `index` measured it so
  /// far (e.g. a map's cost per position of the solves every layout needs): used for the stages to
  /// come and for a current stage without a rate or estimate of its own. NaN clears it.
  void stage_item_seconds(std::size_t index, double seconds_per_item);
  /// Seconds left at `t_s`; NaN before any stage has a measured rate or seconds per item.
  double seconds_left(double t_s) const;

 private:
  struct Stage {
    std::size_t planned = 0;
    bool started = false;
    double start_s = 0;
    bool reported = false;
    std::size_t first_done = 0, last_done = 0;
    double first_s = 0, last_s = 0;
    double own_left_s = -1, own_at_s = 0;  ///< stage_seconds_left's (< 0: none)
    double item_s = -1;                    ///< stage_item_seconds' (< 0: none)
    double rate() const;   ///< items per second between first and latest report; 0 if not measured
    double setup_s() const;  ///< measured setup, < 0 if not measured
  };
  std::vector<Stage> stages_;
  std::size_t current_ = 0;
};

}  // namespace pvdf
