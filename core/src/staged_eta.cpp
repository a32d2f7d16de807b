// StagedEta: the ETA of stages each made of a setup and items (see the header for the model).
#include "pvdf/core/staged_eta.hpp"

#include <algorithm>
#include <cmath>

namespace pvdf {

double StagedEta::Stage::rate() const {
  const double dt = last_s - first_s;
  return reported && last_done > first_done && dt > 0 ? double(last_done - first_done) / dt : 0.0;
}

double StagedEta::Stage::setup_s() const {
  const double r = rate();
  if (!started || r <= 0) return -1;
  return std::max(0.0, first_s - start_s - double(first_done) / r);
}

StagedEta::StagedEta(std::vector<std::size_t> planned_items) {
  stages_.resize(planned_items.size());
  for (std::size_t k = 0; k < planned_items.size(); ++k) stages_[k].planned = planned_items[k];
}

void StagedEta::start_stage(std::size_t index, double t_s) {
  if (index >= stages_.size()) return;
  Stage& s = stages_[index];
  s.started = true;
  s.start_s = t_s;
  current_ = index;
}

void StagedEta::items_done(std::size_t index, std::size_t done, std::size_t total, double t_s) {
  if (index >= stages_.size()) return;
  Stage& s = stages_[index];
  if (!s.started) start_stage(index, t_s);
  s.planned = total;
  current_ = index;
  // A report of no items (a map's total, shown as soon as its setup ends) measures nothing: the
  // stage counts as reported from its first items on (its rate and setup are measured from those).
  if (!s.reported && done == 0) return;
  if (!s.reported) {
    s.reported = true;
    s.first_done = done;
    s.first_s = t_s;
  }
  s.last_done = done;
  s.last_s = t_s;
  current_ = index;
}

void StagedEta::stage_seconds_left(std::size_t index, double seconds, double t_s) {
  if (index >= stages_.size()) return;
  Stage& s = stages_[index];
  s.own_left_s = std::isfinite(seconds) && seconds >= 0 ? seconds : -1;
  s.own_at_s = t_s;
}

void StagedEta::stage_item_seconds(std::size_t index, double seconds_per_item) {
  if (index >= stages_.size()) return;
  stages_[index].item_s = std::isfinite(seconds_per_item) && seconds_per_item > 0 ? seconds_per_item : -1;
}

double StagedEta::seconds_left(double t_s) const {
  // Pooled rate and mean setup of the stages whose rate is measured.
  double items = 0, seconds = 0, setup_sum = 0;
  int n_setups = 0;
  for (const Stage& s : stages_) {
    if (s.rate() <= 0) continue;
    items += double(s.last_done - s.first_done);
    seconds += s.last_s - s.first_s;
    const double setup = s.setup_s();
    if (setup >= 0) {
      setup_sum += setup;
      ++n_setups;
    }
  }
  const double pooled = items > 0 && seconds > 0 ? items / seconds : 0.0;
  const double mean_setup = n_setups > 0 ? setup_sum / n_setups : 0.0;
  // Seconds per item of a stage not yet measured: the stages' stated ones, weighted by their items
  // done (at least one each), else the pooled rate's.
  double stated = 0, weight = 0;
  for (const Stage& s : stages_) {
    if (s.item_s < 0) continue;
    const double w = double(std::max<std::size_t>(1, s.last_done));
    stated += w * s.item_s;
    weight += w;
  }
  const double item_s = weight > 0 ? stated / weight : pooled > 0 ? 1.0 / pooled : NAN;

  double left = 0;
  if (current_ < stages_.size()) {
    const Stage& c = stages_[current_];
    // A stage's own estimate before its first items (a prior from its setup) yields to the seconds
    // per item the stages before it measured (at the machine's load as it was, not the setup's).
    bool measured_before = false;
    for (std::size_t k = 0; k < current_; ++k) measured_before = measured_before || stages_[k].item_s >= 0;
    if (c.own_left_s >= 0 && (c.reported || !measured_before)) {
      left += std::max(0.0, c.own_left_s - (t_s - c.own_at_s));
    } else if (c.rate() > 0) {
      const double rest = double(c.planned > c.last_done ? c.planned - c.last_done : 0) / c.rate();
      left += rest - std::min(t_s - c.last_s, rest);
    } else if (!c.reported) {
      const double into = c.started ? t_s - c.start_s : 0.0;
      left += std::max(0.0, mean_setup - into) + double(c.planned) * item_s;
    } else {
      const double rest = double(c.planned > c.last_done ? c.planned - c.last_done : 0) * item_s;
      left += rest - std::min(t_s - c.last_s, rest);
    }
  }
  for (std::size_t k = current_ + 1; k < stages_.size(); ++k) left += mean_setup + double(stages_[k].planned) * item_s;
  return std::isfinite(left) ? std::max(0.0, left) : NAN;
}

}  // namespace pvdf
