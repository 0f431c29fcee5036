// Sparse stiffness assembly for the static solver (docs/method.md §2.3, the paper's eq. 26-28): the
// 3x3-block pattern of the nodes with a free component, built once per (mesh, anchors) and
// refilled in place at every Newton iteration, deterministically on any thread count.
#pragma once

#include <Eigen/SparseCore>

#include <cstdint>
#include <span>
#include <vector>

#include "shatter/core/parallel.h"
#include "shatter/core/types.h"
#include "shatter/fem/constitutive.h"

namespace shatter {

struct FemModel;

/// Held (Dirichlet) components of a node: bit c (0 = x, 1 = y, 2 = z) set = component c held.
/// 7 holds the node; 2 alone is a roller on a plane y = const.
using AnchorMask = std::uint8_t;
inline constexpr AnchorMask anchor_none = 0;  ///< no component held
inline constexpr AnchorMask anchor_all = 7;   ///< all three components held
/// Whether component c (0 = x, 1 = y, 2 = z) is held in mask m.
constexpr bool held(AnchorMask m, int c) { return (m & (1u << c)) != 0; }

/// Symmetric stiffness over the DOFs of the *active* nodes: nodes that belong to a tet and have at
/// least one free component. DOF 3a + c is component c of active node a. Fully held nodes and
/// nodes in no tet are eliminated. A held component of a partly held node (roller, symmetry plane)
/// stays as a decoupled identity row and column whose right-hand side is zero, so that every block
/// stays 3x3 and the solution there is exactly 0.
///
/// Storage: one Eigen::SparseMatrix (column-major, both triangles). Being symmetric, its columns are
/// also its rows, so it is at the same time a scalar CSR matrix. Its value array is laid out by
/// blocks: block row a (= scalar rows 3a..3a+2) holds m_a blocks, sorted by block column; scalar
/// row 3a+i is the i-th run of 3 m_a values. The block-CSR view (block_ptr, block_col,
/// block_entry) indexes that same array: nothing is copied between the two forms.
class BlockSparseMatrix {
 public:
  /// An empty matrix (no nodes, no pattern).
  BlockSparseMatrix() = default;
  /// Pattern of the stiffness of `tets` over `num_nodes` nodes; `anchors`: held components per node
  /// (#nodes, or empty = nothing held). Values start at zero.
  BlockSparseMatrix(Index num_nodes, const std::vector<TetIndices>& tets, const std::vector<AnchorMask>& anchors);

  /// Nodes of the mesh the pattern was built for.
  [[nodiscard]] Index num_nodes() const { return static_cast<Index>(active_of_node_.size()); }
  /// Active nodes: in some tet, with at least one free component.
  [[nodiscard]] Index num_active() const { return static_cast<Index>(node_of_active_.size()); }
  /// Number of scalar rows (3 per active node).
  [[nodiscard]] Index size() const { return 3 * num_active(); }
  /// Number of stored 3x3 blocks.
  [[nodiscard]] Index num_blocks() const { return static_cast<Index>(block_col_.size()); }
  /// Unique per built pattern; symbolic factorizations are keyed on it.
  [[nodiscard]] std::uint64_t pattern_id() const { return pattern_id_; }

  /// Active index of each node, -1 if eliminated (#nodes).
  [[nodiscard]] const std::vector<Index>& active_of_node() const { return active_of_node_; }
  /// Node of each active index (#active).
  [[nodiscard]] const std::vector<Index>& node_of_active() const { return node_of_active_; }
  /// Held components per node (#nodes).
  [[nodiscard]] const std::vector<AnchorMask>& anchors() const { return anchors_; }
  /// True when some active node has a held component (identity rows present).
  [[nodiscard]] bool has_partial_anchors() const { return !held_diagonal_.empty(); }

  /// Tets with at least one active corner, grouped by colour: no two tets of one colour share a
  /// node, colour c is active_tets()[color_ptr()[c] .. color_ptr()[c+1]).
  [[nodiscard]] const std::vector<Index>& active_tets() const { return active_tets_; }
  /// Start of each colour in active_tets() (#colours + 1).
  [[nodiscard]] const std::vector<Index>& color_ptr() const { return color_ptr_; }
  /// Number of colours.
  [[nodiscard]] Index num_colors() const { return static_cast<Index>(color_ptr_.size()) - 1; }

  /// Block CSR: block row a has blocks block_ptr()[a] .. block_ptr()[a+1] (#active + 1).
  [[nodiscard]] const std::vector<Index>& block_ptr() const { return block_ptr_; }
  /// Block column of each block, sorted within its row; the diagonal block is among them (#blocks).
  [[nodiscard]] const std::vector<Index>& block_col() const { return block_col_; }
  /// Position in values() of entry (i, j) of block k of block row a: A(3a+i, 3 block_col[k] + j).
  [[nodiscard]] Index block_entry(Index a, Index k, int i, int j) const {
    const Index p0 = block_ptr_[a];
    return 9 * p0 + i * 3 * (block_ptr_[a + 1] - p0) + 3 * (k - p0) + j;
  }
  /// Block k of block row a as a 3x3 matrix.
  [[nodiscard]] Mat3 block(Index a, Index k) const;
  /// Index of the diagonal block of block row a.
  [[nodiscard]] Index diagonal_block(Index a) const { return diagonal_block_[a]; }

  /// The matrix in Eigen's form (size() x size(), both triangles).
  [[nodiscard]] const Eigen::SparseMatrix<double>& matrix() const { return matrix_; }
  /// The stored values, laid out by blocks as described above (num_values()).
  [[nodiscard]] const double* values() const { return matrix_.valuePtr(); }
  [[nodiscard]] double* values() { return matrix_.valuePtr(); }
  /// Number of stored values (9 per block).
  [[nodiscard]] Index num_values() const { return static_cast<Index>(matrix_.nonZeros()); }

