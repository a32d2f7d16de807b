// The tangent's sparse direct factorization (tangent_factorization.hpp): CHOLMOD supernodal LLᵀ,
// Eigen's simplicial LDLᵀ where the tangent is not positive definite.
#include "tangent_factorization.hpp"

#include <Eigen/CholmodSupport>
#include <Eigen/OrderingMethods>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>

#include <omp.h>

#include <algorithm>
#include <cstdlib>
#include <mutex>
#include <string>
#include <vector>

namespace pvdf::fem::detail {

// Eigen's CHOLMOD wrapper with one addition: the numeric values of the factor can be dropped while
// its symbolic analysis (ordering, supernodes) is kept, so a factor that is not in use (a Cholesky
// that met a non-positive pivot, while the LDLᵀ serves) holds no memory but its structure.
// cholmod_factorize refills a symbolic factor from scratch, so the next factor is the same.
class SupernodalCholesky : public Eigen::CholmodSupernodalLLT<Eigen::SparseMatrix<double>, Eigen::Upper> {
 public:
  void release_numeric() {
    if (m_cholmodFactor && m_cholmodFactor->xtype != CHOLMOD_PATTERN)
      cholmod_change_factor(CHOLMOD_PATTERN, m_cholmodFactor->is_ll, m_cholmodFactor->is_super, 1, 1, m_cholmodFactor,
                            &cholmod());
  }
};

// Eigen's AMDOrdering, the same permutation with a sixth of its memory. AMDOrdering hands the
// minimum-degree routine the pattern of Aᵀ + A built with values (two more full copies of the
// matrix); the matrix it is given here is already the full symmetric one, sorted, so that pattern
// is its own, and only the structure is read. Measured: on the Q3 estimate space of a direct map
// solve near the clamp the two copies were 0.98 GB of a 5.3 GB peak (heaptrack). Same
// permutation: Eigen's own minimum_degree_ordering on an identical, identically ordered pattern
// (checked against AMDOrdering on 20 random symmetric patterns, n = 200…5900).
struct PatternAmdOrdering {
  using PermutationType = Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int>;
  template <typename MatrixType>
  void operator()(const MatrixType& mat, PermutationType& perm) const {
    if (!mat.isCompressed()) {
      Eigen::AMDOrdering<int>()(mat, perm);
      return;
    }
    Eigen::SparseMatrix<char, Eigen::ColMajor, int> pattern(mat.rows(), mat.cols());
    pattern.resizeNonZeros(mat.nonZeros());
    std::copy(mat.outerIndexPtr(), mat.outerIndexPtr() + mat.outerSize() + 1, pattern.outerIndexPtr());
    std::copy(mat.innerIndexPtr(), mat.innerIndexPtr() + mat.nonZeros(), pattern.innerIndexPtr());
    Eigen::internal::minimum_degree_ordering(pattern, perm);
  }
};

struct TangentFactorization::Impl {
  using Matrix = Eigen::SparseMatrix<double>;
  using Ldlt = Eigen::SimplicialLDLT<Matrix, Eigen::Upper, PatternAmdOrdering>;
  // The upper triangle of the symmetric pattern (CSC), all that both factorizations read: half the
  // copy of the full pattern (measured: the Q3 estimate space of a direct map solve near the clamp
  // held 0.54 GB in the full copy and its slots). Upper, not lower: CHOLMOD's supernodal
  // factorization wants tril(PAPᵀ) and makes it with one permuted transpose from triu(A), two
  // from tril(A) (cholmod_factorize.c); the second was 4 % of a map node (perf,
  // cholmod_transpose_sym 8 % of the samples).
  Matrix matrix;
  std::vector<int> slot;  // deal.II entry k (in its row-major order) → value slot in `matrix`; -1 below the diagonal
  SupernodalCholesky cholesky;
  // Built on the first indefinite tangent and dropped when a Cholesky succeeds again: its factor
  // (simplicial, AMD) is as large as the Cholesky's, and a map's engines met an indefinite tangent
  // once (a cold row start) and then kept both for the rest of the map.
  std::unique_ptr<Ldlt> ldlt;
  bool cholesky_analyzed = false;
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
// runs every OpenMP region on the calling thread; pvdfkit's own parallelism is by std::thread (map
// generation, estimates) and by processes (MPI), never by OpenMP. The setting is per thread in
// GCC's libgomp (max-active-levels is a data-environment ICV since OpenMP 5.0): set once in the
// main thread it left every map worker thread at the default, with CHOLMOD's teams of 4 (r12,
// checked with a std::thread: 0 in main, 1 in the thread). So every thread that factorizes or
// solves sets it for itself, once.
static void openmp_serial_on_this_thread() {
  thread_local const bool set = [] {
    omp_set_max_active_levels(0);
    return true;
  }();
  (void)set;
}

// CHOLMOD's dense kernels run in whichever BLAS the process loaded: OpenBLAS (fem/CMakeLists.txt
// puts it first). Debian's single-threaded flavour (libopenblas0-serial, "SINGLE_THREADED" in
// openblas_get_config) is not built for two threads calling at once (its work buffers are handed
// out without a lock unless built with USE_LOCKING), and map threads do call at once. On it a
// 2-thread map of the 10 mm CI film differed from the 1-thread one, and from itself run to run,
// by up to 1e-15 of the largest charge at 5-20 % of its values (5 runs of 5), and the main job's
// map decided the clamp layer differently at 2 nodes (0.26 %). Newton hid the race by iterating;
// an estimate solved with a raced factor has no such cover. The reference BLAS (thread-safe) gave
// the 1-thread map in 3 runs of 3, 1.9x slower; so did the pthread flavour asked for one thread
// per call (scripts/install-deps), in 4 runs of 4, at the serial flavour's speed
// (docs/map-generation.md §2). So: one OpenBLAS thread per call (the map's threads are the
// parallelism), and where the loaded OpenBLAS is the single-threaded one, one BLAS caller at a
// time (correct, slower). Other BLAS (ATLAS, the reference BLAS) define neither symbol.
extern "C" {
void openblas_set_num_threads(int) __attribute__((weak));
int openblas_get_parallel(void) __attribute__((weak));
}

static bool blas_needs_one_caller_at_a_time() {
  static const bool serialize = [] {
    if (openblas_set_num_threads) openblas_set_num_threads(1);
    return openblas_get_parallel != nullptr && openblas_get_parallel() == 0;
  }();
  return serialize;
}

// Held while a factorization or solve may call the BLAS, when blas_needs_one_caller_at_a_time().
std::unique_lock<std::mutex> blas_turn() {
  static std::mutex m;
  return blas_needs_one_caller_at_a_time() ? std::unique_lock<std::mutex>(m) : std::unique_lock<std::mutex>();
}

// CHOLMOD may order by METIS (it tries METIS when AMD's fill is high), whose random generator's
// state is a process global: two threads analysing at once would interleave its draws, and the
// ordering (so the rounding of every factorization) would depend on timing. Not the race measured
// above (the CI film's orderings are AMD's: AMD alone gave the same map bit for bit), a guard for
// the larger meshes; one analysis per mesh, so the lock costs nothing measurable.
static std::mutex& cholmod_analysis_mutex() {
  static std::mutex m;
  return m;
}

// PVDF_FACTORIZATION=simplicial-ldlt in the environment selects the method used before CHOLMOD,
// so that benchmarks can compare both in one run on one machine (docs/bench-fem.md).
// Settled once per process (a map builds a factorization for every probe mesh).
static bool simplicial_requested() {
  static const bool requested = [] {
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
// rows, O(nnz): row r gives column c >= r its entry (r, c) (deal.II keeps the diagonal first in
// a row, which is still the column's last); visiting the rows in increasing order leaves every
// column's row indices sorted, so
// no sort or search is needed (the triplet sort + lower_bound before took 6.7 % of seed 001's
// centre solve, perf, for the Q2 and the Q3 pattern). Same CSC as Eigen's setFromTriplets.
void TangentFactorization::set_pattern(const dealii::SparsityPattern& pattern) {
  const auto n = static_cast<int>(pattern.n_rows());
  // A fresh Impl: CHOLMOD's and Eigen's symbolic analyses belong to the old pattern.
  impl_ = std::make_unique<Impl>();
  Impl& m = *impl_;
  m.matrix.resize(n, n);
  std::vector<int> count(static_cast<std::size_t>(n) + 1, 0);
  for (int r = 0; r < n; ++r)
    for (auto it = pattern.begin(r); it != pattern.end(r); ++it)
      if (static_cast<int>(it->column()) >= r) ++count[it->column() + 1];
  for (int c = 0; c < n; ++c) count[c + 1] += count[c];
  const auto nnz = static_cast<Eigen::Index>(count[n]);
  m.matrix.resizeNonZeros(nnz);
  int* outer = m.matrix.outerIndexPtr();
  int* inner = m.matrix.innerIndexPtr();
  std::copy(count.begin(), count.end(), outer);
  std::vector<int>& next = count;  // reused: the next free slot of each column
  m.slot.resize(static_cast<std::size_t>(pattern.n_nonzero_elements()));
  std::size_t k = 0;
  for (int r = 0; r < n; ++r)
    for (auto it = pattern.begin(r); it != pattern.end(r); ++it) {
      const int c = static_cast<int>(it->column());
      if (c < r) {
        m.slot[k++] = -1;
        continue;
      }
      const int pos = next[c]++;
      inner[pos] = r;
      m.slot[k++] = pos;
    }
  std::fill(m.matrix.valuePtr(), m.matrix.valuePtr() + nnz, 0.0);
  usable_ = false;
}

bool TangentFactorization::factorize(const dealii::SparseMatrix<double>& matrix, Fallback fallback) {
  openmp_serial_on_this_thread();
  const auto blas = blas_turn();
  Impl& m = *impl_;
  double* values = m.matrix.valuePtr();
  std::size_t k = 0;
  for (dealii::types::global_dof_index r = 0; r < matrix.m(); ++r)
    for (auto it = matrix.begin(r); it != matrix.end(r); ++it) {
      const int pos = m.slot[k++];
      if (pos >= 0) values[pos] = it->value();
    }
  ++n_factorizations_;
  usable_ = false;
  // A tangent that was indefinite tends to stay so for a few Newton steps (a slack or compressed
  // film): after a failed Cholesky the next four factorizations go straight to the LDLᵀ.
  if (method_ == Method::supernodal_cholesky && m.skip_cholesky > 0 && fallback == Fallback::ldlt) --m.skip_cholesky;
  else if (method_ == Method::supernodal_cholesky) {
    if (!m.cholesky_analyzed) {
      std::lock_guard<std::mutex> one_at_a_time(cholmod_analysis_mutex());
      m.cholesky.analyzePattern(m.matrix);
      m.cholesky_analyzed = true;
    }
    m.cholesky.factorize(m.matrix);
    if (m.cholesky.info() == Eigen::Success) {
      m.last_was_cholesky = true;
      m.ldlt.reset();
      usable_ = true;
      return true;
    }
    // Its partial factor is of no use while the LDLᵀ serves: only the analysis is kept.
    m.cholesky.release_numeric();
    if (fallback == Fallback::none) return false;
    m.skip_cholesky = 4;
  }
  if (method_ == Method::supernodal_cholesky) ++n_ldlt_fallbacks_;
  if (!m.ldlt) {
    m.ldlt = std::make_unique<Impl::Ldlt>();
    m.ldlt->analyzePattern(m.matrix);
  }
  m.ldlt->factorize(m.matrix);
  m.last_was_cholesky = false;
  usable_ = m.ldlt->info() == Eigen::Success;
  return usable_;
}

void TangentFactorization::forget_history() {
  usable_ = false;
  if (impl_) impl_->skip_cholesky = 0;
}

void TangentFactorization::solve(const double* b, double* x, std::size_t n) const {
  openmp_serial_on_this_thread();
  const auto blas = blas_turn();
  const Eigen::Map<const Eigen::VectorXd> bv(b, static_cast<Eigen::Index>(n));
  Eigen::Map<Eigen::VectorXd> xv(x, static_cast<Eigen::Index>(n));
  if (impl_->last_was_cholesky)
    xv = impl_->cholesky.solve(bv);
  else
    xv = impl_->ldlt->solve(bv);
}

}  // namespace pvdf::fem::detail
