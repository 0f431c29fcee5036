// Tet-mesh contact mode: grid point location and BVH closest points equal brute force over all
// tets / triangles; vertex contacts equal a brute-force reference on random scenes; analytic cases
// (face on face, an edge crossing an edge with no vertex inside, gaps, a box on a plane); the same
// inputs give the same output sequence.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>

#include "shatter/collide/tet_contact.h"
#include "shatter/core/random.h"
#include "shatter/mesh/generate.h"

namespace shatter {
namespace {

TetContactShape shape_of(const TetMesh& mesh) { return make_tet_contact_shape(mesh, compute_faces(mesh)); }

TetContactShape box_shape(const Vec3& lo, const Vec3& hi, std::array<Index, 3> cells,
                          BoxMeshDef::Pattern pattern = BoxMeshDef::Pattern::six, double jitter = 0,
                          std::uint64_t seed = 1) {
  return shape_of(
      make_box_mesh({.min = lo, .max = hi, .cells = cells, .pattern = pattern, .jitter = jitter, .seed = seed}));
}

Mat3 random_angle_axis(Random& rng) {
  const double angle = rng.uniform(0, 2 * std::numbers::pi);  // drawn first, whatever the compiler
  return Eigen::AngleAxisd(angle, rng.unit_vec3()).toRotationMatrix();
}

Mat3 rotation_about(const Vec3& axis, double angle) { return Eigen::AngleAxisd(angle, axis).toRotationMatrix(); }

// Reference containment: barycentric coordinates from the inverse of the edge matrix.
bool contains_reference(const TetMesh& m, Index e, const Vec3& p) {
  const Mat34 x = m.corners(e);
  Mat3 d;
  d << x.col(1) - x.col(0), x.col(2) - x.col(0), x.col(3) - x.col(0);
  const Vec3 l = d.inverse() * (p - x.col(0));
  return l.minCoeff() >= -kTetInsideTolerance && 1 - l.sum() >= -kTetInsideTolerance;
}

Index locate_reference(const TetMesh& m, const Vec3& p) {
  for (Index e = 0; e < m.num_tets(); ++e)
    if (contains_reference(m, e, p)) return e;
  return -1;
}

Vec3 closest_on_segment(const Vec3& p, const Vec3& a, const Vec3& b) {
  const Vec3 ab = b - a;
  const double t = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
  return a + t * ab;
}

// Reference closest point on a triangle: the plane projection when it falls inside, else the
// closest of the three edges.
Vec3 closest_on_triangle_reference(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 n = (b - a).cross(c - a);
  const Vec3 q = p - n * (n.dot(p - a) / n.squaredNorm());
  if ((b - a).cross(q - a).dot(n) >= 0 && (c - b).cross(q - b).dot(n) >= 0 && (a - c).cross(q - c).dot(n) >= 0)
    return q;
  Vec3 best = closest_on_segment(p, a, b);
  for (const Vec3& r : {closest_on_segment(p, b, c), closest_on_segment(p, c, a)})
    if ((r - p).squaredNorm() < (best - p).squaredNorm()) best = r;
  return best;
}

double triangle_distance(const TetContactShape& s, Index t, const Vec3& p) {
  const auto& tri = s.surface.triangles[static_cast<std::size_t>(t)];
  return (closest_on_triangle_reference(p, s.surface.positions[tri[0]], s.surface.positions[tri[1]],
                                        s.surface.positions[tri[2]]) -
          p)
      .norm();
}

double distance_reference(const TetContactShape& s, const Vec3& p, Index* triangle = nullptr) {
  double best = std::numeric_limits<double>::infinity();
  for (Index t = 0; t < static_cast<Index>(s.surface.triangles.size()); ++t) {
    const double d = triangle_distance(s, t, p);
    if (d < best) {
      best = d;
      if (triangle) *triangle = t;
    }
  }
  return best;
}

// Random points in the box grown by `grow` times its extent, plus every node and face centroid
// (points on tet boundaries, where the tolerance and the grid padding matter).
std::vector<Vec3> query_points(Random& rng, const TetMesh& m, int count, double grow) {
  const Aabb b = m.bounds();
  const Vec3 pad = grow * b.extent();
  std::vector<Vec3> pts;
  for (int i = 0; i < count; ++i) {
    const Vec3 u{rng.uniform(), rng.uniform(), rng.uniform()};  // braces: drawn left to right
    pts.push_back(b.min - pad + u.cwiseProduct(b.extent() + 2 * pad));
  }
  // Nodes and face centroids, exactly and moved by far less than the containment tolerance.
  const double nudge = 1e-12 * b.extent().maxCoeff();
  for (const Vec3& x : m.positions) {
    pts.push_back(x);
    pts.push_back(x + nudge * rng.unit_vec3());
  }
  for (Index e = 0; e < m.num_tets(); ++e) {
    const Mat34 x = m.corners(e);
    pts.push_back((x.col(1) + x.col(2) + x.col(3)) / 3);
    pts.push_back((x.col(1) + x.col(2) + x.col(3)) / 3 + nudge * rng.unit_vec3());
    pts.push_back(x.rowwise().mean());
  }
  return pts;
}

TetMesh rotated(TetMesh m, const Mat3& r, const Vec3& shift) {
  for (Vec3& x : m.positions) x = r * x + shift;
  return m;
}

std::vector<PointContact> collide(const TetContactShape& a, const Transform& ta, const TetContactShape& b,
                                  const Transform& tb, double speculative) {
  std::vector<PointContact> out;
  collide_tet_shapes(a, ta, b, tb, speculative, out);
  return out;
}

bool is_edge(const PointContact& c) { return (c.feature & kTetFeatureEdge) != 0; }
bool of_b(const PointContact& c) { return (c.feature & kTetFeatureBodyB) != 0; }

TEST(TetContact, ShapeHasClosedBoundaryAndGridListsEveryTet) {
  const auto s = box_shape(Vec3(0, 0, 0), Vec3(1, 0.5, 2), {4, 2, 8});
  // A closed triangle surface: V - E + F = 2.
  EXPECT_EQ(static_cast<Index>(s.surface.positions.size()) - static_cast<Index>(s.boundary_edges.size()) +
                static_cast<Index>(s.surface.triangles.size()),
            2);
  const std::size_t cells = static_cast<std::size_t>(s.grid_dims[0]) * s.grid_dims[1] * s.grid_dims[2];
  ASSERT_EQ(s.cell_start.size(), cells + 1);
  std::vector<int> listed(static_cast<std::size_t>(s.mesh.num_tets()), 0);
  for (std::size_t c = 0; c < cells; ++c)
    for (Index i = s.cell_start[c]; i < s.cell_start[c + 1]; ++i) {
      if (i > s.cell_start[c]) {
        EXPECT_LT(s.cell_tets[i - 1], s.cell_tets[i]);  // increasing per cell
      }
      ++listed[static_cast<std::size_t>(s.cell_tets[i])];
    }
  for (int n : listed) EXPECT_GE(n, 1);
  // Every triangle in exactly one BVH leaf.
  std::vector<int> in_leaf(s.surface.triangles.size(), 0);
  for (const auto& node : s.bvh)
    if (node.left < 0)
      for (Index i = node.first; i < node.right; ++i) ++in_leaf[static_cast<std::size_t>(s.bvh_triangles[i])];
  for (int n : in_leaf) EXPECT_EQ(n, 1);
}

TEST(TetContact, LocateTetMatchesBruteForce) {
  Random rng(11);
  const TetMesh box = make_box_mesh({.min = Vec3(-0.3, 0, -0.2),
                                     .max = Vec3(0.5, 0.6, 0.9),
                                     .cells = {4, 3, 5},
                                     .pattern = BoxMeshDef::Pattern::five,
                                     .jitter = 0.2,
                                     .seed = 3});
  const TetMesh turned = rotated(box, random_angle_axis(rng), Vec3(1, -2, 0.5));
  for (const TetMesh* m : {&box, &turned}) {
    const auto s = shape_of(*m);
    int inside = 0, total = 0;
    for (const Vec3& p : query_points(rng, *m, 4000, 0.1)) {
      const Index expected = locate_reference(*m, p);
      ASSERT_EQ(locate_tet(s, p), expected) << "point " << p.transpose();
      inside += expected >= 0;
      ++total;
    }
    std::printf("locate: %d of %d points inside, grid %d x %d x %d, %zu entries for %d tets\n", inside, total,
                s.grid_dims[0], s.grid_dims[1], s.grid_dims[2], s.cell_tets.size(), m->num_tets());
    EXPECT_GT(inside, 1000);
    EXPECT_GT(total - inside, 1000);
  }
}

TEST(TetContact, ClosestBoundaryPointMatchesBruteForce) {
  Random rng(12);
  const TetMesh m = rotated(make_box_mesh({.min = Vec3(0, 0, 0),
                                           .max = Vec3(1.2, 0.4, 0.7),
                                           .cells = {6, 2, 4},
                                           .pattern = BoxMeshDef::Pattern::five,
                                           .jitter = 0.2}),
                            random_angle_axis(rng), Vec3::Zero());
  const auto s = shape_of(m);
  int inside = 0;
  for (const Vec3& p : query_points(rng, m, 3000, 0.5)) {
    const double expected = distance_reference(s, p);
    BoundaryPoint bp;
    ASSERT_TRUE(closest_boundary_point(s, p, std::numeric_limits<double>::infinity(), bp));
    ASSERT_NEAR(bp.distance, expected, 1e-12) << "point " << p.transpose();
    EXPECT_NEAR((bp.point - p).norm(), bp.distance, 1e-12);
    EXPECT_NEAR(triangle_distance(s, bp.triangle, bp.point), 0.0, 1e-12);  // on the triangle it names
    // The distance limit only cuts off points farther than it.
    if (expected > 1e-9) {
      EXPECT_TRUE(closest_boundary_point(s, p, expected * (1 + 1e-9), bp));
      EXPECT_FALSE(closest_boundary_point(s, p, expected * (1 - 1e-9), bp));
    }
    inside += locate_tet(s, p) >= 0;
  }
  EXPECT_GT(inside, 500);
}

// For A at `ta` and B at `tb`: every boundary vertex contact of A (against B) and of B (against A)
// equals the brute-force one: present exactly when inside or within the speculative distance, the
// same separation, a normal from A to B that is the face normal of a closest triangle (inside) or
// the direction to the closest point (outside).
void check_vertex_contacts(const TetContactShape& a, const Transform& ta, const TetContactShape& b, const Transform& tb,
                           double speculative, const std::vector<PointContact>& got, int& inside_count,
                           int& outside_count) {
  std::size_t k = 0;
  for (int pass = 0; pass < 2; ++pass) {
    const TetContactShape& v = pass == 0 ? a : b;
    const TetContactShape& s = pass == 0 ? b : a;
    const Transform& tv = pass == 0 ? ta : tb;
    const Transform& ts = pass == 0 ? tb : ta;
    const double sign = pass == 0 ? 1 : -1;
    for (Index i = 0; i < static_cast<Index>(v.surface.positions.size()); ++i) {
      const Vec3 p = ts.apply_inverse(tv.apply(v.surface.positions[i]));
      const bool inside = locate_reference(s.mesh, p) >= 0;
      Index tri = -1;
      const double d = distance_reference(s, p, &tri);
      if (!inside && d > speculative) continue;
      ASSERT_LT(k, got.size());
      const PointContact& c = got[k++];
      ASSERT_EQ(c.feature, (pass == 0 ? 0u : kTetFeatureBodyB) | static_cast<std::uint32_t>(i));
      ASSERT_NEAR(c.separation, inside ? -d : d, 1e-12);
      ASSERT_NEAR(c.normal.norm(), 1.0, 1e-12);
      const Vec3 local_n = sign * (ts.rotation.transpose() * c.normal);  // into s, in s's frame
      if (inside) {
        bool matches = false;
        for (Index t = 0; t < static_cast<Index>(s.surface.triangles.size()); ++t)
          matches |=
              std::abs(triangle_distance(s, t, p) - d) < 1e-12 && (local_n + s.triangle_normals[t]).norm() < 1e-9;
        EXPECT_TRUE(matches) << "vertex " << i << " of body " << pass;
        ++inside_count;
      } else {
        const auto& t3 = s.surface.triangles[tri];
        const Vec3 q = closest_on_triangle_reference(p, s.surface.positions[t3[0]], s.surface.positions[t3[1]],
                                                     s.surface.positions[t3[2]]);
        EXPECT_LT((local_n - (q - p).normalized()).norm(), 1e-6) << "vertex " << i << " of body " << pass;
        ++outside_count;
      }
    }
  }
  // What follows are edge contacts: overlapping, ends outside the other body.
  for (; k < got.size(); ++k) {
    const PointContact& c = got[k];
    ASSERT_TRUE(is_edge(c));
    EXPECT_LT(c.separation, 0);
    const TetContactShape& v = of_b(c) ? b : a;
    const TetContactShape& s = of_b(c) ? a : b;
    const Transform& tv = of_b(c) ? tb : ta;
    const Transform& ts = of_b(c) ? ta : tb;
    for (Index end : v.boundary_edges[c.feature & kTetFeatureIndexMask])
      EXPECT_LT(locate_reference(s.mesh, ts.apply_inverse(tv.apply(v.surface.positions[end]))), 0);
  }
  // Edges against a sampled reference (grid location and BVH distance, both checked against brute
  // force above): an edge with both ends outside that clearly passes through the other body has a
  // contact, and no edge contact is deeper than the deepest point of its edge.
  std::size_t next = 0;
  while (next < got.size() && !is_edge(got[next])) ++next;
  for (int pass = 0; pass < 2; ++pass) {
    const TetContactShape& v = pass == 0 ? a : b;
    const TetContactShape& s = pass == 0 ? b : a;
    const Transform& tv = pass == 0 ? ta : tb;
    const Transform& ts = pass == 0 ? tb : ta;
    for (Index e = 0; e < static_cast<Index>(v.boundary_edges.size()); ++e) {
      const Vec3 p = ts.apply_inverse(tv.apply(v.surface.positions[v.boundary_edges[e][0]]));
      const Vec3 q = ts.apply_inverse(tv.apply(v.surface.positions[v.boundary_edges[e][1]]));
      if (locate_tet(s, p) >= 0 || locate_tet(s, q) >= 0) continue;
      const int samples = 200;
      double deepest = 0;
      for (int j = 1; j < samples; ++j) {
        const Vec3 x = p + (q - p) * (double(j) / samples);
        BoundaryPoint bp;
        if (locate_tet(s, x) >= 0 && closest_boundary_point(s, x, 1e9, bp)) deepest = std::max(deepest, bp.distance);
      }
      const std::uint32_t feature = (pass == 0 ? 0u : kTetFeatureBodyB) | kTetFeatureEdge | std::uint32_t(e);
      const bool reported = next < got.size() && got[next].feature == feature;
      if (deepest > 1e-3) {
        EXPECT_TRUE(reported) << "edge " << e << " of body " << pass << " deepest " << deepest;
      }
      if (reported) {
        EXPECT_LE(-got[next++].separation, deepest + 0.5 * (q - p).norm() / samples + 1e-12);
      }
    }
  }
  EXPECT_EQ(next, got.size());  // every edge contact was matched, in order
}

TEST(TetContact, VertexContactsMatchBruteForceOnRandomScenes) {
  Random rng(13);
  int inside = 0, outside = 0, edges = 0;
  for (int scene = 0; scene < 40; ++scene) {
    const auto a =
        box_shape(Vec3::Zero(), rng.uniform_vec3(0.3, 1.0), {3, 3, 3}, BoxMeshDef::Pattern::five, 0.2, rng.next_u64());
    const auto b =
        box_shape(Vec3::Zero(), rng.uniform_vec3(0.3, 1.0), {2, 3, 4}, BoxMeshDef::Pattern::six, 0.2, rng.next_u64());
    const Transform ta{random_angle_axis(rng), rng.uniform_vec3(-1, 1)};
    const Transform tb{random_angle_axis(rng), ta.translation + rng.uniform_vec3(-0.6, 0.6)};
    const double speculative = 0.05;
    const auto got = collide(a, ta, b, tb, speculative);
    check_vertex_contacts(a, ta, b, tb, speculative, got, inside, outside);
    for (const auto& c : got) edges += is_edge(c);
  }
  std::printf("random scenes: %d inside, %d speculative vertex contacts, %d edge contacts\n", inside, outside, edges);
  EXPECT_GT(inside, 200);
  EXPECT_GT(outside, 50);
  EXPECT_GT(edges, 10);
}

TEST(TetContact, BoxesOverlappingFaceToFace) {
  // A: the unit cube; B: a smaller box whose bottom is 1 mm below A's top, inside A's footprint.
  // The whole scene is turned and moved, so the normal must come out as that turn of +y.
  Random rng(14);
  const auto a = box_shape(Vec3::Zero(), Vec3::Ones(), {4, 4, 4});
  const auto b = box_shape(Vec3(-0.3, 0, -0.35), Vec3(0.3, 0.5, 0.35), {3, 2, 3});
  const Transform world{random_angle_axis(rng), rng.uniform_vec3(-5, 5)};
  const Transform ta = world;
  const Transform tb{world.rotation, world.apply(Vec3(0.5, 0.999, 0.5))};
  const auto got = collide(a, ta, b, tb, 1e-4);
  // A's top vertices strictly inside B's footprint (x, z in 0.25..0.75: 9) and all of B's bottom
  // vertices (4 x 4), each 1 mm deep; no edge passes through with both ends outside.
  ASSERT_EQ(got.size(), 25u);
  const Vec3 up = world.rotation * Vec3::UnitY();
  for (const auto& c : got) {
    EXPECT_FALSE(is_edge(c));
    EXPECT_NEAR(c.separation, -1e-3, 1e-12);
    EXPECT_LT((c.normal - up).norm(), 1e-12);  // from A (below) to B (above)
    // Midway between the surfaces: at height 0.9995 in A's frame.
    EXPECT_NEAR(ta.apply_inverse(c.point).y(), 0.9995, 1e-12);
  }
  int int_b = 0;
  for (const auto& c : got) int_b += of_b(c);
  EXPECT_EQ(int_b, 16);
}

TEST(TetContact, EdgeCrossingEdgeWithNoVertexInside) {
  // Two square bars crossing like an X seen from above: A along x, turned 45 degrees about x so an
  // edge points down; B along z, turned about z so an edge points up; A's lowest edge 2 mm below
  // B's highest. 21 cells along each bar keep the nodes 24 mm from the crossing.
  const double side = 0.1, depth = 2e-3, half_diagonal = side / std::numbers::sqrt2;
  const auto a = box_shape(Vec3(-0.5, -side / 2, -side / 2), Vec3(0.5, side / 2, side / 2), {21, 2, 2});
  const auto b = box_shape(Vec3(-side / 2, -side / 2, -0.5), Vec3(side / 2, side / 2, 0.5), {2, 2, 21});
  const Transform ta{rotation_about(Vec3::UnitX(), std::numbers::pi / 4), Vec3(0, half_diagonal - depth, 0)};
  const Transform tb{rotation_about(Vec3::UnitZ(), std::numbers::pi / 4), Vec3(0, -half_diagonal, 0)};
  // No vertex of either is inside the other.
  for (const Vec3& p : a.surface.positions) ASSERT_LT(locate_tet(b, tb.apply_inverse(ta.apply(p))), 0);
  for (const Vec3& p : b.surface.positions) ASSERT_LT(locate_tet(a, ta.apply_inverse(tb.apply(p))), 0);
  const auto got = collide(a, ta, b, tb, 0.0);
  ASSERT_GE(got.size(), 1u);
  // Each crossing edge's entry/exit midpoint is the other's edge line, depth/sqrt(2) from the
  // closest face; the normal is that face's, pointing down (A above, B below).
  for (const auto& c : got) {
    EXPECT_TRUE(is_edge(c));
    EXPECT_NEAR(c.separation, -depth / std::numbers::sqrt2, 1e-12);
    EXPECT_NEAR(c.normal.y(), -1 / std::numbers::sqrt2, 1e-12);
    // Halfway between the midpoint (on A's lowest edge, y = -depth; on B's highest, y = 0) and the
    // closest face point of the other bar, depth / 2 up (B's face) or down (A's face).
    EXPECT_NEAR(c.point.y(), of_b(c) ? -depth / 4 : -3 * depth / 4, 1e-12);
  }
  std::printf("edge crossing: %zu contacts\n", got.size());
}

TEST(TetContact, SeparatedBodies) {
  // B 5 cm above A, shifted sideways.
  const auto a = box_shape(Vec3::Zero(), Vec3::Ones(), {3, 3, 3});
  const auto b = box_shape(Vec3::Zero(), Vec3::Ones(), {2, 3, 2});
  const Transform ta;
  const Transform tb{rotation_about(Vec3::UnitY(), 0.3), Vec3(0.2, 1.05, 0.1)};
  EXPECT_TRUE(collide(a, ta, b, tb, 0.04).empty());
  EXPECT_TRUE(collide(a, ta, b, tb, 0.0).empty());
  const auto got = collide(a, ta, b, tb, 0.1);
  ASSERT_FALSE(got.empty());
  int facing = 0;
  for (const auto& c : got) {
    EXPECT_FALSE(is_edge(c));
    EXPECT_GE(c.separation, 0.05 - 1e-12);
    EXPECT_LE(c.separation, 0.1);
    EXPECT_GT(c.normal.y(), 0);  // from A (below) to B
    if (std::abs(c.separation - 0.05) < 1e-12) {
      EXPECT_LT((c.normal - Vec3::UnitY()).norm(), 1e-9);
      ++facing;
    }
  }
  EXPECT_GT(facing, 4);
}

TEST(TetContact, BoxRestingOnPlane) {
  const auto a = box_shape(Vec3(-0.5, 0, -0.3), Vec3(0.5, 0.4, 0.3), {4, 2, 3});
  std::vector<std::uint32_t> bottom;
  for (std::size_t i = 0; i < a.surface.positions.size(); ++i)
    if (a.surface.positions[i].y() == 0) bottom.push_back(static_cast<std::uint32_t>(i));
  ASSERT_EQ(bottom.size(), 5u * 4u);
  for (const double lift : {0.0, 0.005}) {
    const Transform ta{rotation_about(Vec3::UnitY(), 0.3), Vec3(1, lift, 2)};
    std::vector<PointContact> got;
    collide_tet_shape_plane(a, ta, Plane{}, 0.01, got);
    ASSERT_EQ(got.size(), bottom.size());
    for (std::size_t k = 0; k < got.size(); ++k) {
      EXPECT_EQ(got[k].feature, bottom[k]);
      EXPECT_NEAR(got[k].separation, lift, 1e-15);
      EXPECT_EQ(got[k].normal, -Vec3::UnitY());
      EXPECT_NEAR(got[k].point.y(), lift / 2, 1e-15);
    }
  }
  std::vector<PointContact> none;
  collide_tet_shape_plane(a, Transform{Mat3::Identity(), Vec3(0, 0.02, 0)}, Plane{}, 0.01, none);
  EXPECT_TRUE(none.empty());
  // A tilted plane: the same rule on the signed distance.
  const Plane tilted{Vec3(1, 1, 0).normalized(), 0.1};
  std::vector<PointContact> got;
  collide_tet_shape_plane(a, Transform{}, tilted, 0.0, got);
  int expected = 0;
  for (const Vec3& x : a.surface.positions) expected += tilted.normal.dot(x) - tilted.offset <= 0;
  EXPECT_EQ(static_cast<int>(got.size()), expected);
  for (const auto& c : got) EXPECT_LE(c.separation, 0);
}

TEST(TetContact, SameInputsSameOutput) {
  Random rng(15);
  const auto make = [] {
    return std::pair{box_shape(Vec3::Zero(), Vec3(0.8, 0.5, 0.6), {4, 3, 3}, BoxMeshDef::Pattern::five, 0.2, 5),
                     box_shape(Vec3::Zero(), Vec3(0.4, 0.9, 0.5), {2, 5, 3}, BoxMeshDef::Pattern::six, 0.2, 6)};
  };
  const auto [a1, b1] = make();
  const auto [a2, b2] = make();
  EXPECT_EQ(a1.cell_tets, a2.cell_tets);
  EXPECT_EQ(a1.bvh_triangles, a2.bvh_triangles);
  for (int trial = 0; trial < 5; ++trial) {
    // Turned about their centres (0.4, 0.25, 0.3) and (0.2, 0.45, 0.25), centres 0.2 apart or less.
    const Transform ta{random_angle_axis(rng), Vec3::Zero()};
    const Mat3 rb = random_angle_axis(rng);
    const Transform tb{rb, ta.apply(Vec3(0.4, 0.25, 0.3)) - rb * Vec3(0.2, 0.45, 0.25) + rng.uniform_vec3(-0.1, 0.1)};
    const auto x = collide(a1, ta, b1, tb, 0.02);
    const auto y = collide(a2, ta, b2, tb, 0.02);
    ASSERT_EQ(x.size(), y.size());
    EXPECT_FALSE(x.empty());
    for (std::size_t k = 0; k < x.size(); ++k) {
      EXPECT_EQ(x[k].feature, y[k].feature);
      EXPECT_EQ(x[k].point, y[k].point);
      EXPECT_EQ(x[k].normal, y[k].normal);
      EXPECT_EQ(x[k].separation, y[k].separation);
    }
  }
}

TEST(TetContact, EmptyShapesGiveNothing) {
  const auto empty = shape_of(TetMesh{});
  const auto a = box_shape(Vec3::Zero(), Vec3::Ones(), {1, 1, 1});
  EXPECT_EQ(locate_tet(empty, Vec3::Zero()), -1);
  BoundaryPoint bp;
  EXPECT_FALSE(closest_boundary_point(empty, Vec3::Zero(), 1.0, bp));
  EXPECT_TRUE(collide(a, {}, empty, {}, 1.0).empty());
  EXPECT_TRUE(collide(empty, {}, a, {}, 1.0).empty());
}

}  // namespace
}  // namespace shatter
