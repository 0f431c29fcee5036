// Tet-mesh contact mode (see tet_contact.h): grid point location, BVH closest points and segment
// crossings, and the vertex and edge contacts built from them.
#include "shatter/collide/tet_contact.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "shatter/collide/broad_phase.h"

namespace shatter {
namespace {

constexpr int kLeafSize = 4;        // triangles per BVH leaf
constexpr int kStackSize = 64;      // BVH traversal stack: depth of a median-split tree is ~log2(n)
constexpr int kMaxCrossings = 32;   // segment-boundary crossings kept per edge (more are ignored)
constexpr double kCellsPerTet = 8;  // the grid never has more cells than this times the tets (+1)

// Box grown by r on every side.
Aabb padded(const Aabb& b, double r) {
  Aabb out = b;
  out.min.array() -= r;
  out.max.array() += r;
  return out;
}

double box_distance_squared(const Aabb& b, const Vec3& p) {
  const Vec3 d = (b.min - p).cwiseMax(p - b.max).cwiseMax(0.0);
  return d.squaredNorm();
}

// The map from a point to the barycentric coordinates 1..3 of tet e: with the edge vectors
// e1, e2, e3 from corner 0, the rows of the inverse edge matrix (cross products over the
// determinant, Cramer's rule). False for a degenerate or inverted tet, which contains nothing.
bool barycentric_map(const TetMesh& mesh, Index e, TetContactShape::TetMap& map) {
  const TetIndices& t = mesh.tets[static_cast<std::size_t>(e)];
  const Vec3& x0 = mesh.positions[static_cast<std::size_t>(t[0])];
  const Vec3 e1 = mesh.positions[static_cast<std::size_t>(t[1])] - x0;
  const Vec3 e2 = mesh.positions[static_cast<std::size_t>(t[2])] - x0;
  const Vec3 e3 = mesh.positions[static_cast<std::size_t>(t[3])] - x0;
  const double det = e1.dot(e2.cross(e3));
  if (!(det > 0) || !std::isfinite(det)) return false;
  map.to_barycentric.row(0) = e2.cross(e3).transpose() / det;
  map.to_barycentric.row(1) = e3.cross(e1).transpose() / det;
  map.to_barycentric.row(2) = e1.cross(e2).transpose() / det;
  map.origin = x0;
  return true;
}

bool tet_contains(const TetContactShape::TetMap& map, const Vec3& p) {
  // Row by row, stopping at the first coordinate below the tolerance (most tests fail early).
  const Vec3 d = p - map.origin;
  const double l1 = map.to_barycentric.row(0).dot(d);
  if (l1 < -kTetInsideTolerance) return false;
  const double l2 = map.to_barycentric.row(1).dot(d);
  if (l2 < -kTetInsideTolerance) return false;
  const double l3 = map.to_barycentric.row(2).dot(d);
  return l3 >= -kTetInsideTolerance && 1.0 - l1 - l2 - l3 >= -kTetInsideTolerance;
}

// Closest point to p on triangle abc (Ericson, Real-Time Collision Detection §5.1.5: Voronoi
// regions of the vertices, then the edges, then the face).
Vec3 closest_on_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Vec3 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + ab * (d1 / (d1 - d3));
  const Vec3 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + ac * (d2 / (d2 - d6));
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
  const double sum = va + vb + vc;
  if (!(sum > 0)) return a;  // degenerate (zero-area) triangle: its edges were tested above
  return a + ab * (vb / sum) + ac * (vc / sum);
}

// Parameter t in [0, 1] where segment p + t (q - p) crosses triangle abc (Möller & Trumbore 1997);
// false when it misses or runs parallel to it.
bool segment_triangle(const Vec3& p, const Vec3& dir, const Vec3& a, const Vec3& b, const Vec3& c, double& t) {
  const Vec3 e1 = b - a, e2 = c - a;
  const Vec3 h = dir.cross(e2);
  const double det = e1.dot(h);
  const double scale = e1.squaredNorm() * e2.squaredNorm() * dir.squaredNorm();
  if (det * det <= 1e-24 * scale) return false;  // parallel (relative test)
  const double inv = 1.0 / det;
  const Vec3 s = p - a;
  const double u = s.dot(h) * inv;
  if (u < 0 || u > 1) return false;
  const Vec3 q = s.cross(e1);
  const double v = dir.dot(q) * inv;
  if (v < 0 || u + v > 1) return false;
  t = e2.dot(q) * inv;
  return t >= 0 && t <= 1;
}

// Whether segment p + t dir, t in [0, 1], meets box b (slab test).
bool segment_box(const Vec3& p, const Vec3& dir, const Aabb& b) {
  double t0 = 0, t1 = 1;
  for (int k = 0; k < 3; ++k) {
    if (dir[k] == 0) {
      if (p[k] < b.min[k] || p[k] > b.max[k]) return false;
      continue;
    }
    const double inv = 1.0 / dir[k];
    double ta = (b.min[k] - p[k]) * inv, tb = (b.max[k] - p[k]) * inv;
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
    if (t0 > t1) return false;
  }
  return true;
}

Aabb triangle_box(const TriSurface& s, Index t) {
  Aabb b;
  for (Index v : s.triangles[static_cast<std::size_t>(t)]) b.extend(s.positions[static_cast<std::size_t>(v)]);
  return b;
}

// Builds the BVH over tris[begin, end) as node `node` (already allocated), median split.
void build_bvh(TetContactShape& shape, const std::vector<Vec3>& centroids, Index node, Index begin, Index end) {
  Aabb box;
  for (Index i = begin; i < end; ++i) {
    const Aabb tb = triangle_box(shape.surface, shape.bvh_triangles[static_cast<std::size_t>(i)]);
    box.extend(tb.min);
    box.extend(tb.max);
  }
  shape.bvh[static_cast<std::size_t>(node)].box = box;
  if (end - begin <= kLeafSize) {
    auto& n = shape.bvh[static_cast<std::size_t>(node)];
    n.left = -1;
    n.first = begin;
    n.right = end;
    return;
  }
  Aabb cbox;
  for (Index i = begin; i < end; ++i) cbox.extend(centroids[static_cast<std::size_t>(shape.bvh_triangles[i])]);
  int axis = 0;
  const Vec3 ext = cbox.extent();
  if (ext.y() > ext[axis]) axis = 1;
  if (ext.z() > ext[axis]) axis = 2;
  // A full sort with the index as tie-break: the same tree on every standard library.
  std::sort(shape.bvh_triangles.begin() + begin, shape.bvh_triangles.begin() + end, [&](Index x, Index y) {
    const double cx = centroids[static_cast<std::size_t>(x)][axis], cy = centroids[static_cast<std::size_t>(y)][axis];
    return cx < cy || (cx == cy && x < y);
  });
  const Index mid = begin + (end - begin) / 2;
  const auto left = static_cast<Index>(shape.bvh.size());
  shape.bvh.emplace_back();
  shape.bvh.emplace_back();
  shape.bvh[static_cast<std::size_t>(node)].left = left;
  shape.bvh[static_cast<std::size_t>(node)].right = left + 1;
  build_bvh(shape, centroids, left, begin, mid);
  build_bvh(shape, centroids, left + 1, mid, end);
}

void build_grid(TetContactShape& shape) {
  const TetMesh& m = shape.mesh;
  const Index nt = m.num_tets();
  shape.grid_origin = shape.bounds.empty() ? Vec3::Zero() : shape.bounds.min;
  shape.grid_dims = {0, 0, 0};
  shape.cell_start.assign(1, 0);
  shape.cell_tets.clear();
  if (nt == 0 || shape.bounds.empty()) return;
  // Cell size: half the mean tet edge. Measured on box meshes, a query then tests ~17 tets per
  // cell instead of ~26 with the full mean edge (a quarter fewer instructions per collide call),
  // for ~3x the grid entries.
  double edge_sum = 0;
  for (Index e = 0; e < nt; ++e) {
    const Mat34 x = m.corners(e);
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j) edge_sum += (x.col(i) - x.col(j)).norm();
  }
  const Vec3 extent = shape.bounds.extent();
  double h = 0.5 * edge_sum / (6.0 * nt);
  if (!(h > 0)) h = std::max(extent.maxCoeff(), 1.0);
  // Never more than kCellsPerTet cells per tet (sparse meshes: shells, spread fragments).
  const double max_cells = kCellsPerTet * nt + 1;
  for (;;) {
    double cells = 1;
    for (int k = 0; k < 3; ++k) cells *= std::max(1.0, std::ceil(extent[k] / h));
    if (cells <= max_cells) break;
    h *= 1.25;
  }
  shape.cell_size = h;
  for (int k = 0; k < 3; ++k)
    shape.grid_dims[static_cast<std::size_t>(k)] = static_cast<std::int32_t>(std::max(1.0, std::ceil(extent[k] / h)));
  const auto [nx, ny, nz] = shape.grid_dims;
  // Degenerate and inverted tets contain nothing: they stay out of the grid.
  shape.tet_maps.assign(static_cast<std::size_t>(nt), {});
  std::vector<std::uint8_t> valid(static_cast<std::size_t>(nt), 0);
  for (Index e = 0; e < nt; ++e)
    valid[static_cast<std::size_t>(e)] = barycentric_map(m, e, shape.tet_maps[static_cast<std::size_t>(e)]);
  const auto cell_range = [&](Index e, std::array<std::int32_t, 3>& lo, std::array<std::int32_t, 3>& hi) {
    Aabb b;
    const Mat34 x = m.corners(e);
    for (int k = 0; k < 4; ++k) b.extend(x.col(k));
    // Padded by the containment tolerance (relative to the tet's size), so every point the
    // tolerant test accepts lies within a cell the tet is listed in.
    b = padded(b, 4 * kTetInsideTolerance * b.extent().maxCoeff());
    for (int k = 0; k < 3; ++k) {
      const auto dim = shape.grid_dims[static_cast<std::size_t>(k)];
      const auto cell = [&](double v) {
        const double c = std::floor((v - shape.grid_origin[k]) / h);
        return static_cast<std::int32_t>(std::clamp(c, 0.0, static_cast<double>(dim - 1)));
      };
      lo[static_cast<std::size_t>(k)] = cell(b.min[k]);
      hi[static_cast<std::size_t>(k)] = cell(b.max[k]);
    }
  };
  // Counting sort of (cell, tet) entries: count, prefix sum, fill in tet order.
  const std::size_t num_cells = static_cast<std::size_t>(nx) * ny * nz;
  shape.cell_start.assign(num_cells + 1, 0);
  std::array<std::int32_t, 3> lo{}, hi{};
  for (int pass = 0; pass < 2; ++pass) {
    for (Index e = 0; e < nt; ++e) {
      if (!valid[static_cast<std::size_t>(e)]) continue;
      cell_range(e, lo, hi);
      for (std::int32_t z = lo[2]; z <= hi[2]; ++z)
        for (std::int32_t y = lo[1]; y <= hi[1]; ++y)
          for (std::int32_t x = lo[0]; x <= hi[0]; ++x) {
            const std::size_t c =
                static_cast<std::size_t>(x) + static_cast<std::size_t>(nx) * (y + std::size_t(ny) * z);
            if (pass == 0)
              ++shape.cell_start[c + 1];
            else
              shape.cell_tets[static_cast<std::size_t>(shape.cell_start[c]++)] = e;
          }
    }
    if (pass == 0) {
      for (std::size_t c = 0; c < num_cells; ++c) shape.cell_start[c + 1] += shape.cell_start[c];
      shape.cell_tets.resize(static_cast<std::size_t>(shape.cell_start[num_cells]));
    }
  }
  // cell_start[c] now holds the end of cell c: shift back.
  for (std::size_t c = num_cells; c > 0; --c) shape.cell_start[c] = shape.cell_start[c - 1];
  shape.cell_start[0] = 0;
}

