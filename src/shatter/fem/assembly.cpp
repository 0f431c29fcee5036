// Block pattern construction, greedy tet colouring and the in-place refill of the stiffness.
#include "shatter/fem/assembly.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cstdint>

#include <Eigen/Eigenvalues>

#include "shatter/core/assert.h"
#include "shatter/fem/fem_model.h"
#include "shatter/fem/tet_kernels.h"

namespace shatter {

namespace {

std::uint64_t next_pattern_id() {
  static std::atomic<std::uint64_t> counter{0};
  return ++counter;
}

}  // namespace

BlockSparseMatrix::BlockSparseMatrix(Index num_nodes, const std::vector<TetIndices>& tets,
                                     const std::vector<AnchorMask>& anchors)
    : pattern_id_(next_pattern_id()) {
  SHATTER_CHECK(anchors.empty() || static_cast<Index>(anchors.size()) == num_nodes);
  anchors_ = anchors.empty() ? std::vector<AnchorMask>(static_cast<std::size_t>(num_nodes), anchor_none) : anchors;
  for (AnchorMask& m : anchors_) m &= anchor_all;

  // Active nodes: in some tet, with a free component. Numbered in node order.
  std::vector<char> in_tet(static_cast<std::size_t>(num_nodes), 0);
  for (const TetIndices& t : tets)
    for (Index v : t) {
      SHATTER_CHECK(v >= 0 && v < num_nodes);
      in_tet[v] = 1;
    }
  active_of_node_.assign(static_cast<std::size_t>(num_nodes), -1);
  for (Index v = 0; v < num_nodes; ++v) {
    if (in_tet[v] && anchors_[v] != anchor_all) {
      active_of_node_[v] = static_cast<Index>(node_of_active_.size());
      node_of_active_.push_back(v);
    }
  }
  const Index na = num_active();

  // Active tets and their greedy colouring (in tet order): a tet takes the smallest colour that
  // no tet sharing one of its nodes already has.
  // The colours used at each node as bit sets of `words` 64-bit words (grown when a tet needs a
  // colour beyond them); the smallest colour free at all four nodes is the lowest zero bit.
  std::vector<Index> tet_color;
  std::vector<Index> active;
  std::size_t words = 1;
  std::vector<std::uint64_t> used(static_cast<std::size_t>(num_nodes), 0);
  for (Index e = 0; e < static_cast<Index>(tets.size()); ++e) {
    const TetIndices& t = tets[e];
    if (active_of_node_[t[0]] < 0 && active_of_node_[t[1]] < 0 && active_of_node_[t[2]] < 0 &&
        active_of_node_[t[3]] < 0)
      continue;
    Index color = -1;
    for (std::size_t w = 0; w < words && color < 0; ++w) {
      std::uint64_t taken = 0;
      for (Index v : t) taken |= used[static_cast<std::size_t>(v) * words + w];
      if (~taken != 0) color = static_cast<Index>(64 * w) + std::countr_zero(~taken);
    }
    if (color < 0) {  // every colour of the words in use is taken at some corner: one word more
      std::vector<std::uint64_t> wider(static_cast<std::size_t>(num_nodes) * (words + 1), 0);
      for (std::size_t v = 0; v < static_cast<std::size_t>(num_nodes); ++v)
        std::copy_n(used.begin() + static_cast<std::ptrdiff_t>(v * words), words,
                    wider.begin() + static_cast<std::ptrdiff_t>(v * (words + 1)));
      used.swap(wider);
      color = static_cast<Index>(64 * words);
      ++words;
    }
    const std::size_t w = static_cast<std::size_t>(color) / 64;
    for (Index v : t) used[static_cast<std::size_t>(v) * words + w] |= std::uint64_t{1} << (color % 64);
    active.push_back(e);
    tet_color.push_back(color);
  }
  Index num_colors = 0;
  for (Index c : tet_color) num_colors = std::max(num_colors, c + 1);
  color_ptr_.assign(static_cast<std::size_t>(num_colors) + 1, 0);
  for (Index c : tet_color) ++color_ptr_[c + 1];
  for (Index c = 0; c < num_colors; ++c) color_ptr_[c + 1] += color_ptr_[c];
  active_tets_.resize(active.size());
  {
    std::vector<Index> fill(color_ptr_.begin(), color_ptr_.end() - 1);
    for (std::size_t s = 0; s < active.size(); ++s) active_tets_[fill[tet_color[s]]++] = active[s];
  }
  active_tet_nodes_.resize(active_tets_.size());
  for (std::size_t s = 0; s < active_tets_.size(); ++s) active_tet_nodes_[s] = tets[active_tets_[s]];

  // Block pattern: active node pairs sharing a tet. The active tets of each active node (CSR by
  // counting), then per node the sorted distinct active nodes of those tets.
  std::vector<Index> tets_begin(static_cast<std::size_t>(na) + 1, 0);
  for (const TetIndices& t : active_tet_nodes_)
    for (Index v : t)
      if (const Index a = active_of_node_[v]; a >= 0) ++tets_begin[a + 1];
  for (Index a = 0; a < na; ++a) tets_begin[a + 1] += tets_begin[a];
  // Each entry is 4 * tet slot + the corner that is the node.
  std::vector<Index> tets_of(static_cast<std::size_t>(tets_begin[na]));
  {
    std::vector<Index> fill(tets_begin.begin(), tets_begin.end() - 1);
    for (std::size_t s = 0; s < active_tet_nodes_.size(); ++s)
      for (int i = 0; i < 4; ++i)
        if (const Index a = active_of_node_[active_tet_nodes_[s][i]]; a >= 0)
          tets_of[fill[a]++] = 4 * static_cast<Index>(s) + i;
  }
  // Then, with the row's columns known, the row's entries of those tets: each (tet, corner) is
  // visited once, from the row of its corner. The distinct columns come from a mark per active
  // node (the row that last listed it) and only they are sorted: sorting every corner of every
  // tet at the node (about 96 entries for 15 distinct) and a binary search per tet block cost
  // about 0.5 us per tet.
  block_ptr_.assign(static_cast<std::size_t>(na) + 1, 0);
  diagonal_block_.assign(static_cast<std::size_t>(na), -1);
  block_col_.clear();
  block_col_.reserve(static_cast<std::size_t>(tets_begin[na]));
  std::array<Index, 16> no_entries;
  no_entries.fill(-1);
  tet_block_entry_.assign(active_tets_.size(), no_entries);
  std::vector<Index> listed_by(static_cast<std::size_t>(na), -1);  // the row that last listed the node
  std::vector<Index> block_of(static_cast<std::size_t>(na), -1);   // its block in that row
  std::vector<Index> nb;
  for (Index a = 0; a < na; ++a) {
    nb.clear();
    for (Index k = tets_begin[a]; k < tets_begin[a + 1]; ++k)
      for (Index w : active_tet_nodes_[tets_of[k] / 4])
        if (const Index b = active_of_node_[w]; b >= 0 && listed_by[b] != a) {
          listed_by[b] = a;
          nb.push_back(b);
        }
    std::sort(nb.begin(), nb.end());
    for (Index b : nb) {
      if (b == a) diagonal_block_[a] = static_cast<Index>(block_col_.size());
      block_of[b] = static_cast<Index>(block_col_.size());
      block_col_.push_back(b);
    }
    block_ptr_[a + 1] = static_cast<Index>(block_col_.size());
    SHATTER_CHECK(diagonal_block_[a] >= 0);
    for (Index k = tets_begin[a]; k < tets_begin[a + 1]; ++k) {
      const Index slot = tets_of[k] / 4, i = tets_of[k] % 4;
      const TetIndices& t = active_tet_nodes_[slot];
      for (int j = 0; j < 4; ++j)
        if (const Index b = active_of_node_[t[j]]; b >= 0)
          tet_block_entry_[slot][4 * i + j] = block_entry(a, block_of[b], 0, 0);
    }
  }

  // Eigen matrix with the block layout (column-major; by symmetry column j = row j).
  const Index n = 3 * na;
  const Index nnz = 9 * block_ptr_[na];
  matrix_.resize(n, n);
  matrix_.resizeNonZeros(nnz);
  int* outer = matrix_.outerIndexPtr();
  int* inner = matrix_.innerIndexPtr();
  for (Index a = 0; a < na; ++a) {
    const Index m = block_ptr_[a + 1] - block_ptr_[a];
    for (int i = 0; i < 3; ++i) {
      Index p = 9 * block_ptr_[a] + i * 3 * m;
      outer[3 * a + i] = p;
      for (Index k = block_ptr_[a]; k < block_ptr_[a + 1]; ++k)
        for (int j = 0; j < 3; ++j) inner[p++] = 3 * block_col_[k] + j;
    }
  }
  outer[n] = nnz;
  std::fill(values(), values() + nnz, 0.0);

  for (Index a = 0; a < na; ++a) {
    const AnchorMask mask = anchors_[node_of_active_[a]];
    for (int c = 0; c < 3; ++c)
      if (mask & (1u << c)) held_diagonal_.push_back(block_entry(a, diagonal_block_[a], c, c));
  }
}

Mat3 BlockSparseMatrix::block(Index a, Index k) const {
  Mat3 b;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) b(i, j) = values()[block_entry(a, k, i, j)];
  return b;
}

