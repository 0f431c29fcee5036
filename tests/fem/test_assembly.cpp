// The block pattern and the assembled stiffness against a brute-force dense assembly, and the
// refill's bits on several thread counts.
#include "shatter/fem/assembly.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <algorithm>
#include <set>
#include <vector>

#include "shatter/core/parallel.h"
#include "shatter/core/random.h"
#include "shatter/fem/fem_model.h"
#include "shatter/fem/material.h"
#include "shatter/fem/tet_kernels.h"
#include "shatter/mesh/generate.h"

namespace shatter {
namespace {

// A jittered box with some nodes held whole, some in one or two components, the rest free, and
// (with `loose`) a node that no tet uses.
struct Case {
  TetMesh mesh;
  std::vector<AnchorMask> anchors;
};

Case make_case(std::uint64_t seed, bool loose) {
  Random rng(seed);
  Case c;
  c.mesh = make_box_mesh({.max = Vec3(0.3, 0.2, 0.1), .cells = {5, 4, 2}, .jitter = 0.2, .seed = seed});
  if (loose) c.mesh.positions.push_back(Vec3(1, 1, 1));
  c.anchors.assign(c.mesh.positions.size(), anchor_none);
  for (AnchorMask& a : c.anchors) {
    const double u = rng.uniform(0, 1);
    a = u < 0.3 ? anchor_all : u < 0.4 ? static_cast<AnchorMask>(1 + rng.below(6)) : anchor_none;
  }
  return c;
}

TEST(BlockSparseMatrix, PatternMatchesTheTetsNodePairs) {
  for (std::uint64_t seed : {1, 2, 3}) {
    const Case c = make_case(seed, seed == 2);
    const auto nn = static_cast<Index>(c.mesh.positions.size());
    const BlockSparseMatrix m(nn, c.mesh.tets, c.anchors);
    // Active nodes: used by a tet and not held whole, in node order.
    std::vector<char> used(static_cast<std::size_t>(nn), 0);
    for (const TetIndices& t : c.mesh.tets)
      for (Index v : t) used[v] = 1;
    std::vector<Index> expected_active;
    for (Index v = 0; v < nn; ++v)
      if (used[v] && c.anchors[v] != anchor_all) expected_active.push_back(v);
    ASSERT_EQ(m.node_of_active(), expected_active) << "seed " << seed;
    const std::vector<Index>& active_of = m.active_of_node();
    // Each row's blocks: exactly the active nodes sharing a tet with it, sorted, the diagonal among them.
    std::vector<std::set<Index>> neighbours(expected_active.size());
    std::vector<Index> active_tets;
    for (Index e = 0; e < static_cast<Index>(c.mesh.tets.size()); ++e) {
      const TetIndices& t = c.mesh.tets[e];
      bool any = false;
      for (Index v : t)
        for (Index w : t)
          if (active_of[v] >= 0 && active_of[w] >= 0) {
            neighbours[active_of[v]].insert(active_of[w]);
            any = true;
          }
      if (any) active_tets.push_back(e);
    }
    for (Index a = 0; a < m.num_active(); ++a) {
      const std::vector<Index> row(m.block_col().begin() + m.block_ptr()[a],
                                   m.block_col().begin() + m.block_ptr()[a + 1]);
      EXPECT_EQ(row, std::vector<Index>(neighbours[a].begin(), neighbours[a].end())) << "seed " << seed << " row " << a;
      EXPECT_EQ(m.block_col()[m.diagonal_block(a)], a);
    }
    // The colouring: every active tet once, no two tets of a colour sharing a node.
    std::vector<Index> sorted = m.active_tets();
    std::sort(sorted.begin(), sorted.end());
    EXPECT_EQ(sorted, active_tets);
    for (Index k = 0; k < m.num_colors(); ++k) {
      std::set<Index> nodes;
      for (Index s = m.color_ptr()[k]; s < m.color_ptr()[k + 1]; ++s)
        for (Index v : c.mesh.tets[m.active_tets()[s]]) EXPECT_TRUE(nodes.insert(v).second) << "colour " << k;
    }
  }
}

TEST(BlockSparseMatrix, AssembledStiffnessMatchesADenseAssembly) {
  for (std::uint64_t seed : {4, 5}) {
    const Case c = make_case(seed, false);
    Random rng(seed);
    const FemModel model = make_fem_model(c.mesh, *material_preset("modelling_clay"), ModelKind::stvk);
    std::vector<Vec3> x = c.mesh.positions;
    for (Vec3& p : x) p += 0.01 * rng.uniform_vec3(-1, 1);
    BlockSparseMatrix m(static_cast<Index>(x.size()), c.mesh.tets, c.anchors);
    assemble_stiffness(model, x, AssemblyOptions{}, m);
    // Dense reference: every element matrix added into the free rows and columns of its active
    // corners; held components of active nodes get a unit diagonal.
    const std::vector<Index>& active_of = m.active_of_node();
    Eigen::MatrixXd dense = Eigen::MatrixXd::Zero(m.size(), m.size());
    for (Index e = 0; e < static_cast<Index>(c.mesh.tets.size()); ++e) {
      const TetIndices& t = c.mesh.tets[e];
      Mat34 xe;
      for (int i = 0; i < 4; ++i) xe.col(i) = x[t[i]];
      const Mat12 k = element_stiffness(model, e, xe, true);
      for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) {
          const Index a = active_of[t[i]], b = active_of[t[j]];
          if (a < 0 || b < 0) continue;
          for (int r = 0; r < 3; ++r)
            for (int q = 0; q < 3; ++q)
              if (!(c.anchors[t[i]] & (1u << r)) && !(c.anchors[t[j]] & (1u << q)))
                dense(3 * a + r, 3 * b + q) += k(3 * i + r, 3 * j + q);
        }
    }
    for (Index a = 0; a < m.num_active(); ++a)
      for (int r = 0; r < 3; ++r)
        if (c.anchors[m.node_of_active()[a]] & (1u << r)) dense(3 * a + r, 3 * a + r) = 1.0;
    const Eigen::MatrixXd assembled = Eigen::MatrixXd(m.matrix());
    EXPECT_LE((assembled - dense).cwiseAbs().maxCoeff(), 1e-12 * dense.cwiseAbs().maxCoeff()) << "seed " << seed;
  }
}

// The refill's values on 1, 2 and 3 threads, which must be the same bits.
std::vector<std::vector<double>> refill_on_thread_counts(const TetMesh& mesh, const std::vector<AnchorMask>& anchors,
                                                         bool colour_by_colour) {
  Random rng(11);
  const FemModel model = make_fem_model(mesh, *material_preset("modelling_clay"), ModelKind::stvk);
  std::vector<Vec3> x = mesh.positions;
  for (Vec3& p : x) p += 0.02 * rng.uniform_vec3(-1, 1);
  const int saved = num_threads();
  std::vector<std::vector<double>> values;
  for (int threads : {1, 2, 3}) {
    set_num_threads(threads);
    BlockSparseMatrix m(static_cast<Index>(x.size()), mesh.tets, anchors);
    // Enough tets to go parallel; colours of a few hundred tets go side by side, smaller ones
    // through the buffer.
    EXPECT_GE(m.active_tets().size(), 1024U);
    const auto mean_colour = static_cast<Index>(m.active_tets().size()) / m.num_colors();
    EXPECT_EQ(mean_colour >= 256, colour_by_colour) << mean_colour << " tets per colour";
    assemble_stiffness(model, x, AssemblyOptions{}, m);
    values.emplace_back(m.values(), m.values() + m.num_values());
  }
  set_num_threads(saved);
  return values;
}

TEST(BlockSparseMatrix, RefillGivesTheSameBitsOnAnyThreadCount) {
  const TetMesh mesh = make_box_mesh({.max = Vec3(1, 0.6, 0.4), .cells = {24, 12, 8}, .jitter = 0.2, .seed = 9});
  std::vector<AnchorMask> anchors(mesh.positions.size(), anchor_none);
  for (std::size_t v = 0; v < anchors.size(); ++v)
    if (mesh.positions[v].x() == 0.0) anchors[v] = anchor_all;
  const auto values = refill_on_thread_counts(mesh, anchors, true);
  ASSERT_EQ(values.size(), 3U);
  EXPECT_TRUE(values[0] == values[1]);
  EXPECT_TRUE(values[0] == values[2]);
}

// Colours too small to go side by side: the element matrices go through the buffer and are added
// in order, with held, partly held and free nodes.
TEST(BlockSparseMatrix, BufferedRefillGivesTheSameBitsOnAnyThreadCount) {
  Case c;
  c.mesh = make_box_mesh({.max = Vec3(0.5, 0.3, 0.3), .cells = {12, 8, 6}, .jitter = 0.2, .seed = 5});
  Random rng(6);
  c.anchors.assign(c.mesh.positions.size(), anchor_none);
  for (AnchorMask& a : c.anchors) {
    const double u = rng.uniform(0, 1);
    a = u < 0.1 ? anchor_all : u < 0.3 ? static_cast<AnchorMask>(1 + rng.below(6)) : anchor_none;
  }
  const auto values = refill_on_thread_counts(c.mesh, c.anchors, false);
  ASSERT_EQ(values.size(), 3U);
  EXPECT_TRUE(values[0] == values[1]);
  EXPECT_TRUE(values[0] == values[2]);
}

// A corotated refill from the tets' polar decompositions, found beforehand, gives the bits of one
// that finds them itself: exact and projected, at a state that compresses some tets.
TEST(BlockSparseMatrix, CorotatedRefillFromKnownPolarDecompositionsGivesTheSameBits) {
  const Case c = make_case(21, false);
  Random rng(22);
  const FemModel model = make_fem_model(c.mesh, *material_preset("modelling_clay"), ModelKind::corotated);
  std::vector<Vec3> x = c.mesh.positions;
  for (Vec3& p : x) p += 0.02 * rng.uniform_vec3(-1, 1);
  std::vector<Polar> polar(c.mesh.tets.size());
  for (std::size_t e = 0; e < polar.size(); ++e) {
    Mat34 xe;
    for (int k = 0; k < 4; ++k) xe.col(k) = x[c.mesh.tets[e][k]];
    polar[e] = polar_decomposition(deformation_gradient(model.rest[e], xe));
  }
  for (bool projected : {false, true}) {
    BlockSparseMatrix found(static_cast<Index>(x.size()), c.mesh.tets, c.anchors);
    BlockSparseMatrix given(static_cast<Index>(x.size()), c.mesh.tets, c.anchors);
    assemble_stiffness(model, x, AssemblyOptions{.project_psd = projected}, found);
    assemble_stiffness(model, x, AssemblyOptions{.project_psd = projected}, given, polar);
    EXPECT_TRUE(std::equal(found.values(), found.values() + found.num_values(), given.values())) << projected;
  }
  // The given decompositions are the ones read: unrotated ones give another matrix.
  std::vector<Polar> unrotated = polar;
  for (Polar& p : unrotated) p.R = Mat3::Identity();
  BlockSparseMatrix found(static_cast<Index>(x.size()), c.mesh.tets, c.anchors);
  BlockSparseMatrix given(static_cast<Index>(x.size()), c.mesh.tets, c.anchors);
  assemble_stiffness(model, x, AssemblyOptions{.project_psd = false}, found);
  assemble_stiffness(model, x, AssemblyOptions{.project_psd = false}, given, unrotated);
  EXPECT_FALSE(std::equal(found.values(), found.values() + found.num_values(), given.values()));
}

}  // namespace
}  // namespace shatter
