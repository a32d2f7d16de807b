// Differential evolution with Deb's feasibility rules (differential_evolution.hpp).
//
// Per generation and member i: guide = a random member of the best ⌈p·NP⌉, r1 ≠ r2 ≠ i random,
//   v = x_i + F (x_guide − x_i) + F (x_r1 − x_r2)          (JADE's current-to-pbest/1, F dithered)
// binomial crossover with rate CR (one coordinate always from v), a coordinate that leaves [0, 1]
// is put half-way between x_i and the bound it crossed, and the trial replaces x_i when it is not
// worse by Deb's rules. Only comparisons are used, so a step-like objective (a fraction of grid
// nodes) is no harder than a smooth one of the same landscape.
#include "pvdf/mapping/differential_evolution.hpp"

#include "pvdf/core/error.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>

namespace pvdf::mapping {

bool better_fitness(const Fitness& a, const Fitness& b) {
  if (a.violation != b.violation) return a.violation < b.violation;
  return std::lexicographical_compare(a.keys.begin(), a.keys.end(), b.keys.begin(), b.keys.end());
}

std::string differential_evolution_status_name(DifferentialEvolutionStatus status) {
  switch (status) {
    case DifferentialEvolutionStatus::budget_spent: return "budget_spent";
    case DifferentialEvolutionStatus::trials_exhausted: return "trials_exhausted";
    case DifferentialEvolutionStatus::no_feasible_point: return "no_feasible_point";
  }
  return "unknown";
}

namespace {

/// Uniform in [0, 1) from the 53 high bits: the same numbers on every platform (the standard
/// distributions are implementation-defined).
double uniform01(std::mt19937_64& rng) { return double(rng() >> 11) * 0x1.0p-53; }
std::size_t uniform_index(std::mt19937_64& rng, std::size_t n) {
  return std::min(n - 1, std::size_t(uniform01(rng) * double(n)));
}

}  // namespace

DifferentialEvolutionSummary differential_evolution(
    const std::function<double(const std::vector<double>&)>& violation,
    const std::function<std::vector<double>(const std::vector<double>&)>& objective,
    const DifferentialEvolutionOptions& o, const std::function<void(std::size_t)>& on_evaluation) {
  if (o.dimension == 0) throw InputError("differential_evolution: dimension 0; give at least one variable");
  if (o.max_evaluations == 0) throw InputError("differential_evolution: max_evaluations 0; give at least 1");
  const std::size_t d = o.dimension;
  const std::size_t np = o.population > 0 ? std::max<std::size_t>(o.population, 4)
                                          : std::clamp<std::size_t>(2 * d, 12, 40);
  const std::size_t max_trials = o.max_trials > 0 ? o.max_trials : 50 * o.max_evaluations;
  std::mt19937_64 rng(o.seed);

  DifferentialEvolutionSummary summary;
  auto score = [&](const std::vector<double>& x) {
    ++summary.n_trials;
    Fitness f;
    f.violation = violation(x);
    // Callers check spent() first, so a feasible point is always evaluated here.
    if (f.violation == 0) {
      f.keys = objective(x);
      ++summary.n_evaluations;
      if (on_evaluation) on_evaluation(summary.n_evaluations);
    }
    return f;
  };
  auto spent = [&] { return summary.n_evaluations >= o.max_evaluations || summary.n_trials >= max_trials; };

  // Step 1: the initial population — the given points, then random ones, each the first feasible
  // of up to init_tries draws (else the least violating): evaluations are spent on feasible points.
  std::vector<std::vector<double>> x;
  std::vector<Fitness> fit;
  for (std::size_t i = 0; i < np && !spent(); ++i) {
    std::vector<double> best_draw;
    double best_violation = std::numeric_limits<double>::infinity();
    if (i < o.initial.size()) {
      best_draw = o.initial[i];
      best_draw.resize(d, 0.5);
      for (double& v : best_draw) v = std::clamp(v, 0.0, 1.0);
      best_violation = violation(best_draw);
    }
    for (std::size_t t = 0; t < o.init_tries && best_violation > 0; ++t) {
      std::vector<double> draw(d);
      for (double& v : draw) v = uniform01(rng);
      const double viol = violation(draw);
      if (viol < best_violation) {
        best_violation = viol;
        best_draw = std::move(draw);
      }
    }
    fit.push_back(score(best_draw));
    x.push_back(std::move(best_draw));
  }
  auto keep_best = [&](const std::vector<double>& xi, const Fitness& fi) {
    if (summary.best_x.empty() || better_fitness(fi, summary.best)) {
      summary.best = fi;
      summary.best_x = xi;
    }
  };
  for (std::size_t i = 0; i < x.size(); ++i) keep_best(x[i], fit[i]);

  // Step 2: generations until the budget is spent.
  std::vector<std::size_t> order(x.size());
  while (!spent() && x.size() >= 4) {
    ++summary.n_generations;
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return better_fitness(fit[a], fit[b]); });
    const std::size_t n_pbest = std::max<std::size_t>(1, std::size_t(std::ceil(o.pbest_fraction * double(x.size()))));
    for (std::size_t i = 0; i < x.size() && !spent(); ++i) {
      const std::size_t guide = order[uniform_index(rng, n_pbest)];
      std::size_t r1 = i, r2 = i;
      while (r1 == i) r1 = uniform_index(rng, x.size());
      while (r2 == i || r2 == r1) r2 = uniform_index(rng, x.size());
      const double f = o.f_min + (o.f_max - o.f_min) * uniform01(rng);
      const std::size_t j_rand = uniform_index(rng, d);
      std::vector<double> trial = x[i];
      for (std::size_t j = 0; j < d; ++j) {
        if (j != j_rand && uniform01(rng) >= o.crossover) continue;
        double v = x[i][j] + f * (x[guide][j] - x[i][j]) + f * (x[r1][j] - x[r2][j]);
        if (v < 0) v = 0.5 * x[i][j];
        if (v > 1) v = 0.5 * (x[i][j] + 1);
        trial[j] = v;
      }
      Fitness ft = score(trial);
      keep_best(trial, ft);
      if (!better_fitness(fit[i], ft)) {  // not worse: replace (lets the population drift on plateaus)
        x[i] = std::move(trial);
        fit[i] = std::move(ft);
      }
    }
  }
  if (summary.best_x.empty() || summary.best.violation > 0) {
    summary.status = DifferentialEvolutionStatus::no_feasible_point;
  } else {
    summary.status = summary.n_evaluations >= o.max_evaluations ? DifferentialEvolutionStatus::budget_spent
                                                                 : DifferentialEvolutionStatus::trials_exhausted;
  }
  return summary;
}

}  // namespace pvdf::mapping
