// Node selection by ids, box, plane or named set (see node_selection.h).
#include "shatter/scene/node_selection.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <unordered_map>

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
                            ") is not in the mesh (its node ids range from " + std::to_string(lo) +
                            " to " + std::to_string(hi) + ")");
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
                          " contains no node of the mesh (mesh bounds " + fmt_vec(b.min) + ".." +
                          fmt_vec(b.max) + ")");
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

}  // namespace shatter