  /// y = A x (x, y: size()); rows in parallel, each summed in a fixed order.
  void multiply(const Eigen::VectorXd& x, Eigen::VectorXd& y) const;

  /// Refill the values: element_matrix(tet) (a symmetric 12x12, ordering [x0;x1;x2;x3]) of every
  /// active tet is added into its blocks in active_tets() order, so every entry sums its tets in
  /// the same order on any thread count; then the held components are held. Serially each matrix
  /// is added as soon as it is computed; on threads colour by colour (the tets of a colour share no
  /// node) when the colours are large, else through a buffer filled by one parallel loop.
  /// element_matrix must be safe to call concurrently, and its matrices exactly symmetric (each is
  /// read down its columns).
  template <class ElementMatrix>
  void refill(ElementMatrix&& element_matrix);

 private:
  /// Active tets from which a refill goes parallel (~0.5-1 us per element matrix: about half a
  /// millisecond of work).
  static constexpr std::int64_t kMinParallelRefill = 1024;
  /// Mean tets per colour from which a refill goes colour by colour: short parallel regions cost
  /// more than they save when other programs share the cores.
  static constexpr std::int64_t kMinParallelColour = 256;
  void add_element(Index slot, const Mat12& k);
  void finish_fill();

  std::uint64_t pattern_id_ = 0;
  std::vector<Index> active_of_node_;
  std::vector<Index> node_of_active_;
  std::vector<AnchorMask> anchors_;
  std::vector<Index> active_tets_;
  std::vector<Index> color_ptr_;
  std::vector<TetIndices> active_tet_nodes_;  ///< corners of each active tet, in active_tets order
  /// Per active tet and corner pair (i, j), position of entry (0,0) of block (i, j) in values(),
  /// -1 if a corner is eliminated (#active tets x 16).
  std::vector<std::array<Index, 16>> tet_block_entry_;
  std::vector<Index> block_ptr_;
  std::vector<Index> block_col_;
  std::vector<Index> diagonal_block_;
  std::vector<Index> held_diagonal_;   ///< positions in values() of held components' diagonals
  std::vector<Mat12> element_buffer_;  ///< a refill's element matrices, when it goes through one
  Eigen::SparseMatrix<double> matrix_;
};

/// Options of the stiffness assembly.
struct AssemblyOptions {
  /// Make each element matrix positive semi-definite (docs/method.md §2.3), so that Newton's system
  /// stays SPD when elements are compressed. linear: already PSD. stvk: the negative part of the
  /// 2nd Piola-Kirchhoff stress S is removed from the geometric stiffness V (B S B^T) (x) I (the
  /// material part is PSD): a 3x3 eigenproblem instead of a 12x12 one, and no change at all where
  /// S is PSD. corotated: the negative eigenvalues of its Hessian in F clamped (a 3x3 eigenproblem
  /// where one may be negative, corotated_projected_stiffness).
  bool project_psd = true;
};

/// Element stiffness of tet e at corners xe (3x4, m), symmetrised, made PSD if asked (above).
Mat12 element_stiffness(const FemModel& model, Index e, const Mat34& xe, bool make_psd);

/// Refill `matrix` (whose pattern was built for model.tets) with the stiffness dF/dx at the
/// deformed positions x (m, #nodes). Element matrices are symmetrised. A corotated model may pass
/// `polar`, the polar decomposition of each tet's F at x (#tets; only the matrix's active tets are
/// read), found already for the forces: the same bits without finding it again.
void assemble_stiffness(const FemModel& model, const std::vector<Vec3>& x, const AssemblyOptions& options,
                        BlockSparseMatrix& matrix, std::span<const Polar> polar = {});

// ---------------------------------------------------------------------------------------------

template <class ElementMatrix>
void BlockSparseMatrix::refill(ElementMatrix&& element_matrix) {
  std::fill(values(), values() + num_values(), 0.0);
  const auto n = static_cast<std::int64_t>(active_tets_.size());
  const auto add = [&](std::int64_t s) {
    add_element(static_cast<Index>(s), element_matrix(active_tets_[static_cast<std::size_t>(s)]));
  };
  if (num_threads() < 2 || n < kMinParallelRefill || detail::in_parallel_region()) {
    // Each element matrix added as soon as it is computed, while it is in the cache.
    for (std::int64_t s = 0; s < n; ++s) add(s);
  } else if (n >= kMinParallelColour * num_colors()) {
    // Colour by colour, the tets of a colour side by side: they share no node, so they write
    // disjoint blocks, and every entry still sums its tets in active_tets() order. (Through a
    // buffer of every element matrix, 1.2 KB per tet, a whole-mesh refill went out to memory and
    // back.)
    for (Index c = 0; c < num_colors(); ++c)
      parallel_for(color_ptr_[c], color_ptr_[c + 1], [&](std::int64_t s) { add(s); }, kMinParallelColour);
  } else {
    // Colours too small for a parallel region each: the element matrices in one parallel loop into
    // a buffer (a few MB, in the cache), then added in order.
    element_buffer_.resize(active_tets_.size());
    parallel_for(
        0, n,
        [&](std::int64_t s) {
          element_buffer_[static_cast<std::size_t>(s)] = element_matrix(active_tets_[static_cast<std::size_t>(s)]);
        },
        kMinParallelRefill);
    for (std::size_t s = 0; s < active_tets_.size(); ++s) add_element(static_cast<Index>(s), element_buffer_[s]);
  }
  finish_fill();
}

}  // namespace shatter
