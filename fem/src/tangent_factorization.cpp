// The tangent's sparse direct factorization (tangent_factorization.hpp): CHOLMOD supernodal LLᵀ,
// Eigen's simplicial LDLᵀ where the tangent is not positive definite.
#include "tangent_factorization.hpp"

#include <Eigen/CholmodSupport>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>

#include <omp.h>

#include <algorithm>
#include <cstdlib>
#include <string>
#include <vector>

namespace pvdf::fem::detail {

struct TangentFactorization::Impl {
  using Matrix = Eigen::SparseMatrix<double>;
  Matrix matrix;                     // the full symmetric pattern (CSC); both factorizations read its lower part
  std::vector<std::ptrdiff_t> slot;  // deal.II entry k (in its row-major order) → value slot in `matrix`
  Eigen::CholmodSupernodalLLT<Matrix, Eigen::Lower> cholesky;
  Eigen::SimplicialLDLT<Matrix, Eigen::Lower, Eigen::AMDOrdering<int>> ldlt;
  bool cholesky_analyzed = false, ldlt_analyzed = false;
  int skip_cholesky = 0;  // factorizations left to do by LDLᵀ after a Cholesky met a non-positive pivot
  bool last_was_cholesky = false;

  Impl() {
    // CHOLMOD reports a non-positive pivot as a warning through its printf: keep stdout clean
    // (a --json caller reads it); the failure is seen through info() instead.
    cholesky.cholmod().print = 0;
  }
};

// Debian's CHOLMOD runs a few copy loops of its supernodal factorization in OpenMP teams of a
// fixed 4 threads (compiled in, `num_threads` clauses that OMP_NUM_THREADS cannot lower). On the
// 10k-DOF seed-001 tangent the wake-ups and spin-waits of those threads cost 4x the arithmetic
// (measured: 0.12 s against 0.028 s CPU per factorization). Allowing no active parallel level
// runs every OpenMP region of the process on the calling thread; pvdfkit's own parallelism is by
// std::thread (map generation, estimates) and by processes (MPI), never by OpenMP.
//
// PVDF_FACTORIZATION=simplicial-ldlt in the environment selects the method used before CHOLMOD,
// so that benchmarks can compare both in one run on one machine (docs/bench-fem.md).
// Both are settled once per process (a map builds a factorization for every probe mesh).
static bool simplicial_requested() {
  static const bool requested = [] {
    omp_set_max_active_levels(0);
    const char* env = std::getenv("PVDF_FACTORIZATION");
    return env && std::string(env) == "simplicial-ldlt";
  }();
  return requested;
}

TangentFactorization::TangentFactorization(Method method) : method_(method), impl_(std::make_unique<Impl>()) {
  if (simplicial_requested()) method_ = Method::simplicial_ldlt;
}
TangentFactorization::~TangentFactorization() = default;

// The Eigen copy of the pattern (CSC) and, for each deal.II entry, its slot there: each
// factorization copies the values without searching. Built by a counting transpose of deal.II's
// rows, O(nnz): visiting the rows in increasing order leaves every column's row indices sorted, so
// no sort or search is needed (the triplet sort + lower_bound before took 6.7 % of seed 001's
// centre solve, perf, for the Q2 and the Q3 pattern). Same CSC as Eigen's setFromTriplets.
void TangentFactorization::set_pattern(const dealii::SparsityPattern& pattern) {
  const auto n = static_cast<int>(pattern.n_rows());
  // A fresh Impl: CHOLMOD's and Eigen's symbolic analyses belong to the old pattern.
  impl_ = std::make_unique<Impl>();
  Impl& m = *impl_;
  const auto nnz = static_cast<Eigen::Index>(pattern.n_nonzero_elements());
  m.matrix.resize(n, n);
  m.matrix.resizeNonZeros(nnz);
  int* outer = m.matrix.outerIndexPtr();
  int* inner = m.matrix.innerIndexPtr();
  std::fill(outer, outer + n + 1, 0);
  for (int r = 0; r < n; ++r)
    for (auto it = pattern.begin(r); it != pattern.end(r); ++it) ++outer[it->column() + 1];
  for (int c = 0; c < n; ++c) outer[c + 1] += outer[c];
  std::vector<int> next(outer, outer + n);
  m.slot.resize(static_cast<std::size_t>(nnz));
  std::size_t k = 0;
  for (int r = 0; r < n; ++r)
    for (auto it = pattern.begin(r); it != pattern.end(r); ++it) {
      const int pos = next[it->column()]++;
      inner[pos] = r;
      m.slot[k++] = pos;
    }
  std::fill(m.matrix.valuePtr(), m.matrix.valuePtr() + nnz, 0.0);
  usable_ = false;
}

bool TangentFactorization::factorize(const dealii::SparseMatrix<double>& matrix) {
  Impl& m = *impl_;
  double* values = m.matrix.valuePtr();
  std::size_t k = 0;
  for (dealii::types::global_dof_index r = 0; r < matrix.m(); ++r)
    for (auto it = matrix.begin(r); it != matrix.end(r); ++it) values[m.slot[k++]] = it->value();
  ++n_factorizations_;
  usable_ = false;
  // A tangent that was indefinite tends to stay so for a few Newton steps (a slack or compressed
  // film): after a failed Cholesky the next four factorizations go straight to the LDLᵀ.
  if (method_ == Method::supernodal_cholesky && m.skip_cholesky > 0) --m.skip_cholesky;
  else if (method_ == Method::supernodal_cholesky) {
    if (!m.cholesky_analyzed) {
      m.cholesky.analyzePattern(m.matrix);
      m.cholesky_analyzed = true;
    }
    m.cholesky.factorize(m.matrix);
    if (m.cholesky.info() == Eigen::Success) {
      m.last_was_cholesky = true;
      usable_ = true;
      return true;
    }
    m.skip_cholesky = 4;
  }
  if (method_ == Method::supernodal_cholesky) ++n_ldlt_fallbacks_;
  if (!m.ldlt_analyzed) {
    m.ldlt.analyzePattern(m.matrix);
    m.ldlt_analyzed = true;
  }
  m.ldlt.factorize(m.matrix);
  m.last_was_cholesky = false;
  usable_ = m.ldlt.info() == Eigen::Success;
  return usable_;
}

void TangentFactorization::forget_history() {
  usable_ = false;
  if (impl_) impl_->skip_cholesky = 0;
}

void TangentFactorization::solve(const double* b, double* x, std::size_t n) const {
  const Eigen::Map<const Eigen::VectorXd> bv(b, static_cast<Eigen::Index>(n));
  Eigen::Map<Eigen::VectorXd> xv(x, static_cast<Eigen::Index>(n));
  if (impl_->last_was_cholesky)
    xv = impl_->cholesky.solve(bv);
  else
    xv = impl_->ldlt.solve(bv);
}

}  // namespace pvdf::fem::detail
