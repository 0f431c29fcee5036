#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>

#include "shatter/core/parallel.h"
#include "shatter/core/random.h"
#include "shatter/mesh/generate.h"
#include "shatter/mesh/quality.h"
#include "shatter/mesh/topology.h"
#include "shatter/mesh/validate.h"
#include "support/test_support.h"

namespace shatter {
namespace {

TetMesh unit_tet() {
  TetMesh m;
  m.positions = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)};
  m.tets = {{0, 1, 2, 3}};
  return m;
}

TEST(BoxMesh, VolumeAndOrientation) {
  for (auto pattern : {BoxMeshDef::Pattern::six, BoxMeshDef::Pattern::five}) {
    for (double jitter : {0.0, 0.2}) {
      const TetMesh m = make_box_mesh({.min = Vec3(-1, 0, 0),
                                       .max = Vec3(1, 0.5, 3),
                                       .cells = {4, 3, 5},
                                       .pattern = pattern,
                                       .jitter = jitter,
                                       .seed = 7});
      EXPECT_EQ(m.num_nodes(), 5 * 4 * 6);
      EXPECT_EQ(m.num_tets(), 4 * 3 * 5 * (pattern == BoxMeshDef::Pattern::six ? 6 : 5));
      EXPECT_NEAR(total_volume(m), 2.0 * 0.5 * 3.0, 1e-12);
      for (Index e = 0; e < m.num_tets(); ++e) EXPECT_GT(signed_volume(m, e), 0.0);
      const ValidationReport report = validate_mesh(m);
      EXPECT_TRUE(report.problems.empty()) << report.problems.front().message;
      // Conforming: the boundary is exactly the box surface, 2 triangles per boundary cell face.
      const TriSurface s = boundary_surface(m);
      EXPECT_EQ(s.triangles.size(), 2u * 2u * (4 * 3 + 3 * 5 + 4 * 5));
      EXPECT_EQ(connected_components(m).count, 1);
    }
  }
}

TEST(Topology, BoundaryIsClosedAndOutward) {
  const TetMesh m = make_box_mesh({.cells = {3, 3, 3}, .jitter = 0.15});
  const TriSurface s = boundary_surface(m);
  // Divergence theorem: sum over triangles of (centroid . normal) * area / 3 = volume.
  double v = 0;
  for (const TriIndices& t : s.triangles) {
    const Vec3 &a = s.positions[t[0]], &b = s.positions[t[1]], &c = s.positions[t[2]];
    v += a.dot(b.cross(c)) / 6.0;
  }
  EXPECT_NEAR(v, 1.0, 1e-12);
  // Closed 2-manifold: every directed edge appears once, its reverse once.
  std::map<std::pair<Index, Index>, int> edges;
  for (const TriIndices& t : s.triangles)
    for (int k = 0; k < 3; ++k) ++edges[{t[k], t[(k + 1) % 3]}];
  for (const auto& [e, n] : edges) {
    EXPECT_EQ(n, 1);
    EXPECT_EQ(edges.count({e.second, e.first}), 1u);
  }
}

TEST(Topology, NeighborsAreSymmetric) {
  const TetMesh m = make_box_mesh({.cells = {2, 2, 2}});
  const TetFaces f = compute_faces(m);
  for (Index e = 0; e < m.num_tets(); ++e)
    for (int k = 0; k < 4; ++k) {
      const Index n = f.neighbor(e, k);
      if (n < 0) continue;
      bool back = false;
      for (int l = 0; l < 4; ++l) back |= f.neighbor(n, l) == e;
      EXPECT_TRUE(back);
    }
  EXPECT_TRUE(f.overshared.empty());
}

