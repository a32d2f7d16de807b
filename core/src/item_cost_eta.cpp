// ItemCostEta: the time left of items whose kind of work is predicted from a feature (see the
// header for the model).
#include "pvdf/core/item_cost_eta.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace pvdf {

namespace {

/// The bin nearest `bin` among [0, nb) for which `has(bin)` holds (ties: the larger bin, i.e. farther
/// from the clamp); nb when none does.
template <class Has>
std::size_t nearest_bin(std::size_t bin, std::size_t nb, Has has) {
  for (std::size_t d = 0; d < nb; ++d) {
    if (bin + d < nb && has(bin + d)) return bin + d;
    if (d <= bin && bin - d < nb && has(bin - d)) return bin - d;
  }
  return nb;
}

}  // namespace

ItemCostEta::ItemCostEta(std::size_t n_kinds, double bin_width, int threads)
    : n_kinds_(std::max<std::size_t>(1, n_kinds)),
      bin_width_(bin_width > 0 ? bin_width : 1.0),
      threads_(std::max(1, threads)),
      prior_cost_(n_kinds_, 0.0),
      prior_weight_(n_kinds_, 0.0) {}

void ItemCostEta::set_prior(std::size_t kind, double cpu_s_per_unit, double weight_units, double cpu_per_wall_s_per_thread) {
  if (kind < n_kinds_ && std::isfinite(cpu_s_per_unit) && cpu_s_per_unit > 0 && std::isfinite(weight_units) && weight_units > 0) {
    prior_cost_[kind] = cpu_s_per_unit;
    prior_weight_[kind] = weight_units;
  }
  if (std::isfinite(cpu_per_wall_s_per_thread) && cpu_per_wall_s_per_thread > 0) prior_rate_ = cpu_per_wall_s_per_thread;
}

void ItemCostEta::queue_blocks(const std::vector<std::vector<std::size_t>>& blocks) {
  for (const auto& b : blocks) {
    std::vector<std::size_t> ids;
    for (std::size_t id : b)
      if (id < feature_.size()) ids.push_back(id);
    if (!ids.empty()) queued_.push_back(std::move(ids));
  }
}

void ItemCostEta::block_started(const std::vector<std::size_t>& items, double start_s) {
  tracking_ = true;
  InFlight b;
  for (std::size_t id : items)
    if (id < feature_.size() && !done_[id]) b.items.push_back(id);
  b.start_s = start_s;
  if (!b.items.empty()) in_flight_.push_back(std::move(b));
}

std::size_t ItemCostEta::plan(const std::vector<double>& features) {
  const std::size_t first = feature_.size();
  for (double f : features) {
    feature_.push_back(std::isfinite(f) ? std::max(0.0, f) : 0.0);
    units_.push_back(1.0);
    done_.push_back(0);
  }
  return first;
}

void ItemCostEta::set_units(std::size_t id, double units) {
  if (id < units_.size() && std::isfinite(units) && units > 0) units_[id] = units;
}

std::size_t ItemCostEta::bin_of(double feature) const {
  // Features beyond 10⁶ bins share the last one (no unbounded allocation from a wild feature).
  return std::size_t(std::min(1e6, std::floor(feature / bin_width_)));
}

bool ItemCostEta::mark_done(std::size_t id, const std::vector<double>& work, std::vector<double>& sum, std::vector<double>& own) {
  own.assign(n_kinds_, 0.0);
  if (id >= feature_.size() || done_[id]) return false;
  done_[id] = 1;
  const std::size_t b = bin_of(feature_[id]);
  if (b >= bin_items_.size()) {
    bin_items_.resize(b + 1, 0);
    bin_work_.resize(b + 1, std::vector<double>(n_kinds_, 0.0));
    bin_units_.resize(b + 1, 0.0);
  }
  ++bin_items_[b];
  bin_units_[b] += units_[id];
  for (std::size_t c = 0; c < n_kinds_ && c < work.size(); ++c) {
    const double w = std::isfinite(work[c]) ? std::max(0.0, work[c]) : 0.0;
    bin_work_[b][c] += w;
    sum[c] += w;
    own[c] = w;
  }
  return true;
}

