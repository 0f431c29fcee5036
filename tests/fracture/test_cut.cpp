// Cutting: splitting tets along a plane, node duplication, conservation and validity under random
// sequences of cuts.
#include <gtest/gtest.h>

#include <cmath>

#include "fracture_checks.h"
#include "shatter/core/random.h"
#include "shatter/fracture/cut.h"
#include "shatter/fracture/fragments.h"
#include "shatter/mesh/generate.h"
#include "shatter/mesh/topology.h"
#include "support/test_support.h"

namespace shatter {
namespace {

TetMesh one_tet() {
  TetMesh m;
  m.positions = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)};
  m.tets = {{0, 1, 2, 3}};
  return m;
}

std::vector<Index> all_tets(const TetMesh& m) {
  std::vector<Index> r(m.tets.size());
  for (Index e = 0; e < m.num_tets(); ++e) r[e] = e;
  return r;
}

double side_volume(const CutResult& r, int side) {
  double v = 0;
  for (Index e = 0; e < r.mesh.num_tets(); ++e)
    if (r.tet_side[e] == side) v += signed_volume(r.mesh, e);
  return v;
}

TEST(SplitTet, EachCrossingCase) {
  struct Case {
    Vec3 point, normal;
    int pieces;
  };
  // 1|3 corners: tet + prism (1 + 3); 2|2: two prisms (3 + 3); through a corner: tet + pyramid
  // (1 + 2); through two corners: 1 + 1.
  const Case cases[] = {
      {Vec3(0.3, 0, 0), Vec3(1, 0, 0), 4},
      {Vec3(0.25, 0.25, 0.2), Vec3(1, 1, 0).normalized(), 6},
      {Vec3(0, 0, 0), Vec3(1, -1, 0.3).normalized(), 3},
      {Vec3(0.5, 0.5, 0), Vec3(1, -1, 0).normalized(), 2},
  };
  for (const Case& c : cases) {
    const TetMesh m = one_tet();
    const CutResult r = split_along_plane(m, {.point = c.point, .normal = c.normal.normalized()}, {0});
    EXPECT_EQ(r.mesh.num_tets(), c.pieces) << c.normal.transpose();
    EXPECT_NEAR(total_volume(r.mesh), 1.0 / 6.0, 1e-15);
    EXPECT_TRUE(test::mesh_is_valid(r.mesh, 1e-3 / 6.0));
    // Each piece lies on its side of the plane.
    for (Index e = 0; e < r.mesh.num_tets(); ++e)
      for (Index v : r.mesh.tets[e]) {
        const double d = c.normal.normalized().dot(r.mesh.positions[v] - c.point) * r.tet_side[e];
        EXPECT_GT(d, -1e-12);
      }
  }
  // Two corners on the plane, the other two on either side: 2 tets.
  const TetMesh m = one_tet();
  const Vec3 n = Vec3(0, 1, -1).normalized();
  const CutResult r = split_along_plane(m, {.point = Vec3(0, 0, 0), .normal = n}, {0});
  EXPECT_EQ(r.mesh.num_tets(), 2);
  EXPECT_NEAR(side_volume(r, 1) + side_volume(r, -1), 1.0 / 6.0, 1e-15);
}

TEST(SplitTet, SnapsNearlyOnPlaneNodes) {
  // The plane passes 1e-4 from corner 1: no sliver, the corner counts as on the plane.
  const TetMesh m = one_tet();
  const CutResult r = split_along_plane(m, {.point = Vec3(1 - 1e-4, 0, 0), .normal = Vec3(1, 0, 0)}, {0});
  EXPECT_EQ(r.mesh.num_tets(), 1);
  EXPECT_EQ(r.tet_side[0], -1);
  const CutResult off = split_along_plane(m, {.point = Vec3(1 - 1e-4, 0, 0), .normal = Vec3(1, 0, 0)}, {0},
                                          {.snap_fraction = 0.0, .min_volume_fraction = 0.0});
  EXPECT_EQ(off.mesh.num_tets(), 4);
}

