// Sparse LDL^T in 3x3 blocks of a symmetric BlockSparseMatrix (docs/solver.md, "Direct solver"):
// A = P^T L D L^T P with P a fill-reducing ordering (AMD) of the node graph, L unit lower triangular
// in 3x3 blocks and D block diagonal. Up-looking: row k of L is a sparse triangular solve along the
// elimination tree, as in a scalar simplicial LDL^T, with every entry a 3x3 block. The blocks keep
// the arithmetic dense and the index work a ninth of the scalar method's.
#pragma once

#include <Eigen/Core>

#include <array>
#include <cstdint>
#include <vector>

#include "shatter/core/types.h"
#include "shatter/fem/assembly.h"

namespace shatter {

class BlockLdlt {
 public:
  /// Symbolic analysis of a's pattern: the ordering, the elimination tree and the blocks of each
  /// column of L. Redo it when the pattern changes (BlockSparseMatrix::pattern_id).
  void analyze(const BlockSparseMatrix& a);

  /// Numeric factorization of a's values (of the pattern analysed). False when a pivot block is
  /// singular or not finite (then solve must not be called).
  bool factorize(const BlockSparseMatrix& a);

  /// Every pivot block of the last factorization is positive definite: so is A.
  [[nodiscard]] bool positive_definite() const { return positive_definite_; }

  /// x = A^-1 b (b, x: 3 x active nodes) after a successful factorize.
  void solve(const Eigen::VectorXd& b, Eigen::VectorXd& x) const;

  /// What a scalar LDL^T with the same fill would store below its diagonal, and its multiply-adds
  /// (sum over scalar columns of count^2): the direct solver's cost model (after analyze).
  [[nodiscard]] double factor_nonzeros() const { return factor_nonzeros_; }
  [[nodiscard]] double factor_flops() const { return factor_flops_; }

  /// The fill-reducing ordering (after analyze): ordering()[k] is the active node eliminated k-th.
  [[nodiscard]] const std::vector<Index>& ordering() const { return old_of_; }

 public:
  /// A 3x3 block stored by columns of four (the fourth entry of each column zero): the block
  /// products then run on whole vectors (four-wide with AVX2, two two-wide otherwise).
  struct alignas(32) Block {
    std::array<double, 12> v{};  ///< (r, c) at 4 c + r, r < 3
  };

 private:
  /// factorize's body, compiled for AVX2 and for the baseline (the same operations: the same bits).
  template <bool kAvx2>
  bool factorize_with(const BlockSparseMatrix& a);
  bool factorize_avx2(const BlockSparseMatrix& a);
  bool factorize_baseline(const BlockSparseMatrix& a);

  Index n_ = 0;                        ///< block rows (active nodes)
  std::vector<Index> old_of_;          ///< ordered index -> active node (#n)
  std::vector<Index> new_of_;          ///< active node -> ordered index (#n)
  std::vector<Index> upper_ptr_;       ///< column k of P A P^T above its diagonal: upper_ptr_[k] .. [k+1)
  std::vector<Index> upper_row_;       ///< its rows (ordered indices < k)
  std::vector<Index> upper_block_;     ///< the block of a holding A(old row, old k)
  std::vector<Index> diagonal_block_;  ///< per ordered index, a's diagonal block
  std::vector<Index> parent_;          ///< elimination tree (-1: a root)
  std::vector<Index> l_ptr_;           ///< column i of L: l_ptr_[i] .. l_ptr_[i] + count
  std::vector<Index> l_row_;
  std::vector<Block> l_block_;
  std::vector<Mat3> d_inverse_;  ///< D_k^-1
  bool positive_definite_ = false;
  double factor_nonzeros_ = 0;
  double factor_flops_ = 0;
  // Work space of factorize and solve.
  std::vector<Block> y_;
  std::vector<Index> pattern_, flag_, count_;
  mutable std::vector<Vec3> z_;
};

}  // namespace shatter