void ItemCostEta::item_done(std::size_t id, const std::vector<double>& work, double item_cpu_s, double end_s) {
  std::vector<double> sum(n_kinds_, 0.0), own;
  if (!mark_done(id, work, sum, own)) return;
  row_work_.push_back(own);
  row_cpu_s_.push_back(std::isfinite(item_cpu_s) ? std::max(0.0, item_cpu_s) : 0.0);
  for (auto& b : in_flight_)
    if (std::find(b.items.begin(), b.items.end(), id) != b.items.end()) b.last_item_s = std::max(b.last_item_s, end_s);
  fit();
}

void ItemCostEta::block_done(const std::vector<std::size_t>& items, const std::vector<std::vector<double>>& work,
                             double cpu_s, double start_s, double end_s, const std::vector<double>& item_cpu_s) {
  // The block is no longer in flight (matched by any of its items).
  for (std::size_t f = 0; f < in_flight_.size();) {
    const auto& fi = in_flight_[f].items;
    const bool mine = std::any_of(items.begin(), items.end(), [&](std::size_t id) { return std::find(fi.begin(), fi.end(), id) != fi.end(); });
    if (mine) in_flight_.erase(in_flight_.begin() + std::ptrdiff_t(f));
    else ++f;
  }
  // Its items not already done one by one (item_done).
  std::vector<double> sum(n_kinds_, 0.0), own;
  const bool by_item = !items.empty() && item_cpu_s.size() == items.size();
  for (std::size_t n = 0; n < items.size() && n < work.size(); ++n) {
    if (!mark_done(items[n], work[n], sum, own)) continue;
    if (by_item) {
      row_work_.push_back(own);
      row_cpu_s_.push_back(std::isfinite(item_cpu_s[n]) ? std::max(0.0, item_cpu_s[n]) : 0.0);
    }
  }
  if (!(cpu_s >= 0) || !std::isfinite(cpu_s)) cpu_s = 0;
  if (!by_item) {
    row_work_.push_back(sum);
    row_cpu_s_.push_back(cpu_s);
  }
  ++blocks_done_;
  cpu_done_s_ += cpu_s;
  if (std::isfinite(end_s - start_s) && end_s > start_s) wall_done_s_ += end_s - start_s;
  last_end_s_ = end_s;
  fit();
}

// Ridge least squares of the blocks' CPU seconds on their work, k ≥ 0 by dropping the negative
// ones and solving again (at most n_kinds rounds; n_kinds is a handful).
void ItemCostEta::fit() {
  const std::size_t n = n_kinds_;
  double units = 0, cpu = 0;
  for (std::size_t b = 0; b < row_work_.size(); ++b) {
    for (double x : row_work_[b]) units += x;
    cpu += row_cpu_s_[b];
  }
  const double mean = units > 0 ? cpu / units : 0.0;
  std::vector<char> free(n, 1);
  std::vector<double> k(n, mean);
  for (std::size_t round = 0; round <= n; ++round) {
    // Normal equations (AᵀA + Λ) k = Aᵀb + Λ·mean over the free kinds; Λ_c = 10⁻³ Σ_b A_bc² (+1e-12).
    std::vector<double> M(n * n, 0.0), r(n, 0.0);
    for (std::size_t b = 0; b < row_work_.size(); ++b) {
      const auto& a = row_work_[b];
      for (std::size_t i = 0; i < n; ++i) {
        r[i] += a[i] * row_cpu_s_[b];
        for (std::size_t j = 0; j < n; ++j) M[i * n + j] += a[i] * a[j];
      }
    }
    for (std::size_t i = 0; i < n; ++i) {  // the priors: one block of that many units done at their cost
      const double w2 = prior_weight_[i] * prior_weight_[i];
      M[i * n + i] += w2;
      r[i] += w2 * prior_cost_[i];
    }
    for (std::size_t i = 0; i < n; ++i) {
      const double lambda = 1e-3 * M[i * n + i] + 1e-12;
      M[i * n + i] += lambda;
      r[i] += lambda * mean;
    }
    for (std::size_t i = 0; i < n; ++i) {
      if (free[i]) continue;
      for (std::size_t j = 0; j < n; ++j) M[i * n + j] = M[j * n + i] = 0;
      M[i * n + i] = 1;
      r[i] = 0;
    }
    // Gaussian elimination with partial pivoting (n ≤ a handful; M is positive definite).
    std::vector<double> x = r;
    std::vector<std::size_t> perm(n);
    for (std::size_t i = 0; i < n; ++i) perm[i] = i;
    bool singular = false;
    for (std::size_t c = 0; c < n; ++c) {
      std::size_t p = c;
      for (std::size_t i = c + 1; i < n; ++i)
        if (std::abs(M[i * n + c]) > std::abs(M[p * n + c])) p = i;
      if (!(std::abs(M[p * n + c]) > 0)) {
        singular = true;
        break;
      }
      if (p != c) {
        for (std::size_t j = 0; j < n; ++j) std::swap(M[c * n + j], M[p * n + j]);
        std::swap(x[c], x[p]);
      }
      for (std::size_t i = c + 1; i < n; ++i) {
        const double f = M[i * n + c] / M[c * n + c];
        for (std::size_t j = c; j < n; ++j) M[i * n + j] -= f * M[c * n + j];
        x[i] -= f * x[c];
      }
    }
    if (singular) break;
    for (std::size_t c = n; c-- > 0;) {
      double s = x[c];
      for (std::size_t j = c + 1; j < n; ++j) s -= M[c * n + j] * x[j];
      x[c] = s / M[c * n + c];
    }
    k = x;
    bool negative = false;
    for (std::size_t i = 0; i < n; ++i)
      if (free[i] && k[i] < 0) {
        free[i] = 0;
        negative = true;
      }
    if (!negative) break;
  }
  for (double& v : k) v = std::isfinite(v) ? std::max(0.0, v) : mean;
  cost_ = k;
}