void BlockSparseMatrix::multiply(const Eigen::VectorXd& x, Eigen::VectorXd& y) const {
  SHATTER_ASSERT(x.size() == size());
  y.resize(size());
  const double* v = values();
  // Block row by block row: each block's three x entries are read once for its three rows, and the
  // rows' sums are three independent chains of additions (one chain per row leaves the CPU waiting
  // on each addition). Each row still adds its products in column order, as a scalar CSR product.
  parallel_for(
      0, num_active(),
      [&](std::int64_t a) {
        const Index k0 = block_ptr_[a], k1 = block_ptr_[a + 1];
        const Index stride = 3 * (k1 - k0);
        const double* r0 = v + 9 * k0;
        const double* r1 = r0 + stride;
        const double* r2 = r1 + stride;
        double s0 = 0, s1 = 0, s2 = 0;
        for (Index k = k0; k < k1; ++k) {
          const Index c = 3 * block_col_[k];
          const Index o = 3 * (k - k0);
          const double x0 = x[c], x1 = x[c + 1], x2 = x[c + 2];
          s0 += r0[o] * x0;
          s1 += r1[o] * x0;
          s2 += r2[o] * x0;
          s0 += r0[o + 1] * x1;
          s1 += r1[o + 1] * x1;
          s2 += r2[o + 1] * x1;
          s0 += r0[o + 2] * x2;
          s1 += r1[o + 2] * x2;
          s2 += r2[o + 2] * x2;
        }
        y[3 * a] = s0;
        y[3 * a + 1] = s1;
        y[3 * a + 2] = s2;
      },
      4096);  // ~0.15 us per block row, once per PCG iteration: parallel only for large systems
}