TEST(Cut, BarCutThroughGivesTwoExactHalves) {
  for (auto pattern : {BoxMeshDef::Pattern::six, BoxMeshDef::Pattern::five}) {
    const TetMesh m =
        make_box_mesh({.min = Vec3(0, 0, 0), .max = Vec3(4, 1, 1), .cells = {8, 2, 2}, .pattern = pattern});
    const double x0 = 1.37;
    const CutResult r = cut_mesh(m, {.point = Vec3(x0, 0.5, 0.5), .normal = Vec3(1, 0, 0)}, all_tets(m));
    EXPECT_TRUE(test::mesh_is_valid(r.mesh));
    EXPECT_GT(r.tets_split, 0);
    const std::vector<Fragment> f = extract_fragments(r.mesh, 1000.0);
    ASSERT_EQ(f.size(), 2u);
    // A flat crack: the halves are the boxes [0, x0] and [x0, 4] exactly.
    const Fragment& left = f[0].mass.center.x() < f[1].mass.center.x() ? f[0] : f[1];
    const Fragment& right = &left == &f[0] ? f[1] : f[0];
    EXPECT_NEAR(left.mass.volume, x0, 1e-12);
    EXPECT_NEAR(right.mass.volume, 4 - x0, 1e-12);
    EXPECT_NEAR(left.mass.center.x(), x0 / 2, 1e-12);
    for (const Vec3& p : left.mesh.positions) EXPECT_LE(p.x(), x0 + 1e-12);
    for (const Vec3& p : right.mesh.positions) EXPECT_GE(p.x(), x0 - 1e-12);
    // Without splitting, the crack follows faces: still two pieces, same total.
    const CutResult faces_only =
        cut_mesh(m, {.point = Vec3(x0, 0.5, 0.5), .normal = Vec3(1, 0, 0)}, all_tets(m), {.split_tets = false});
    EXPECT_EQ(faces_only.tets_split, 0);
    EXPECT_TRUE(test::mesh_is_valid(faces_only.mesh));
    EXPECT_EQ(connected_components(faces_only.mesh).count, 2);
    EXPECT_NEAR(total_volume(faces_only.mesh), 4.0, 1e-12);
  }
}

TEST(Cut, CrackEndingInsideLeavesOnePiece) {
  const TetMesh m = make_box_mesh({.min = Vec3(0, 0, 0), .max = Vec3(2, 2, 2), .cells = {8, 8, 8}});
  // Region: tets with centroid within 0.6 of the centre; the crack is a disc inside the body.
  std::vector<Index> region;
  for (Index e = 0; e < m.num_tets(); ++e)
    if ((m.corners(e).rowwise().mean() - Vec3(1, 1, 1)).norm() < 0.6) region.push_back(e);
  const CutResult r = cut_mesh(m, {.point = Vec3(1.03, 1, 1), .normal = Vec3(1, 0.2, 0.1).normalized()}, region);
  EXPECT_TRUE(test::mesh_is_valid(r.mesh));
  EXPECT_GT(r.nodes_duplicated, 0);
  EXPECT_GT(r.faces_cut, 0);
  EXPECT_EQ(connected_components(r.mesh).count, 1);
  EXPECT_NEAR(total_volume(r.mesh), 8.0, 8e-12);
  // The crack opened an internal surface: the boundary has more triangles than the box's.
  EXPECT_GT(boundary_surface(r.mesh).triangles.size(), boundary_surface(m).triangles.size());
}

TEST(Cut, AttributesFollow) {
  TetMesh m = make_box_mesh({.max = Vec3(2, 1, 1), .cells = {4, 2, 2}});
  for (Index i = 0; i < m.num_nodes(); ++i) m.node_ids.push_back(100 + 2 * i);
  for (Index e = 0; e < m.num_tets(); ++e) {
    m.tet_ids.push_back(1000 + e);
    m.tet_tags.push_back(e % 3);
  }
  for (Index i = 0; i < m.num_nodes(); ++i)
    if (m.positions[i].y() == 0) m.node_sets["bottom"].push_back(i);
  m.tet_sets["first"] = {0, 1, 2};
  const CutResult r = cut_mesh(m, {.point = Vec3(0.8, 0, 0), .normal = Vec3(1, 0, 0)}, all_tets(m));
  ASSERT_TRUE(test::mesh_is_valid(r.mesh));
  ASSERT_EQ(r.mesh.node_ids.size(), r.mesh.positions.size());
  ASSERT_EQ(r.mesh.tet_ids.size(), r.mesh.tets.size());
  // Kept nodes/tets keep ids; new ones are fresh and above the maximum.
  for (Index i = 0; i < m.num_nodes(); ++i) EXPECT_EQ(r.mesh.node_ids[i], m.node_ids[i]);
  for (Index i = m.num_nodes(); i < r.mesh.num_nodes(); ++i) EXPECT_GT(r.mesh.node_ids[i], m.node_ids.back());
  for (Index e = m.num_tets(); e < r.mesh.num_tets(); ++e) {
    EXPECT_GT(r.mesh.tet_ids[e], m.tet_ids.back());
    EXPECT_EQ(r.mesh.tet_tags[e], m.tet_tags[r.tet_parent[e]]);
  }
  std::vector<FileId> ids = r.mesh.node_ids;
  std::sort(ids.begin(), ids.end());
  EXPECT_TRUE(std::adjacent_find(ids.begin(), ids.end()) == ids.end());
  // Node sets: every node on y = 0 (kept, duplicated or on a split edge) is in "bottom".
  const auto& bottom = r.mesh.node_sets.at("bottom");
  EXPECT_TRUE(std::is_sorted(bottom.begin(), bottom.end()));
  for (Index i = 0; i < r.mesh.num_nodes(); ++i)
    EXPECT_EQ(std::binary_search(bottom.begin(), bottom.end(), i), r.mesh.positions[i].y() == 0) << i;
  // Node origins reproduce positions.
  for (Index i = 0; i < r.mesh.num_nodes(); ++i) {
    const NodeOrigin& o = r.node_origin[i];
    const Vec3 p = (1 - o.t) * m.positions[o.a] + o.t * m.positions[o.b];
    EXPECT_LT((p - r.mesh.positions[i]).norm(), 1e-15);
  }
}