// Where the segment p + t dir (t in [0, 1]) crosses the boundary of `s`: up to kMaxCrossings
// parameters t, sorted (a crossing on a shared triangle edge may come twice).
int segment_crossings(const TetContactShape& s, const Vec3& p, const Vec3& dir, std::array<double, kMaxCrossings>& ts) {
  int count = 0;
  if (s.bvh.empty()) return 0;
  std::array<Index, kStackSize> stack{};
  int top = 0;
  stack[static_cast<std::size_t>(top++)] = 0;
  while (top > 0) {
    const auto& node = s.bvh[static_cast<std::size_t>(stack[static_cast<std::size_t>(--top)])];
    if (!segment_box(p, dir, node.box)) continue;
    if (node.left >= 0) {
      stack[static_cast<std::size_t>(top++)] = node.right;
      stack[static_cast<std::size_t>(top++)] = node.left;
      continue;
    }
    for (Index i = node.first; i < node.right; ++i) {
      const TriIndices& tri =
          s.surface.triangles[static_cast<std::size_t>(s.bvh_triangles[static_cast<std::size_t>(i)])];
      double t = 0;
      if (segment_triangle(p, dir, s.surface.positions[static_cast<std::size_t>(tri[0])],
                           s.surface.positions[static_cast<std::size_t>(tri[1])],
                           s.surface.positions[static_cast<std::size_t>(tri[2])], t) &&
          count < kMaxCrossings)
        ts[static_cast<std::size_t>(count++)] = t;
    }
  }
  std::sort(ts.begin(), ts.begin() + count);
  return count;
}

