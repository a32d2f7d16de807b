// A small self-contained differential evolution (DE/current-to-pbest/1/bin, Zhang & Sanderson's
// JADE mutation with fixed dithered parameters) over the unit cube, with constraints handled by
// Deb's feasibility rules. Used by the layout optimizer (optimize.hpp); docs/design.md §7 says why.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace pvdf::mapping {

/// What a trial point scored. Compared by Deb's rules (better_fitness): a feasible point
/// (violation 0) beats an infeasible one, two infeasible points compare by violation, two feasible
/// ones by `keys` lexicographically (smaller is better). Only feasible points are evaluated.
struct Fitness {
  double violation = 0;          ///< ≥ 0; 0 = feasible
  std::vector<double> keys;      ///< objective, lexicographic, smaller first (feasible points only)
};

/// True when `a` is strictly better than `b` by Deb's rules.
bool better_fitness(const Fitness& a, const Fitness& b);

/// Settings (public members with defaults).
struct DifferentialEvolutionOptions {
  std::size_t dimension = 0;          ///< search space [0, 1]^dimension
  std::size_t population = 0;         ///< 0 = clamp(2 × dimension, 12, 40)
  double crossover = 0.9;             ///< CR of the binomial crossover
  double f_min = 0.4, f_max = 0.9;    ///< the scale factor F is drawn uniformly in [f_min, f_max] per trial (dither)
  double pbest_fraction = 0.2;        ///< the "p" of current-to-pbest: the guide is one of the best p × population
  std::uint64_t seed = 1;             ///< the only source of randomness: equal seeds give equal runs
  std::size_t max_evaluations = 400;  ///< objective evaluations (feasible points) allowed
  std::size_t max_trials = 0;         ///< points generated at most, feasible or not; 0 = 50 × max_evaluations
  std::size_t init_tries = 200;       ///< random draws per initial member to find a feasible one
  std::vector<std::vector<double>> initial;  ///< starting points placed first in the population (clipped to [0, 1])
};

/// How the search ended.
enum class DifferentialEvolutionStatus {
  budget_spent,      ///< max_evaluations feasible points evaluated
  trials_exhausted,  ///< max_trials points generated first (feasible points are rare)
  no_feasible_point  ///< trials exhausted and no point met the constraints
};
std::string differential_evolution_status_name(DifferentialEvolutionStatus status);

struct DifferentialEvolutionSummary {
  DifferentialEvolutionStatus status = DifferentialEvolutionStatus::budget_spent;
  std::vector<double> best_x;  ///< in [0, 1]^dimension
  Fitness best;
  std::size_t n_evaluations = 0, n_trials = 0, n_generations = 0;
};

/// Minimizes over [0, 1]^dimension.
/// @param[in] violation  cheap constraint measure of a point, ≥ 0 (0 = feasible)
/// @param[in] objective  the keys of a feasible point (costly; called only where violation = 0)
/// @param[in] on_evaluation  called after each objective evaluation with the count so far (may be empty)
DifferentialEvolutionSummary differential_evolution(
    const std::function<double(const std::vector<double>&)>& violation,
    const std::function<std::vector<double>(const std::vector<double>&)>& objective,
    const DifferentialEvolutionOptions& options,
    const std::function<void(std::size_t n_evaluations)>& on_evaluation = {});

}  // namespace pvdf::mapping
