// Feature sharpening by the dual-contouring quadric; see sharpen.h.
#include "shatter/meshing/sharpen.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <span>
#include <vector>

#include <Eigen/Eigenvalues>

#include "shatter/core/parallel.h"
#include "shatter/mesh/quality.h"
#include "shatter/mesh/topology.h"

namespace shatter {
namespace {

// Unit normal of the shape at p (central differences; the CSG distance is only a bound, but its
// gradient points along the normal of the active surface).
Vec3 normal_at(const Sdf& sdf, const Vec3& p, double eps) {
  Vec3 g;
  for (int a = 0; a < 3; ++a) {
    Vec3 d = Vec3::Zero();
    d[a] = eps;
    g[a] = sdf(p + d) - sdf(p - d);
  }
  const double n = g.norm();
  return n > 0 ? Vec3(g / n) : Vec3::Zero();
}

// Newton steps along the gradient onto the zero set (until |sdf| <= tol).
Vec3 project(const Sdf& sdf, Vec3 p, double eps, double tol) {
  for (int it = 0; it < 4; ++it) {
    const double f = sdf(p);
    if (std::abs(f) <= tol) break;
    const Vec3 n = normal_at(sdf, p, eps);
    if (n.isZero()) break;
    p -= f * n;
  }
  return p;
}

struct Sharpener {
  TetMesh& mesh;
  const Sdf& sdf;
  const SharpenDef& def;
  // Cosines of the smallest and largest dihedral angle a moved node's tets may have.
  double cos_min = std::cos(def.min_dihedral_deg * std::numbers::pi / 180.0);
  double cos_max = std::cos(def.max_dihedral_deg * std::numbers::pi / 180.0);
  // Compressed rows, for boundary nodes only (slot b of boundary_nodes[b]): the tets around
  // each boundary node and its boundary triangles.
  std::vector<Index> boundary_nodes, slot;  // slot: node -> row, or -1
  std::vector<std::int64_t> star_start, ring_start;
  std::vector<Index> star_tets;
  std::vector<TriIndices> ring_tris;

  void build() {
    const TriSurface s = boundary_surface(mesh);
    slot.assign(mesh.positions.size(), -1);
    for (Index node : s.vertex_node) {  // increasing node order
      slot[static_cast<std::size_t>(node)] = static_cast<Index>(boundary_nodes.size());
      boundary_nodes.push_back(node);
    }
    const std::size_t nb = boundary_nodes.size();
    std::vector<std::int64_t> count(nb + 1, 0);
    for (const TetIndices& t : mesh.tets)
      for (Index v : t)
        if (slot[static_cast<std::size_t>(v)] >= 0)
          ++count[static_cast<std::size_t>(slot[static_cast<std::size_t>(v)]) + 1];
    star_start.assign(nb + 1, 0);
    for (std::size_t i = 0; i < nb; ++i) star_start[i + 1] = star_start[i] + count[i + 1];
    star_tets.resize(static_cast<std::size_t>(star_start[nb]));
    std::vector<std::int64_t> fill(star_start.begin(), star_start.end() - 1);
    for (Index e = 0; e < mesh.num_tets(); ++e)
      for (Index v : mesh.tets[static_cast<std::size_t>(e)])
        if (const Index r = slot[static_cast<std::size_t>(v)]; r >= 0)
          star_tets[static_cast<std::size_t>(fill[static_cast<std::size_t>(r)]++)] = e;
    std::fill(count.begin(), count.end(), 0);
    for (const TriIndices& t : s.triangles)
      for (int k = 0; k < 3; ++k) ++count[static_cast<std::size_t>(t[k]) + 1];
    ring_start.assign(nb + 1, 0);
    for (std::size_t i = 0; i < nb; ++i) ring_start[i + 1] = ring_start[i] + count[i + 1];
    ring_tris.resize(static_cast<std::size_t>(ring_start[nb]));
    fill.assign(ring_start.begin(), ring_start.end() - 1);
    for (const TriIndices& t : s.triangles) {
      // boundary_surface numbers its own vertices (in node order); map back to mesh nodes.
      TriIndices g;
      for (int k = 0; k < 3; ++k) g[k] = s.vertex_node[static_cast<std::size_t>(t[k])];
      for (int k = 0; k < 3; ++k) ring_tris[static_cast<std::size_t>(fill[static_cast<std::size_t>(t[k])]++)] = g;
    }
  }
  [[nodiscard]] std::span<const Index> star(Index v) const {
    const auto r = static_cast<std::size_t>(slot[static_cast<std::size_t>(v)]);
    return {star_tets.data() + star_start[r], static_cast<std::size_t>(star_start[r + 1] - star_start[r])};
  }
  [[nodiscard]] std::span<const TriIndices> ring(Index v) const {
    const auto r = static_cast<std::size_t>(slot[static_cast<std::size_t>(v)]);
    return {ring_tris.data() + ring_start[r], static_cast<std::size_t>(ring_start[r + 1] - ring_start[r])};
  }