void ItemCostEta::add_predicted_work(std::size_t id, double scale, std::vector<double>& out) const {
  const double units = units_[id];
  // No item done, or the item farther from the clamp than every bin done: the work every unit needs.
  const std::size_t nb = bin_items_.size(), b = bin_of(feature_[id]);
  if (nb == 0 || b >= nb) {
    out[0] += units * scale;
    return;
  }
  // The nearest bin with items done (ties: the larger feature, i.e. farther from the clamp).
  const std::size_t best = nearest_bin(b, nb, [this](std::size_t k) { return bin_items_[k] > 0; });
  if (best == nb) return;
  // The bin's work per unit of its items done (their units as set when done), times this item's units.
  const double per = bin_units_[best] > 0 ? units / bin_units_[best] : 1.0 / double(bin_items_[best]);
  for (std::size_t c = 0; c < n_kinds_; ++c) out[c] += bin_work_[best][c] * per * scale;
}

double ItemCostEta::predicted_cpu_s(std::size_t id) const {
  const std::vector<double>& k = cost_.empty() ? prior_cost_ : cost_;
  std::vector<double> w(n_kinds_, 0.0);
  add_predicted_work(id, 1.0, w);
  double cpu = 0;
  for (std::size_t c = 0; c < n_kinds_; ++c) cpu += k[c] * w[c];
  return cpu;
}