// compute_faces against the definition: faces sorted by their sorted corners, each face's tets in
// (tet, local) order, seen from the first. On shuffled tets and node numbers, with repeated tets
// (faces of more than two tets) and degenerate tets (a repeated node). The last mesh (16.8k tets) is
// listed in blocks of nodes on 2 and 3 threads, and whole on 1.
TEST(Topology, FacesMatchASortOfEveryFace) {
  const int saved_threads = num_threads();
  for (int c = 1; c <= 5; ++c) {
    const std::array<Index, 3> cells = c < 5 ? std::array<Index, 3>{c + 1, c, 3} : std::array<Index, 3>{24, 14, 10};
    TetMesh m = make_box_mesh({.cells = cells, .pattern = BoxMeshDef::Pattern::five, .jitter = 0.2});
    Random rng(static_cast<std::uint64_t>(c));
    for (std::size_t i = m.tets.size() - 1; i > 0; --i) std::swap(m.tets[i], m.tets[rng.next_u64() % (i + 1)]);
    std::vector<Index> renumber(m.positions.size());
    std::iota(renumber.begin(), renumber.end(), Index(0));
    for (std::size_t i = renumber.size() - 1; i > 0; --i) std::swap(renumber[i], renumber[rng.next_u64() % (i + 1)]);
    for (TetIndices& t : m.tets)
      for (Index& v : t) v = renumber[static_cast<std::size_t>(v)];
    for (int i = 0; i < 4; ++i) m.tets.push_back(m.tets[static_cast<std::size_t>(3 * i)]);
    m.tets.push_back({m.tets[0][0], m.tets[0][0], m.tets[0][1], m.tets[0][2]});
    m.tets.push_back({m.tets[1][3], m.tets[1][1], m.tets[1][1], m.tets[1][1]});

    std::map<std::array<Index, 3>, std::vector<std::pair<Index, int>>> by_key;
    for (Index e = 0; e < m.num_tets(); ++e)
      for (int k = 0; k < 4; ++k) {
        std::array<Index, 3> key = {m.tets[e][kTetFaces[k][0]], m.tets[e][kTetFaces[k][1]], m.tets[e][kTetFaces[k][2]]};
        std::sort(key.begin(), key.end());
        by_key[key].push_back({e, k});
      }
    for (int threads = 1; threads <= (c < 5 ? 1 : 3); ++threads) {
      set_num_threads(threads);
      const TetFaces f = compute_faces(m);
      ASSERT_EQ(f.faces.size(), by_key.size());
      std::size_t overshared = 0;
      Index i = 0;
      for (const auto& [key, sides] : by_key) {
        const auto [e0, k0] = sides[0];
        const TriIndices seen = {m.tets[e0][kTetFaces[k0][0]], m.tets[e0][kTetFaces[k0][1]],
                                 m.tets[e0][kTetFaces[k0][2]]};
        EXPECT_EQ(f.faces[i], seen);
        EXPECT_EQ(f.face_tets[i][0], e0);
        EXPECT_EQ(f.face_tets[i][1], sides.size() > 1 ? sides[1].first : -1);
        for (std::size_t s = 0; s < sides.size(); ++s) {
          EXPECT_EQ(f.tet_faces[sides[s].first][sides[s].second], i);
          if (s >= 2) {
            ASSERT_LT(overshared, f.overshared.size());
            EXPECT_EQ(f.overshared[overshared], (std::array<Index, 2>{i, sides[s].first}));
            ++overshared;
          }
        }
        ++i;
      }
      EXPECT_EQ(overshared, f.overshared.size());
      EXPECT_GT(overshared, 0u);
    }
  }
  set_num_threads(saved_threads);
}

// The local query (node incidence) finds the same neighbour as the global face sort, on both box
// patterns and at the boundary (-1).
TEST(Topology, FaceNeighborMatchesTheFaceSort) {
  for (auto pattern : {BoxMeshDef::Pattern::six, BoxMeshDef::Pattern::five}) {
    const TetMesh m = make_box_mesh({.cells = {4, 3, 3}, .pattern = pattern, .jitter = 0.2});
    const TetFaces f = compute_faces(m);
    const NodeTets incidence = node_tets(m);
    int boundary = 0;
    for (Index e = 0; e < m.num_tets(); ++e)
      for (int k = 0; k < 4; ++k) {
        EXPECT_EQ(face_neighbor(m, incidence, e, k), f.neighbor(e, k)) << "tet " << e << " face " << k;
        boundary += f.neighbor(e, k) < 0;
      }
    EXPECT_GT(boundary, 0);
  }
}

// Incidence for some nodes: their lists are node_tets', the others' are empty, and a face query
// whose three nodes are wanted gives the same neighbour.
TEST(Topology, NodeTetsOfSomeNodesMatchTheWholeIncidence) {
  const TetMesh m = make_box_mesh({.cells = {4, 3, 3}, .pattern = BoxMeshDef::Pattern::five, .jitter = 0.2});
  const NodeTets all = node_tets(m);
  std::vector<char> wanted(m.positions.size(), 0);
  for (std::size_t v = 0; v < wanted.size(); v += 3) wanted[v] = 1;
  const NodeTets some = node_tets(m, wanted);
  ASSERT_EQ(some.begin.size(), all.begin.size());
  std::size_t listed = 0;
  for (Index v = 0; v < m.num_nodes(); ++v) {
    const auto a = all.of(v);
    const auto s = some.of(v);
    if (wanted[v] != 0) {
      EXPECT_TRUE(std::equal(a.begin(), a.end(), s.begin(), s.end())) << "node " << v;
      listed += s.size();
    } else {
      EXPECT_TRUE(s.empty()) << "node " << v;
    }
  }
  EXPECT_EQ(some.tets.size(), listed);
  int queried = 0;
  for (Index e = 0; e < m.num_tets(); ++e)
    for (int k = 0; k < 4; ++k) {
      const TetIndices& t = m.tets[e];
      if (wanted[t[kTetFaces[k][0]]] == 0 || wanted[t[kTetFaces[k][1]]] == 0 || wanted[t[kTetFaces[k][2]]] == 0)
        continue;
      EXPECT_EQ(face_neighbor(m, some, e, k), face_neighbor(m, all, e, k));
      ++queried;
    }
  EXPECT_GT(queried, 0);
}