// Random planes and regions, several cuts in a row, on regular and jittered (sliver-heavy) meshes.
TEST(Cut, RandomisedSoak) {
  Random rng(42);
  int cuts = 0, pieces_seen = 0;
  for (int mesh_index = 0; mesh_index < 40; ++mesh_index) {
    const auto pattern = mesh_index % 2 ? BoxMeshDef::Pattern::five : BoxMeshDef::Pattern::six;
    const double jitter = (mesh_index % 3) * 0.12;
    const Index n = 2 + mesh_index % 3;
    TetMesh m = make_box_mesh({.min = Vec3(-1, -0.5, 0),
                               .max = Vec3(1, 0.5, 0.7),
                               .cells = {n + 1, n, n},
                               .pattern = pattern,
                               .jitter = jitter,
                               .seed = std::uint64_t(mesh_index + 1)});
    const double volume = total_volume(m);
    for (int step = 0; step < 40; ++step) {
      const Vec3 point = rng.uniform_vec3(-0.6, 0.6);
      const Vec3 normal = rng.unit_vec3();
      const double radius = rng.uniform(0.1, 1.5);
      std::vector<Index> region;
      for (Index e = 0; e < m.num_tets(); ++e)
        if ((m.corners(e).rowwise().mean() - point).norm() < radius) region.push_back(e);
      const CutOptions options{.split_tets = rng.uniform() < 0.8,
                               .snap_fraction = rng.uniform(0.0, 0.2),
                               .min_volume_fraction = rng.uniform(1e-4, 1e-2)};
      const CutResult r = cut_mesh(m, {.point = point, .normal = normal}, region, options);
      ++cuts;
      ASSERT_TRUE(test::mesh_is_valid(r.mesh)) << "mesh " << mesh_index << " step " << step;
      for (Index e = 0; e < r.mesh.num_tets(); ++e)
        if (e >= m.num_tets() || r.mesh.tets[e] != m.tets[e])  // a piece or renumbered tet
          if (r.tet_parent[e] != e || r.mesh.tets[e] != m.tets[e]) {
            const double v = signed_volume(r.mesh, e);
            const double parent = signed_volume(m, r.tet_parent[e]);
            // Pieces respect the threshold (duplicated-node tets have their parent's volume).
            ASSERT_GE(v, options.min_volume_fraction * parent * (1 - 1e-12));
          }
      ASSERT_NEAR(total_volume(r.mesh), volume, 1e-12 * volume);
      for (const Vec3& p : r.mesh.positions) ASSERT_TRUE(p.allFinite());
      m = r.mesh;
      if (m.num_tets() > 1500) break;
    }
    const std::vector<Fragment> fragments = extract_fragments(m, 2500.0);
    double mass = 0;
    for (const Fragment& f : fragments) {
      mass += f.mass.mass;
      EXPECT_EQ(connected_components(f.mesh).count, 1);
      EXPECT_TRUE(test::mesh_is_valid(f.mesh));
    }
    pieces_seen += static_cast<int>(fragments.size());
    EXPECT_NEAR(mass, 2500.0 * volume, 1e-12 * 2500.0 * volume);
  }
  EXPECT_GT(cuts, 1000);
  EXPECT_GT(pieces_seen, 80);
}

