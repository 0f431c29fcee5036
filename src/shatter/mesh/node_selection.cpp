// Node selection by ids, box, plane or named set; lumped boundary area; rigid-motion check
// (see node_selection.h).
#include "shatter/mesh/node_selection.h"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <unordered_map>

#include "shatter/mesh/topology.h"

namespace shatter {
namespace {

std::string fmt_vec(const Vec3& v) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "[%g, %g, %g]", v.x(), v.y(), v.z());
  return buf;
}

double default_tolerance(const TetMesh& mesh) {
  const Aabb b = mesh.bounds();
  return 1e-6 * b.extent().norm();
}

}  // namespace

Result<std::vector<Index>> select_nodes(const TetMesh& mesh, const NodeSelector& s) {
  std::vector<Index> out;
  const double tol = s.tolerance >= 0 ? s.tolerance : default_tolerance(mesh);
  switch (s.kind) {
    case NodeSelector::Kind::ids: {
      if (s.ids.empty()) return make_error("the list of node ids is empty");
      std::unordered_map<FileId, Index> index_of;
      index_of.reserve(static_cast<std::size_t>(mesh.num_nodes()));
      for (Index i = 0; i < mesh.num_nodes(); ++i) index_of.emplace(mesh.node_id(i), i);
      for (std::size_t k = 0; k < s.ids.size(); ++k) {
        const auto it = index_of.find(s.ids[k]);
        if (it == index_of.end()) {
          FileId lo = mesh.num_nodes() > 0 ? mesh.node_id(0) : 0, hi = lo;
          for (Index i = 0; i < mesh.num_nodes(); ++i) {
            lo = std::min(lo, mesh.node_id(i));
            hi = std::max(hi, mesh.node_id(i));
          }
          return make_error("node id " + std::to_string(s.ids[k]) + " (entry " + std::to_string(k) +
                            ") is not in the mesh (its node ids range from " + std::to_string(lo) + " to " +
                            std::to_string(hi) + ")");
        }
        out.push_back(it->second);
      }
      break;
    }
    case NodeSelector::Kind::box: {
      for (Index i = 0; i < mesh.num_nodes(); ++i) {
        const Vec3& p = mesh.positions[i];
        if ((p.array() >= s.box.min.array() - tol).all() && (p.array() <= s.box.max.array() + tol).all())
          out.push_back(i);
      }
      if (out.empty()) {
        const Aabb b = mesh.bounds();
        return make_error("the box " + fmt_vec(s.box.min) + ".." + fmt_vec(s.box.max) +
                          " contains no node of the mesh (mesh bounds " + fmt_vec(b.min) + ".." + fmt_vec(b.max) + ")");
      }
      break;
    }
    case NodeSelector::Kind::plane: {
      const double len = s.normal.norm();
      if (!(len > 0)) return make_error("the plane's normal is zero");
      const Vec3 n = s.normal / len;
      for (Index i = 0; i < mesh.num_nodes(); ++i)
        if (std::abs(n.dot(mesh.positions[i] - s.point)) <= tol) out.push_back(i);
      if (out.empty()) {
        char buf[64];
        std::snprintf(buf, sizeof buf, "%g", tol);
        return make_error("the plane through " + fmt_vec(s.point) + " with normal " + fmt_vec(s.normal) +
                          " passes within " + buf + " m of no node of the mesh");
      }
      break;
    }
    case NodeSelector::Kind::set: {
      const auto it = mesh.node_sets.find(s.set);
      if (it == mesh.node_sets.end()) {
        std::string names;
        for (const auto& [name, nodes] : mesh.node_sets) names += (names.empty() ? "" : ", ") + name;
        return make_error("the mesh has no node set \"" + s.set + "\" (" +
                          (names.empty() ? std::string("it has no node sets") : "its sets: " + names) + ")");
      }
      if (it->second.empty()) return make_error("node set \"" + s.set + "\" is empty");
      out = it->second;
      break;
    }
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

std::string describe(const NodeSelector& s) {
  switch (s.kind) {
    case NodeSelector::Kind::ids: return std::to_string(s.ids.size()) + " node id(s)";
    case NodeSelector::Kind::box: return "box " + fmt_vec(s.box.min) + ".." + fmt_vec(s.box.max);
    case NodeSelector::Kind::plane: return "plane through " + fmt_vec(s.point) + " normal " + fmt_vec(s.normal);
    case NodeSelector::Kind::set: return "node set \"" + s.set + "\"";
  }
  return "?";
}

std::vector<double> lumped_boundary_area(const TetMesh& mesh, const std::vector<Index>& nodes) {
  std::vector<char> selected(static_cast<std::size_t>(mesh.num_nodes()), 0);
  for (Index i : nodes) selected[static_cast<std::size_t>(i)] = 1;
  const TetFaces faces = compute_faces(mesh);
  std::vector<double> area_of_node(static_cast<std::size_t>(mesh.num_nodes()), 0.0);
  for (Index f = 0; f < faces.num_faces(); ++f) {
    if (!faces.is_boundary(f)) continue;
    const TriIndices& t = faces.faces[f];
    if (!selected[t[0]] || !selected[t[1]] || !selected[t[2]]) continue;
    const Vec3& a = mesh.positions[t[0]];
    const double area = 0.5 * (mesh.positions[t[1]] - a).cross(mesh.positions[t[2]] - a).norm();
    for (Index v : t) area_of_node[static_cast<std::size_t>(v)] += area / 3.0;
  }
  std::vector<double> out;
  out.reserve(nodes.size());
  for (Index i : nodes) out.push_back(area_of_node[static_cast<std::size_t>(i)]);
  return out;
}

bool holds_rigid_motion(const TetMesh& mesh, const std::vector<Index>& piece_nodes,
                        const std::vector<std::uint8_t>& held) {
  Aabb box;
  for (Index i : piece_nodes) box.extend(mesh.positions[i]);
  const Vec3 centre = 0.5 * (box.min + box.max);
  const double scale = std::max(box.extent().norm(), std::numeric_limits<double>::min());
  Eigen::Matrix<double, 6, 6> gram = Eigen::Matrix<double, 6, 6>::Zero();
  for (Index i : piece_nodes) {
    if (held[i] == 0) continue;
    const Vec3 p = (mesh.positions[i] - centre) / scale;
    // velocity of component c under motion (t, w): t_c + (w x p)_c
    for (int c = 0; c < 3; ++c) {
      if (!(held[i] & (1u << c))) continue;
      Eigen::Matrix<double, 6, 1> row = Eigen::Matrix<double, 6, 1>::Zero();
      row[c] = 1.0;
      const Vec3 e = Vec3::Unit(c);
      const Vec3 rot = p.cross(e);  // (w x p)_c = w . (p x e_c)
      row.tail<3>() = rot;
      gram += row * row.transpose();
    }
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eig(gram, Eigen::EigenvaluesOnly);
  return eig.eigenvalues()[0] > 1e-12 * std::max(1.0, eig.eigenvalues()[5]);
}

}  // namespace shatter