TEST(Components, SeparatesDisjointParts) {
  TetMesh m = unit_tet();
  m.positions.push_back(Vec3(5, 0, 0));
  m.positions.push_back(Vec3(6, 0, 0));
  m.positions.push_back(Vec3(5, 1, 0));
  m.positions.push_back(Vec3(5, 0, 1));
  m.tets.push_back({4, 5, 6, 7});
  const Components c = connected_components(m);
  EXPECT_EQ(c.count, 2);
  EXPECT_EQ(c.tet_component[0], 0);
  EXPECT_EQ(c.tet_component[1], 1);
}

TEST(Validate, FindsEveryProblemWithIds) {
  TetMesh m = unit_tet();
  m.node_ids = {10, 20, 30, 40};
  m.tet_ids = {100};
  m.positions.push_back(Vec3(std::nan(""), 0, 0));  // unreferenced and NaN
  m.node_ids.push_back(50);
  m.tets.push_back({0, 1, 2, 9});  // out of range
  m.tet_ids.push_back(101);
  m.tets.push_back({0, 1, 1, 3});  // repeated
  m.tet_ids.push_back(102);
  m.tets.push_back({0, 2, 1, 3});  // inverted
  m.tet_ids.push_back(103);
  const ValidationReport r = validate_mesh(m);
  EXPECT_EQ(r.count(MeshProblemKind::node_not_finite), 1u);
  EXPECT_EQ(r.count(MeshProblemKind::index_out_of_range), 1u);
  EXPECT_EQ(r.count(MeshProblemKind::repeated_node), 1u);
  EXPECT_EQ(r.count(MeshProblemKind::inverted_tet), 1u);
  EXPECT_EQ(r.count(MeshProblemKind::unreferenced_node), 1u);
  bool named = false;
  for (const MeshProblem& p : r.problems) named |= p.message.find("tet 101") != std::string::npos;
  EXPECT_TRUE(named);
  EXPECT_TRUE(r.has_errors());
}

TEST(Validate, RepairsOrientationWithWarning) {
  TetMesh m = unit_tet();
  std::swap(m.tets[0][0], m.tets[0][1]);
  test::ExpectWarnings w;
  ASSERT_OK(check_and_repair(m, "x.msh"));
  EXPECT_GT(signed_volume(m, 0), 0);
  ASSERT_EQ(w.messages().size(), 1u);
  EXPECT_NE(w.messages()[0].find("reoriented 1"), std::string::npos);
}

TEST(Validate, DegenerateAndOversharedAreErrors) {
  TetMesh m = unit_tet();
  m.positions.push_back(Vec3(0.5, 0.5, 0));  // coplanar with face 0-1-2
  m.tets.push_back({0, 1, 2, 4});
  EXPECT_EQ(validate_mesh(m).count(MeshProblemKind::degenerate_tet), 1u);
  TetMesh o = unit_tet();
  o.positions.push_back(Vec3(0, 0, -1));
  o.positions.push_back(Vec3(0.2, 0.2, -2));
  o.tets.push_back({0, 2, 1, 4});
  o.tets.push_back({0, 2, 1, 5});
  EXPECT_EQ(validate_mesh(o).count(MeshProblemKind::overshared_face), 1u);
}

TEST(Quality, RegularTetIsIdeal) {
  Mat34 x;
  x.col(0) = Vec3(1, 1, 1);
  x.col(1) = Vec3(1, -1, -1);
  x.col(2) = Vec3(-1, 1, -1);
  x.col(3) = Vec3(-1, -1, 1);
  EXPECT_NEAR(aspect_ratio(x), 1.0, 1e-12);
  for (double a : dihedral_angles(x)) EXPECT_NEAR(a, std::acos(1.0 / 3.0), 1e-12);
  const auto right = dihedral_angles(unit_tet().corners(0));
  // Right-corner tet: three 90-degree angles at the axes' edges.
  EXPECT_NEAR(right[0], M_PI / 2, 1e-12);
  EXPECT_NEAR(right[1], M_PI / 2, 1e-12);
  EXPECT_NEAR(right[2], M_PI / 2, 1e-12);
}

TEST(ExtractTets, KeepsIdsAndSets) {
  TetMesh m = make_box_mesh({.cells = {2, 1, 1}});
  m.tet_sets["right"] = {6, 7};
  const TetMesh sub = extract_tets(m, {6, 7, 8});
  EXPECT_EQ(sub.num_tets(), 3);
  EXPECT_EQ(sub.tet_sets.at("right"), (std::vector<Index>{0, 1}));
  for (Index e = 0; e < 3; ++e) EXPECT_EQ(sub.corners(e), m.corners(6 + e));
}

}  // namespace
}  // namespace shatter