double ItemCostEta::seconds_left(double t_s) const {
  const bool fitted = blocks_done_ > 0 && !cost_.empty() && wall_done_s_ > 0;
  if (!fitted && !(prior_rate_ > 0 && prior_weight_[0] > 0)) return std::numeric_limits<double>::quiet_NaN();
  const double per_thread = fitted ? cpu_done_s_ / wall_done_s_ : prior_rate_;  // CPU-s per wall-s of one thread
  if (!(per_thread > 0)) return std::numeric_limits<double>::quiet_NaN();
  std::vector<char> flying(feature_.size(), 0);
  for (const auto& b : in_flight_)
    for (std::size_t id : b.items) flying[id] = 1;
  // Before any block is done, the blocks in flight say what the prior cannot: a block that has run
  // r seconds costs at least r × the per-thread rate, so an item to do in the feature bin of one of
  // its items costs per unit at least that over the block's units (the largest such bound of its
  // bin, else of the nearest bin in flight; an item farther from the clamp than every item in
  // flight keeps the prior, as add_predicted_work gives it kind 0 alone).
  // (An item of the block already done, item_done, is measured: the bound then counts the run since
  // the block's latest item over its items not yet done.)
  std::vector<double> floor_per_unit;
  if (blocks_done_ == 0) {
    for (const auto& b : in_flight_) {
      double units = 0;
      for (std::size_t id : b.items)
        if (!done_[id]) units += units_[id];
      if (!(units > 0)) continue;
      const double per_unit = std::max(0.0, t_s - std::max(b.start_s, b.last_item_s)) * per_thread / units;
      for (std::size_t id : b.items) {
        if (done_[id]) continue;
        const std::size_t bin = bin_of(feature_[id]);
        if (bin >= floor_per_unit.size()) floor_per_unit.resize(bin + 1, -1.0);
        floor_per_unit[bin] = std::max(floor_per_unit[bin], per_unit);
      }
    }
  }
  const auto cost_s = [&](std::size_t id) {
    const double cpu = predicted_cpu_s(id);
    const std::size_t nb = floor_per_unit.size(), bin = bin_of(feature_[id]);
    if (nb == 0 || bin >= nb) return cpu;
    const std::size_t k = nearest_bin(bin, nb, [&](std::size_t j) { return floor_per_unit[j] >= 0; });
    return k < nb ? std::max(cpu, floor_per_unit[k] * units_[id]) : cpu;
  };
  double cpu_left = 0;
  for (std::size_t id = 0; id < feature_.size(); ++id)
    if (!done_[id] && !flying[id]) cpu_left += cost_s(id);
  if (!tracking_) {
    // Counted down from the last block's end: the blocks in flight have run since then.
    const double left = cpu_left / (per_thread * double(threads_)) - (fitted ? std::max(0.0, t_s - last_end_s_) : 0.0);
    return std::max(0.0, left);
  }
  // Each block in flight holds its thread for its predicted time less its run so far, and at least
  // overrun_share × its run so far: of its items not yet done, run since its latest item done.
  std::vector<double> free_s;  // when each thread is free, from now
  for (const auto& b : in_flight_) {
    double cpu = 0;
    for (std::size_t id : b.items)
      if (!done_[id]) cpu += cost_s(id);
    const double run_s = std::max(0.0, t_s - std::max(b.start_s, b.last_item_s));
    free_s.push_back(std::max(cpu / per_thread - run_s, overrun_share * run_s));
  }
  free_s.resize(std::max<std::size_t>(free_s.size(), std::size_t(threads_)), 0.0);
  // The blocks queued, in order, each to the thread free first (not yet started: no item done or
  // in flight); their items are taken off the loose ones.
  std::vector<char> queued(feature_.size(), 0);
  for (const auto& b : queued_) {
    bool waiting = true;
    for (std::size_t id : b) waiting = waiting && !done_[id] && !flying[id];
    if (!waiting) continue;
    double cpu = 0;
    for (std::size_t id : b) {
      cpu += cost_s(id);
      queued[id] = 1;
    }
    *std::min_element(free_s.begin(), free_s.end()) += cpu / per_thread;
  }
  double loose_cpu = 0;
  for (std::size_t id = 0; id < feature_.size(); ++id)
    if (!done_[id] && !flying[id] && !queued[id]) loose_cpu += cost_s(id);
  double sum_s = loose_cpu / per_thread, last_s = 0;
  for (double f : free_s) {
    sum_s += f;
    last_s = std::max(last_s, f);
  }
  return std::max(last_s, sum_s / double(free_s.size()));
}

double ItemCostEta::cpu_s_per_item(const std::vector<std::size_t>& kinds) const {
  if (feature_.empty()) return std::numeric_limits<double>::quiet_NaN();
  const bool fitted = cost_.size() == n_kinds_;  // a block or an item done (fit)
  if (!fitted && !(prior_weight_[0] > 0)) return std::numeric_limits<double>::quiet_NaN();
  const std::vector<double>& k = fitted ? cost_ : prior_cost_;
  // The work of the items done (the bins' sums) and the predicted work of the others.
  std::vector<double> work(n_kinds_, 0.0);
  for (const auto& w : bin_work_)
    for (std::size_t c = 0; c < n_kinds_; ++c) work[c] += w[c];
  for (std::size_t id = 0; id < feature_.size(); ++id)
    if (!done_[id]) add_predicted_work(id, 1.0, work);
  double cpu = 0;
  for (std::size_t c : kinds)
    if (c < n_kinds_) cpu += k[c] * work[c];
  return cpu / double(feature_.size());
}

double ItemCostEta::cpu_per_wall_s() const {
  if (!(wall_done_s_ > 0)) return prior_rate_ > 0 ? prior_rate_ * double(threads_) : std::numeric_limits<double>::quiet_NaN();
  return cpu_done_s_ / wall_done_s_ * double(threads_);  // each thread's CPU-s per wall-s × threads
}

}  // namespace pvdf