// t.apply(p), written out by columns: the general matrix-vector product is not always inlined,
// and this runs for every boundary vertex and edge end.
Vec3 place(const Transform& t, const Vec3& p) {
  return t.rotation.col(0) * p.x() + t.rotation.col(1) * p.y() + t.rotation.col(2) * p.z() + t.translation;
}

// The relative placement of one body in the other's frame: local_b = rotation * local_a + translation.
Transform placement_in(const Transform& from, const Transform& to) {
  Transform r;
  r.rotation = to.rotation.transpose() * from.rotation;
  r.translation = to.rotation.transpose() * (from.translation - to.translation);
  return r;
}

// Contact of a point `p` of one body (in the other body `s`'s frame) with `s`, if inside it or
// within `speculative` of its boundary. The local normal points from the point's body into `s`.
bool point_contact(const TetContactShape& s, const Vec3& p, bool inside, double speculative, Vec3& point, Vec3& normal,
                   double& separation) {
  BoundaryPoint bp;
  if (!closest_boundary_point(s, p, inside ? std::numeric_limits<double>::infinity() : speculative, bp)) return false;
  const Vec3& face_normal = s.triangle_normals[static_cast<std::size_t>(bp.triangle)];
  // Below this gap, p - q no longer gives a direction: use the face normal.
  const double tiny = 1e-9 * s.cell_size;
  if (inside) {
    // Minus the outward normal: the other body leaves along it, so `s` moves the opposite way.
    normal = -face_normal;
    separation = -bp.distance;
  } else {
    normal = bp.distance > tiny ? Vec3((bp.point - p) / bp.distance) : Vec3(-face_normal);
    separation = bp.distance;
  }
  if (normal.squaredNorm() == 0) normal = bp.distance > 0 ? Vec3((bp.point - p) / bp.distance) : Vec3::UnitY();
  point = 0.5 * (p + bp.point);
  return true;
}