void BlockSparseMatrix::add_element(Index slot, const Mat12& k) {
  const TetIndices& t = active_tet_nodes_[slot];
  const std::array<Index, 16>& entry = tet_block_entry_[slot];
  double* v = values();
  for (int i = 0; i < 4; ++i) {
    const Index a = active_of_node_[t[i]];
    if (a < 0) continue;
    const Index stride = 3 * (block_ptr_[a + 1] - block_ptr_[a]);
    const AnchorMask mi = anchors_[t[i]];
    for (int j = 0; j < 4; ++j) {
      const Index e = entry[4 * i + j];
      if (e < 0) continue;
      const AnchorMask mj = anchors_[t[j]];
      // k is exactly symmetric: entry (3i + r, 3j + c) is read as (3j + c, 3i + r), down a column
      // of the column-major k.
      if ((mi | mj) == 0) {
        for (int r = 0; r < 3; ++r)
          for (int c = 0; c < 3; ++c) v[e + r * stride + c] += k(3 * j + c, 3 * i + r);
      } else {
        // Held components: their rows and columns are left out (identity set in finish_fill).
        for (int r = 0; r < 3; ++r) {
          if (mi & (1u << r)) continue;
          for (int c = 0; c < 3; ++c)
            if (!(mj & (1u << c))) v[e + r * stride + c] += k(3 * j + c, 3 * i + r);
        }
      }
    }
  }
}

void BlockSparseMatrix::finish_fill() {
  for (Index p : held_diagonal_) values()[p] = 1.0;
}

Mat12 element_stiffness(const FemModel& model, Index e, const Mat34& xe, bool make_psd) {
  // StVK: K = K_material + V (B S B^T) (x) I; the material part is PSD (mu > 0, bulk modulus > 0),
  // the geometric part is PSD iff S is, so the projection removes the negative part of S from it.
  // Corotated: its twist modes' negative eigenvalues clamped (corotated_projected_stiffness).
  if (make_psd && model.model == ModelKind::stvk) return stvk_projected_stiffness(model.lame, model.rest[e], xe);
  if (make_psd && model.model == ModelKind::corotated)
    return corotated_projected_stiffness(model.lame, model.rest[e], xe);
  // The linear model's is constant and positive semi-definite.
  const Mat12 k = tet_stiffness(model.model, model.lame, model.rest[e], xe);
  if (model.model == ModelKind::corotated) return k;  // symmetric to the last bit by construction
  return 0.5 * (k + k.transpose());                   // exactly symmetric: the storage relies on it
}

void assemble_stiffness(const FemModel& model, const std::vector<Vec3>& x, const AssemblyOptions& options,
                        BlockSparseMatrix& matrix, std::span<const Polar> polar) {
  SHATTER_CHECK(static_cast<Index>(x.size()) == matrix.num_nodes());
  if (!polar.empty() && model.model == ModelKind::corotated) {
    SHATTER_CHECK(static_cast<Index>(polar.size()) == model.num_tets());
    matrix.refill([&](Index e) -> Mat12 {
      const Polar& p = polar[static_cast<std::size_t>(e)];
      return options.project_psd ? corotated_projected_stiffness(model.lame, model.rest[e], p)
                                 : corotated_stiffness(model.lame, model.rest[e], p);
    });
    return;
  }
  matrix.refill([&](Index e) -> Mat12 {
    Mat34 xe;
    for (int k = 0; k < 4; ++k) xe.col(k) = x[model.tets[e][k]];
    return element_stiffness(model, e, xe, options.project_psd);
  });
}

}  // namespace shatter