  // Target of node v, or v's own position when it should not move.
  [[nodiscard]] Vec3 target(Index v) const {
    const double h = def.edge_length, eps = 1e-4 * h;
    const Vec3 xv = mesh.positions[static_cast<std::size_t>(v)];
    const double cos_crease = std::cos(def.crease_angle_deg * std::numbers::pi / 180.0);
    // Cheap filter first: on a smooth patch the node's boundary triangles face about the same way.
    {
      std::vector<Vec3> tn;
      for (const TriIndices& t : ring(v)) {
        const Vec3 n =
            (mesh.positions[static_cast<std::size_t>(t[1])] - mesh.positions[static_cast<std::size_t>(t[0])])
                .cross(mesh.positions[static_cast<std::size_t>(t[2])] - mesh.positions[static_cast<std::size_t>(t[0])]);
        if (n.norm() > 0) tn.push_back(n.normalized());
      }
      bool spread = false;
      for (std::size_t i = 0; i < tn.size() && !spread; ++i)
        for (std::size_t j = i + 1; j < tn.size() && !spread; ++j) spread = tn[i].dot(tn[j]) < cos_crease;
      if (!spread) return xv;
    }
    std::vector<Vec3> pts, nrm;
    auto add = [&](const Vec3& q) {
      const Vec3 p = project(sdf, q, eps, 1e-9 * h);
      const Vec3 n = normal_at(sdf, p, eps);
      if (n.isZero() || (p - q).norm() > 0.5 * h) return;
      pts.push_back(p);
      nrm.push_back(n);
    };
    add(xv);
    for (const TriIndices& t : ring(v)) {
      const Vec3 a = mesh.positions[static_cast<std::size_t>(t[0])], b = mesh.positions[static_cast<std::size_t>(t[1])],
                 c = mesh.positions[static_cast<std::size_t>(t[2])];
      add((a + b + c) / 3.0);
      for (int k = 0; k < 3; ++k)
        if (t[k] != v) add(0.5 * (xv + mesh.positions[static_cast<std::size_t>(t[k])]));
    }
    if (pts.size() < 3) return xv;
    // A crease: two sample normals further apart than the crease angle.
    bool crease = false;
    for (std::size_t i = 0; i < nrm.size() && !crease; ++i)
      for (std::size_t j = i + 1; j < nrm.size(); ++j)
        if (nrm[i].dot(nrm[j]) < cos_crease) {
          crease = true;
          break;
        }
    if (!crease) return xv;
    // QEF: minimise sum (n_i . (x - p_i))^2 about the mass point xv, dropping directions whose
    // eigenvalue is below 10 % of the largest (Ju et al. 2002; Lindstrom 2000).
    Mat3 A = Mat3::Zero();
    Vec3 b = Vec3::Zero();
    for (std::size_t i = 0; i < pts.size(); ++i) {
      A += nrm[i] * nrm[i].transpose();
      b += nrm[i] * nrm[i].dot(pts[i] - xv);
    }
    Eigen::SelfAdjointEigenSolver<Mat3> es(A);
    const Vec3& lam = es.eigenvalues();
    const Mat3& U = es.eigenvectors();
    Vec3 dx = Vec3::Zero();
    for (int k = 0; k < 3; ++k)
      if (lam[k] > 0.1 * lam[2]) dx += U.col(k) * (U.col(k).dot(b) / lam[k]);
    const Vec3 x = xv + dx;
    if (!(dx.norm() < 0.5 * h) || !(std::abs(sdf(x)) < 0.02 * h)) return xv;
    return x;
  }

  [[nodiscard]] bool shapes_ok(Index v, const Vec3& x) const {
    for (Index e : star(v)) {
      Mat34 c = mesh.corners(e);
      for (int k = 0; k < 4; ++k)
        if (mesh.tets[static_cast<std::size_t>(e)][static_cast<std::size_t>(k)] == v) c.col(k) = x;
      if (!(signed_volume(c.col(0), c.col(1), c.col(2), c.col(3)) > 0)) return false;
      for (double cs : dihedral_cosines(c))
        if (!(cs <= cos_min && cs >= cos_max)) return false;
    }
    return true;
  }
};

}  // namespace

Result<SharpenReport> sharpen_features(TetMesh& mesh, const Sdf& sdf, const SharpenDef& def) {
  if (!(def.edge_length > 0) || !std::isfinite(def.edge_length))
    return field_error("edge_length", "expected a length > 0 m");
  if (sdf.empty()) return field_error("shape", "no shape given");
  Sharpener s{mesh, sdf, def};
  s.build();
  SharpenReport report;
  report.boundary_nodes = static_cast<Index>(s.boundary_nodes.size());
  const std::size_t nb = s.boundary_nodes.size();
  std::vector<Vec3> targets(nb);
  std::vector<char> dirty(nb, 1), next(nb);
  for (int pass = 0; pass < def.passes; ++pass) {
    // Targets from the current positions (in parallel) for the nodes whose surroundings changed
    // (all on the first pass), then moves in node order (sequential, each checked against the
    // positions the earlier moves left).
    parallel_for(
        0, static_cast<std::int64_t>(nb),
        [&](std::int64_t i) {
          const Index v = s.boundary_nodes[static_cast<std::size_t>(i)];
          targets[static_cast<std::size_t>(i)] =
              dirty[static_cast<std::size_t>(i)] ? s.target(v) : mesh.positions[static_cast<std::size_t>(v)];
        },
        16);
    std::fill(next.begin(), next.end(), 0);
    Index moved = 0;
    for (std::size_t i = 0; i < nb; ++i) {
      const Index v = s.boundary_nodes[i];
      if (targets[i] == mesh.positions[static_cast<std::size_t>(v)]) continue;
      if (!s.shapes_ok(v, targets[i])) continue;
      mesh.positions[static_cast<std::size_t>(v)] = targets[i];
      ++moved;
      for (const TriIndices& t : s.ring(v))
        for (Index w : t) next[static_cast<std::size_t>(s.slot[static_cast<std::size_t>(w)])] = 1;
    }
    report.moved += moved;
    if (moved == 0) break;
    dirty.swap(next);
  }
  return report;
}

}  // namespace shatter