// Contacts of the boundary vertices of `v` against `s`. `rel` maps v's frame into s's; `ts` places
// s in the world. `flip` (v is body B) turns the normals to point from A to B.
void vertex_contacts(const TetContactShape& v, const Transform& rel, const TetContactShape& s, const Transform& ts,
                     double speculative, bool flip, std::vector<PointContact>& out) {
  const double reach = std::max(speculative, 0.0);
  const Aabb near = padded(s.bounds, reach + 1e-6 * s.bounds.extent().maxCoeff());
  const std::uint32_t body = flip ? kTetFeatureBodyB : 0;
  const double sign = flip ? -1.0 : 1.0;
  const auto n = static_cast<Index>(v.surface.positions.size());
  for (Index i = 0; i < n; ++i) {
    const Vec3 p = place(rel, v.surface.positions[static_cast<std::size_t>(i)]);
    if (!near.contains(p)) continue;
    const bool inside = locate_tet(s, p) >= 0;
    if (!inside && speculative < 0) continue;
    PointContact c;
    if (!point_contact(s, p, inside, reach, c.point, c.normal, c.separation)) continue;
    c.point = ts.apply(c.point);
    c.normal = sign * (ts.rotation * c.normal);
    c.feature = body | static_cast<std::uint32_t>(i);
    out.push_back(c);
  }
}

