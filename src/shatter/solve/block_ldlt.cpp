// Sparse LDL^T in 3x3 blocks (see block_ldlt.h).
#include "shatter/solve/block_ldlt.h"

#include <Eigen/OrderingMethods>
#include <Eigen/SparseCore>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>

#include "shatter/core/assert.h"
#include "shatter/core/lanes.h"
#include "shatter/core/simd.h"

namespace shatter {
namespace {

using Block = BlockLdlt::Block;

// The 3x3 kernels, written out (GCC at -O2 leaves Eigen's fixed-size products as calls). The
// factorization's product runs on whole columns of Blocks, as vectors: the fourth lane computes
// zeros, and each of the three others does exactly what the scalar formula does (no fused
// multiply-adds: -ffp-contract=off), so AVX2's four-wide vectors and the baseline's two-wide ones
// give the same bits. That product is nearly all of a factorization's time: 2-2.5 times faster
// than the scalar form (237 to 1,845 block rows).

// One column of a Block as a vector, and back.
[[gnu::always_inline]] inline PlainLanes column(const Block& b, int c) {
  PlainLanes v;
  std::memcpy(&v, b.v.data() + 4 * c, sizeof v);
  return v;
}
[[gnu::always_inline]] inline void set_column(Block& b, int c, const PlainLanes& v) {
  std::memcpy(b.v.data() + 4 * c, &v, sizeof v);
}
// x's entries broadcast: xb[3 c + j] = x(j, c) in every lane.
struct Broadcast {
  PlainLanes xb[9];
  [[gnu::always_inline]] explicit Broadcast(const Block& x) {
    for (int c = 0; c < 3; ++c)
      for (int j = 0; j < 3; ++j) xb[3 * c + j] = PlainLanes{} + x.v[4 * c + j];
  }
};
// y -= l x, a column at a time: y(r, c) -= l(r, 0) x(0, c) + l(r, 1) x(1, c) + l(r, 2) x(2, c).
[[gnu::always_inline]] inline void subtract_product(Block& y, const Block& l, const Broadcast& x) {
  const PlainLanes l0 = column(l, 0), l1 = column(l, 1), l2 = column(l, 2);
  for (int c = 0; c < 3; ++c)
    set_column(y, c, column(y, c) - (l0 * x.xb[3 * c] + l1 * x.xb[3 * c + 1] + l2 * x.xb[3 * c + 2]));
}
// x^T d (d symmetric)
[[gnu::always_inline]] inline Block transposed_product(const Block& x, const Mat3& d) {
  Block out;
  for (int c = 0; c < 3; ++c)
    for (int r = 0; r < 3; ++r)
      out.v[4 * c + r] = x.v[4 * r] * d(0, c) + x.v[4 * r + 1] * d(1, c) + x.v[4 * r + 2] * d(2, c);
  return out;
}
// A matrix as a Block, and back.
[[gnu::always_inline]] inline Block padded(const Mat3& m) {
  Block b;
  for (int c = 0; c < 3; ++c)
    for (int r = 0; r < 3; ++r) b.v[4 * c + r] = m(r, c);
  return b;
}
[[gnu::always_inline]] inline Mat3 unpadded(const Block& b) {
  Mat3 m;
  for (int c = 0; c < 3; ++c)
    for (int r = 0; r < 3; ++r) m(r, c) = b.v[4 * c + r];
  return m;
}
// z -= l v
inline void subtract_product(Vec3& z, const Block& l, const Vec3& v) {
  for (int r = 0; r < 3; ++r) z[r] -= l.v[r] * v[0] + l.v[4 + r] * v[1] + l.v[8 + r] * v[2];
}
// z -= l^T v
inline void subtract_transposed_product(Vec3& z, const Block& l, const Vec3& v) {
  for (int r = 0; r < 3; ++r) z[r] -= l.v[4 * r] * v[0] + l.v[4 * r + 1] * v[1] + l.v[4 * r + 2] * v[2];
}

// The inverse of a symmetric 3x3 pivot from its cofactors; false when it is singular or not finite.
// `positive`: its leading minors are positive (the pivot is positive definite).
[[gnu::always_inline]] inline bool invert_pivot(const Mat3& d, Mat3& inverse, bool& positive) {
  const double c00 = d(1, 1) * d(2, 2) - d(1, 2) * d(2, 1);
  const double c01 = d(1, 2) * d(2, 0) - d(1, 0) * d(2, 2);
  const double c02 = d(1, 0) * d(2, 1) - d(1, 1) * d(2, 0);
  const double det = d(0, 0) * c00 + d(0, 1) * c01 + d(0, 2) * c02;
  if (!std::isfinite(det) || det == 0.0) return false;
  const double s = 1.0 / det;
  inverse(0, 0) = c00 * s;
  inverse(1, 0) = c01 * s;
  inverse(2, 0) = c02 * s;
  inverse(0, 1) = (d(0, 2) * d(2, 1) - d(0, 1) * d(2, 2)) * s;
  inverse(1, 1) = (d(0, 0) * d(2, 2) - d(0, 2) * d(2, 0)) * s;
  inverse(2, 1) = (d(0, 1) * d(2, 0) - d(0, 0) * d(2, 1)) * s;
  inverse(0, 2) = (d(0, 1) * d(1, 2) - d(0, 2) * d(1, 1)) * s;
  inverse(1, 2) = (d(0, 2) * d(1, 0) - d(0, 0) * d(1, 2)) * s;
  inverse(2, 2) = (d(0, 0) * d(1, 1) - d(0, 1) * d(1, 0)) * s;
  positive = d(0, 0) > 0.0 && d(0, 0) * d(1, 1) - d(0, 1) * d(1, 0) > 0.0 && det > 0.0;
  return inverse.allFinite();
}

}  // namespace

void BlockLdlt::analyze(const BlockSparseMatrix& a) {
  n_ = a.num_active();
  const std::vector<Index>& ptr = a.block_ptr();
  const std::vector<Index>& col = a.block_col();
  // AMD on the node graph: Eigen's minimum degree on the block pattern as it stands. The pattern
  // is symmetric with sorted rows, so it is already the A + A^T that Eigen::AMDOrdering would
  // build from triplets and two transposes: the same input, the same ordering.
  Eigen::SparseMatrix<double, Eigen::ColMajor, int> graph(n_, n_);
  graph.resizeNonZeros(a.num_blocks());
  std::copy(ptr.begin(), ptr.end(), graph.outerIndexPtr());
  std::copy(col.begin(), col.begin() + a.num_blocks(), graph.innerIndexPtr());
  std::fill_n(graph.valuePtr(), a.num_blocks(), 1.0);
  Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> ordering;
  Eigen::internal::minimum_degree_ordering(graph, ordering);  // ordering.indices()[new] = old
  old_of_.assign(ordering.indices().data(), ordering.indices().data() + n_);
  new_of_.assign(static_cast<std::size_t>(n_), 0);
  for (Index k = 0; k < n_; ++k) new_of_[old_of_[k]] = k;

  // Column k of P A P^T above its diagonal, rows ascending: the blocks (old i, old k) with
  // new_of(i) < k, found in block row old i (the matrix stores both triangles). A counting sort
  // by column, filled in ascending new row order.
  upper_ptr_.assign(static_cast<std::size_t>(n_) + 1, 0);
  diagonal_block_.assign(static_cast<std::size_t>(n_), -1);
  for (Index r = 0; r < n_; ++r) {
    const Index nr = new_of_[r];
    for (Index k = ptr[r]; k < ptr[r + 1]; ++k) {
      const Index nc = new_of_[col[k]];
      if (nc == nr) diagonal_block_[nr] = k;
      if (nr < nc) ++upper_ptr_[nc + 1];
    }
  }
  for (Index k = 0; k < n_; ++k) upper_ptr_[k + 1] += upper_ptr_[k];
  upper_row_.resize(static_cast<std::size_t>(upper_ptr_[n_]));
  upper_block_.resize(static_cast<std::size_t>(upper_ptr_[n_]));
  std::vector<Index> next(upper_ptr_.begin(), upper_ptr_.end() - 1);
  for (Index nr = 0; nr < n_; ++nr) {
    const Index r = old_of_[nr];
    for (Index k = ptr[r]; k < ptr[r + 1]; ++k) {
      const Index nc = new_of_[col[k]];
      if (nr < nc) {
        upper_row_[next[nc]] = nr;
        upper_block_[next[nc]++] = k;
      }
    }
  }

  // Elimination tree and column counts of L (a scalar simplicial analysis, on blocks).
  parent_.assign(static_cast<std::size_t>(n_), -1);
  flag_.assign(static_cast<std::size_t>(n_), -1);
  std::vector<Index> counts(static_cast<std::size_t>(n_), 0);
  for (Index k = 0; k < n_; ++k) {
    flag_[k] = k;
    for (Index e = upper_ptr_[k]; e < upper_ptr_[k + 1]; ++e)
      for (Index i = upper_row_[e]; flag_[i] != k; i = parent_[i]) {
        if (parent_[i] == -1) parent_[i] = k;
        ++counts[i];
        flag_[i] = k;
      }
  }
  l_ptr_.assign(static_cast<std::size_t>(n_) + 1, 0);
  factor_nonzeros_ = factor_flops_ = 0;
  for (Index k = 0; k < n_; ++k) {
    l_ptr_[k + 1] = l_ptr_[k] + counts[k];
    // The scalar columns of block column k hold 3c + 2, 3c + 1 and 3c entries below the diagonal.
    const double c = 3.0 * static_cast<double>(counts[k]);
    factor_nonzeros_ += 3.0 * c + 3.0;
    factor_flops_ += (c + 2) * (c + 2) + (c + 1) * (c + 1) + c * c;
  }
  l_row_.resize(static_cast<std::size_t>(l_ptr_[n_]));
  l_block_.resize(static_cast<std::size_t>(l_ptr_[n_]));
  d_inverse_.resize(static_cast<std::size_t>(n_));
  y_.assign(static_cast<std::size_t>(n_), Block{});
  pattern_.resize(static_cast<std::size_t>(n_));
  count_.resize(static_cast<std::size_t>(n_));
  z_.resize(static_cast<std::size_t>(n_));
}

// Compiled once per instruction set (kAvx2 only tells the two copies apart).
template <bool kAvx2>
[[gnu::always_inline]] inline bool BlockLdlt::factorize_with(const BlockSparseMatrix& a) {
  positive_definite_ = true;
  std::fill(count_.begin(), count_.end(), 0);
  std::fill(flag_.begin(), flag_.end(), -1);
  for (Index k = 0; k < n_; ++k) {
    // Scatter column k above the diagonal into y; the rows of L's row k are those reached from
    // its entries up the elimination tree, solved in topological order (pattern_[top..n)).
    Index top = n_;
    flag_[k] = k;
    for (Index e = upper_ptr_[k]; e < upper_ptr_[k + 1]; ++e) {
      Index i = upper_row_[e];
      y_[i] = padded(a.block(old_of_[i], upper_block_[e]));
      Index len = 0;
      for (; flag_[i] != k; i = parent_[i]) {
        pattern_[len++] = i;
        flag_[i] = k;
      }
      while (len > 0) pattern_[--top] = pattern_[--len];
    }
    Block d = padded(a.block(old_of_[k], diagonal_block_[k]));
    for (; top < n_; ++top) {
      // X_i = D_i L(k,i)^T is final here: push it into the rows below i, then L(k,i) = X_i^T D_i^-1
      // and D_k -= L(k,i) X_i.
      const Index i = pattern_[top];
      const Block x = y_[i];
      y_[i] = Block{};
      const Index first = l_ptr_[i];
      const Index end = first + count_[i];
      const Broadcast xb(x);
      for (Index p = first; p < end; ++p) subtract_product(y_[l_row_[p]], l_block_[p], xb);
      const Block l = transposed_product(x, d_inverse_[i]);
      subtract_product(d, l, xb);
      l_row_[end] = k;
      l_block_[end] = l;
      ++count_[i];
    }
    // d is symmetric up to round-off; its inverse from the symmetric part keeps D^-1 symmetric.
    const Mat3 dk = unpadded(d);
    const Mat3 pivot = 0.5 * (dk + dk.transpose());
    bool positive = false;
    if (!invert_pivot(pivot, d_inverse_[k], positive)) return false;
    positive_definite_ = positive_definite_ && positive;
  }
  return true;
}

bool BlockLdlt::factorize(const BlockSparseMatrix& a) {
  SHATTER_CHECK(a.num_active() == n_);
  return simd_isa() == SimdIsa::avx2 ? factorize_avx2(a) : factorize_baseline(a);
}

[[gnu::target("avx2")]] bool BlockLdlt::factorize_avx2(const BlockSparseMatrix& a) { return factorize_with<true>(a); }
bool BlockLdlt::factorize_baseline(const BlockSparseMatrix& a) { return factorize_with<false>(a); }

void BlockLdlt::solve(const Eigen::VectorXd& b, Eigen::VectorXd& x) const {
  SHATTER_CHECK(b.size() == 3 * n_);
  for (Index k = 0; k < n_; ++k) z_[k] = b.segment<3>(3 * old_of_[k]);
  // L z = P b, column by column.
  for (Index i = 0; i < n_; ++i)
    for (Index p = l_ptr_[i]; p < l_ptr_[i] + count_[i]; ++p) subtract_product(z_[l_row_[p]], l_block_[p], z_[i]);
  for (Index i = 0; i < n_; ++i) {
    const Vec3 v = z_[i];
    const Mat3& d = d_inverse_[i];
    for (int r = 0; r < 3; ++r) z_[i][r] = d(r, 0) * v[0] + d(r, 1) * v[1] + d(r, 2) * v[2];
  }
  // L^T x' = z, backwards.
  for (Index i = n_ - 1; i >= 0; --i)
    for (Index p = l_ptr_[i]; p < l_ptr_[i] + count_[i]; ++p)
      subtract_transposed_product(z_[i], l_block_[p], z_[l_row_[p]]);
  x.resize(3 * n_);
  for (Index k = 0; k < n_; ++k) x.segment<3>(3 * old_of_[k]) = z_[k];
}

}  // namespace shatter