void expect_same_faces(const TetFaces& a, const TetFaces& b, const std::string& where) {
  EXPECT_EQ(a.faces, b.faces) << where;
  EXPECT_EQ(a.face_tets, b.face_tets) << where;
  EXPECT_EQ(a.tet_faces, b.tet_faces) << where;
  EXPECT_EQ(a.overshared, b.overshared) << where;
}

// The faces carried through cuts (update_faces) and restricted to each fragment (restrict_faces)
// are compute_faces' own, bit for bit: random planes and regions, several cuts in a row, on
// regular and jittered meshes, with and without splitting.
TEST(Cut, FacesCarriedThroughCutsAreComputeFaces) {
  Random rng(7);
  int updated = 0, restricted = 0;
  for (int mesh_index = 0; mesh_index < 12; ++mesh_index) {
    const Index n = 2 + mesh_index % 3;
    TetMesh m = make_box_mesh({.min = Vec3(-1, -0.5, 0),
                               .max = Vec3(1, 0.5, 0.7),
                               .cells = {n + 2, n, n},
                               .pattern = mesh_index % 2 ? BoxMeshDef::Pattern::five : BoxMeshDef::Pattern::six,
                               .jitter = (mesh_index % 3) * 0.12,
                               .seed = std::uint64_t(mesh_index + 1)});
    TetFaces faces = compute_faces(m);
    // A dent moves nodes only: every tet keeps its corners, and so its faces.
    TetMesh dented = m;
    for (Vec3& p : dented.positions) p *= 0.99;
    expect_same_faces(update_faces(m, faces, dented), faces, "dent");
    for (int step = 0; step < 12; ++step) {
      const Vec3 point = rng.uniform_vec3(-0.6, 0.6);
      const double radius = rng.uniform(0.2, 1.5);
      std::vector<Index> region;
      for (Index e = 0; e < m.num_tets(); ++e)
        if ((m.corners(e).rowwise().mean() - point).norm() < radius) region.push_back(e);
      const CutOptions options{.split_tets = rng.uniform() < 0.8, .snap_fraction = rng.uniform(0.0, 0.2)};
      const CutResult r = cut_mesh(m, {.point = point, .normal = rng.unit_vec3()}, region, options);
      // Carried over one cut, or over two at once (the faces before the previous cut).
      const TetFaces carried = update_faces(m, faces, r.mesh);
      expect_same_faces(carried, compute_faces(r.mesh),
                        "mesh " + std::to_string(mesh_index) + " step " + std::to_string(step));
      ++updated;
      m = r.mesh;
      faces = carried;
    }
    // Every component but the first, as a world keeps the children but drops debris.
    const Components comp = connected_components(m);
    std::vector<Index> tet_part(m.tets.size(), -1), local_tet(m.tets.size(), -1);
    std::vector<Index> local_node(m.positions.size(), -1), part_tets;
    std::vector<TetMesh> parts;
    for (Index c = 1; c < comp.count; ++c) {
      std::vector<Index> tets;
      for (Index e = 0; e < m.num_tets(); ++e)
        if (comp.tet_component[e] == c) tets.push_back(e);
      std::vector<Index> node_map;
      parts.push_back(extract_tets(m, tets, &node_map));
      part_tets.push_back(static_cast<Index>(tets.size()));
      for (std::size_t e = 0; e < tets.size(); ++e) {
        tet_part[static_cast<std::size_t>(tets[e])] = c - 1;
        local_tet[static_cast<std::size_t>(tets[e])] = static_cast<Index>(e);
      }
      for (std::size_t i = 0; i < node_map.size(); ++i)
        local_node[static_cast<std::size_t>(node_map[i])] = static_cast<Index>(i);
    }
    const std::vector<TetFaces> split = split_faces(faces, tet_part, local_tet, local_node, part_tets);
    ASSERT_EQ(split.size(), parts.size());
    for (std::size_t c = 0; c < parts.size(); ++c) {
      expect_same_faces(split[c], compute_faces(parts[c]),
                        "mesh " + std::to_string(mesh_index) + " part " + std::to_string(c + 1));
      ++restricted;
    }
  }
  EXPECT_EQ(updated, 12 * 12);
  EXPECT_GT(restricted, 24);
}

}  // namespace
}  // namespace shatter