// Contacts of the boundary edges of `v` that pass through `s` with both ends outside (same
// arguments as vertex_contacts).
void edge_contacts(const TetContactShape& v, const Transform& rel, const TetContactShape& s, const Transform& ts,
                   bool flip, std::vector<PointContact>& out) {
  const Aabb near = padded(s.bounds, 1e-6 * s.bounds.extent().maxCoeff());
  const std::uint32_t body = flip ? kTetFeatureBodyB : 0;
  const double sign = flip ? -1.0 : 1.0;
  std::array<double, kMaxCrossings> ts_cross{};
  const auto n = static_cast<Index>(v.boundary_edges.size());
  for (Index k = 0; k < n; ++k) {
    const auto& edge = v.boundary_edges[static_cast<std::size_t>(k)];
    const Vec3 p = place(rel, v.surface.positions[static_cast<std::size_t>(edge[0])]);
    const Vec3 q = place(rel, v.surface.positions[static_cast<std::size_t>(edge[1])]);
    Aabb seg;
    seg.extend(p);
    seg.extend(q);
    if (!boxes_overlap(seg, near)) continue;
    // An end inside: that vertex's contact covers the edge (and the grid look-up is cheaper than
    // the crossings).
    if (locate_tet(s, p) >= 0 || locate_tet(s, q) >= 0) continue;
    const Vec3 dir = q - p;
    const int count = segment_crossings(s, p, dir, ts_cross);
    if (count < 2) continue;
    // Each stretch between consecutive crossings whose midpoint is inside is a pass through `s`
    // (robust to crossings counted twice on a shared triangle edge); keep the deepest.
    bool found = false;
    PointContact best;
    for (int j = 0; j + 1 < count; ++j) {
      const double t0 = ts_cross[static_cast<std::size_t>(j)], t1 = ts_cross[static_cast<std::size_t>(j + 1)];
      if (t1 - t0 <= 1e-12) continue;
      const Vec3 m = p + 0.5 * (t0 + t1) * dir;
      if (locate_tet(s, m) < 0) continue;
      PointContact c;
      if (!point_contact(s, m, true, 0, c.point, c.normal, c.separation)) continue;
      if (!found || c.separation < best.separation) {
        best = c;
        found = true;
      }
    }
    if (!found) continue;
    best.point = ts.apply(best.point);
    best.normal = sign * (ts.rotation * best.normal);
    best.feature = body | kTetFeatureEdge | static_cast<std::uint32_t>(k);
    out.push_back(best);
  }
}

}  // namespace

TetContactShape make_tet_contact_shape(const TetMesh& mesh, const TetFaces& faces) {
  TetContactShape shape;
  shape.mesh = mesh;
  shape.surface = boundary_surface(mesh, faces);
  shape.bounds = mesh.bounds();
  const TriSurface& s = shape.surface;
  const auto nt = static_cast<Index>(s.triangles.size());

  shape.triangle_normals.resize(s.triangles.size());
  for (std::size_t t = 0; t < s.triangles.size(); ++t) {
    const auto& tri = s.triangles[t];
    const Vec3& a = s.positions[static_cast<std::size_t>(tri[0])];
    const Vec3 n =
        (s.positions[static_cast<std::size_t>(tri[1])] - a).cross(s.positions[static_cast<std::size_t>(tri[2])] - a);
    const double len = n.norm();
    shape.triangle_normals[t] = len > 0 ? Vec3(n / len) : Vec3::Zero();
  }

  // Unique boundary edges: every triangle's three, sorted and deduplicated.
  shape.boundary_edges.reserve(3 * s.triangles.size());
  for (const auto& tri : s.triangles)
    for (int k = 0; k < 3; ++k) {
      const Index i = tri[static_cast<std::size_t>(k)], j = tri[static_cast<std::size_t>((k + 1) % 3)];
      shape.boundary_edges.push_back({std::min(i, j), std::max(i, j)});
    }
  std::sort(shape.boundary_edges.begin(), shape.boundary_edges.end());
  shape.boundary_edges.erase(std::unique(shape.boundary_edges.begin(), shape.boundary_edges.end()),
                             shape.boundary_edges.end());

  build_grid(shape);

  if (nt > 0) {
    std::vector<Vec3> centroids(s.triangles.size());
    for (std::size_t t = 0; t < s.triangles.size(); ++t) {
      const auto& tri = s.triangles[t];
      centroids[t] = (s.positions[static_cast<std::size_t>(tri[0])] + s.positions[static_cast<std::size_t>(tri[1])] +
                      s.positions[static_cast<std::size_t>(tri[2])]) /
                     3.0;
    }
    shape.bvh_triangles.resize(s.triangles.size());
    for (Index t = 0; t < nt; ++t) shape.bvh_triangles[static_cast<std::size_t>(t)] = t;
    shape.bvh.reserve(2 * s.triangles.size() / kLeafSize + 2);
    shape.bvh.emplace_back();
    build_bvh(shape, centroids, 0, 0, nt);
  }
  return shape;
}

