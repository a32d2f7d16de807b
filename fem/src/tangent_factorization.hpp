// Internal to pvdf::fem: the sparse direct factorization of the film's symmetric tangent, the
// linear algebra behind every Newton step, adjoint and chord step (docs/fem.md §5).
//
// Why this shape: the tangent's pattern is fixed per mesh, its values change every Newton step.
// So the ordering and symbolic analysis are done once per pattern and only the numeric
// factorization per step. The default is CHOLMOD's supernodal LLᵀ (dense BLAS kernels on the
// supernodes of a nested-dissection/AMD ordering): on the 10k-DOF seed-001 tangent it is ~10x
// faster than a simplicial (column-by-column) LDLᵀ. A tangent that is not positive definite
// (a compressed or slack film, a saddle of the continuation) makes the Cholesky stop at a
// non-positive pivot; that factorization is then redone by Eigen's simplicial LDLᵀ, which
// tolerates negative pivots. The caller checks the residual of each solve and falls back to a
// pivoting LU (UMFPACK) when even that is inaccurate.
#pragma once

#include <deal.II/lac/sparse_matrix.h>
#include <deal.II/lac/sparsity_pattern.h>

#include <cstddef>
#include <memory>
#include <mutex>

namespace pvdf::fem::detail {

/// Hold the returned lock while calling the BLAS from code outside TangentFactorization (the
/// UMFPACK fallback in newton.cpp): it is a real lock only when the process loaded OpenBLAS's
/// single-threaded flavour, which does not allow two threads in at once (tangent_factorization.cpp).
std::unique_lock<std::mutex> blas_turn();

class TangentFactorization {
 public:
  /// Which algorithm factorizes: supernodal Cholesky first (the default), or only the simplicial
  /// LDLᵀ (the method before CHOLMOD; kept for comparisons and as the fallback).
  enum class Method { supernodal_cholesky, simplicial_ldlt };

  explicit TangentFactorization(Method method = Method::supernodal_cholesky);
  ~TangentFactorization();
  TangentFactorization(const TangentFactorization&) = delete;
  TangentFactorization& operator=(const TangentFactorization&) = delete;

  /// A new pattern (a new mesh or DOF numbering): copies it and forgets the symbolic analysis.
  void set_pattern(const dealii::SparsityPattern& pattern);
  /// What a failed Cholesky (an indefinite tangent) is followed by: the LDLᵀ, or nothing (the
  /// caller has a positive definite tangent to try instead: newton.cpp's convexified one).
  enum class Fallback { ldlt, none };
  /// Numeric factorization of `matrix` (same pattern as set_pattern's); the symbolic analysis is
  /// done on the first call after set_pattern. Returns false when neither the Cholesky nor the
  /// LDLᵀ produced a factorization (the caller then uses a pivoting LU); with Fallback::none, false
  /// when the Cholesky failed (the tangent is not positive definite), the LDLᵀ not tried and the
  /// next factorization again tried by the Cholesky first.
  bool factorize(const dealii::SparseMatrix<double>& matrix, Fallback fallback = Fallback::ldlt);
  /// x = A⁻¹ b with the last successful factorization (b and x of size n, may not alias).
  void solve(const double* b, double* x, std::size_t n) const;
  /// A factorization of the current pattern is held (factorize() succeeded since set_pattern).
  bool usable() const { return usable_; }
  /// Marks the held factorization unusable (e.g. its solve was found inaccurate).
  void invalidate() { usable_ = false; }
  /// Forgets what earlier factorizations left behind (the held factor, the LDLᵀ-first countdown
  /// after an indefinite tangent), keeping the symbolic analyses: the next solve then depends on
  /// nothing solved before it (a map's rows are bitwise the same whichever thread ran what before).
  void forget_history();
  /// Numeric factorizations since construction, and how many of them fell back to the LDLᵀ.
  int n_factorizations() const { return n_factorizations_; }
  int n_ldlt_fallbacks() const { return n_ldlt_fallbacks_; }

 private:
  struct Impl;  // Eigen/CHOLMOD objects (tangent_factorization.cpp): cholmod.h stays out of this header
  Method method_;
  std::unique_ptr<Impl> impl_;
  bool usable_ = false;
  int n_factorizations_ = 0, n_ldlt_fallbacks_ = 0;
};

}  // namespace pvdf::fem::detail