Index locate_tet(const TetContactShape& shape, const Vec3& p) {
  if (shape.cell_start.size() < 2) return -1;
  std::array<std::int32_t, 3> c{};
  for (int k = 0; k < 3; ++k) {
    const double f = std::floor((p[k] - shape.grid_origin[k]) / shape.cell_size);
    const auto dim = shape.grid_dims[static_cast<std::size_t>(k)];
    // Points beyond the grid by more than a cell cannot be in any (padded) tet box.
    if (!(f >= -1.0 && f <= static_cast<double>(dim))) return -1;
    c[static_cast<std::size_t>(k)] = static_cast<std::int32_t>(std::clamp(f, 0.0, static_cast<double>(dim - 1)));
  }
  const std::size_t cell = static_cast<std::size_t>(c[0]) +
                           static_cast<std::size_t>(shape.grid_dims[0]) *
                               (static_cast<std::size_t>(c[1]) + static_cast<std::size_t>(shape.grid_dims[1]) * c[2]);
  for (Index i = shape.cell_start[cell]; i < shape.cell_start[cell + 1]; ++i) {
    const Index e = shape.cell_tets[static_cast<std::size_t>(i)];
    if (tet_contains(shape.tet_maps[static_cast<std::size_t>(e)], p)) return e;
  }
  return -1;
}

bool closest_boundary_point(const TetContactShape& shape, const Vec3& p, double max_distance, BoundaryPoint& out) {
  if (shape.bvh.empty() || !(max_distance >= 0)) return false;
  double best = max_distance * max_distance;  // squared; inf stays inf
  bool found = false;
  std::array<Index, kStackSize> stack{};
  int top = 0;
  stack[static_cast<std::size_t>(top++)] = 0;
  while (top > 0) {
    const auto& node = shape.bvh[static_cast<std::size_t>(stack[static_cast<std::size_t>(--top)])];
    if (box_distance_squared(node.box, p) > best) continue;
    if (node.left >= 0) {
      // Nearer child last, so it is visited first and tightens the bound for the other.
      const auto& l = shape.bvh[static_cast<std::size_t>(node.left)];
      const auto& r = shape.bvh[static_cast<std::size_t>(node.right)];
      const bool left_first = box_distance_squared(l.box, p) <= box_distance_squared(r.box, p);
      stack[static_cast<std::size_t>(top++)] = left_first ? node.right : node.left;
      stack[static_cast<std::size_t>(top++)] = left_first ? node.left : node.right;
      continue;
    }
    for (Index i = node.first; i < node.right; ++i) {
      const Index t = shape.bvh_triangles[static_cast<std::size_t>(i)];
      const TriIndices& tri = shape.surface.triangles[static_cast<std::size_t>(t)];
      const Vec3 q = closest_on_triangle(p, shape.surface.positions[static_cast<std::size_t>(tri[0])],
                                         shape.surface.positions[static_cast<std::size_t>(tri[1])],
                                         shape.surface.positions[static_cast<std::size_t>(tri[2])]);
      const double d2 = (q - p).squaredNorm();
      if (d2 < best || (!found && d2 <= best)) {
        best = d2;
        found = true;
        out.point = q;
        out.triangle = t;
      }
    }
  }
  if (found) out.distance = std::sqrt(best);
  return found;
}

void collide_tet_shapes(const TetContactShape& a, const Transform& ta, const TetContactShape& b, const Transform& tb,
                        double speculative_distance, std::vector<PointContact>& out) {
  if (a.bounds.empty() || b.bounds.empty()) return;
  const Transform ab = placement_in(ta, tb), ba = placement_in(tb, ta);
  vertex_contacts(a, ab, b, tb, speculative_distance, false, out);
  vertex_contacts(b, ba, a, ta, speculative_distance, true, out);
  edge_contacts(a, ab, b, tb, false, out);
  edge_contacts(b, ba, a, ta, true, out);
}

void collide_tet_shape_plane(const TetContactShape& a, const Transform& ta, const Plane& plane,
                             double speculative_distance, std::vector<PointContact>& out) {
  const auto n = static_cast<Index>(a.surface.positions.size());
  for (Index i = 0; i < n; ++i) {
    const Vec3 x = ta.apply(a.surface.positions[static_cast<std::size_t>(i)]);
    const double d = plane.normal.dot(x) - plane.offset;
    if (d > speculative_distance) continue;
    PointContact c;
    c.point = x - 0.5 * d * plane.normal;
    c.normal = -plane.normal;
    c.separation = d;
    c.feature = static_cast<std::uint32_t>(i);
    out.push_back(c);
  }
}

}  // namespace shatter
