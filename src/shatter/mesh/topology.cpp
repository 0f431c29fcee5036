#include "shatter/mesh/topology.h"

#include <algorithm>
#include <numeric>

#include "shatter/core/assert.h"

namespace shatter {

TetFaces compute_faces(const TetMesh& mesh) {
  // Each face is listed under its smallest corner v. The tets with a face there are among v's
  // incident tets, which node_tets gives in increasing order: walking them, and each tet's faces
  // in local order, lists v's faces in (tet, local) order without a global sort. A stable sort of
  // that short list by the other two corners then gives the order of (key, tet, local).
  struct Entry {
    std::int64_t key;  // the two larger corners, (b << 32) | c
    Index tet;
    int local;
  };
  const Index nt = mesh.num_tets();
  const NodeTets incidence = node_tets(mesh);
  TetFaces out;
  out.tet_faces.assign(static_cast<std::size_t>(nt), {-1, -1, -1, -1});
  // A closed mesh has 2 nt + (boundary faces) / 2 faces.
  out.faces.reserve(2 * static_cast<std::size_t>(nt) + 64);
  out.face_tets.reserve(2 * static_cast<std::size_t>(nt) + 64);
  std::vector<Entry> bucket;
  auto list = [&](Index b, Index c, Index e, int k) {
    bucket.push_back({(static_cast<std::int64_t>(b) << 32) | static_cast<std::uint32_t>(c), e, k});
  };
  for (Index v = 0; v < mesh.num_nodes(); ++v) {
    bucket.clear();
    Index previous = -1;
    for (const Index e : incidence.of(v)) {
      if (e == previous) continue;  // a degenerate tet lists v twice
      previous = e;
      const TetIndices& t = mesh.tets[e];
      if (t[0] == t[1] || t[0] == t[2] || t[0] == t[3] || t[1] == t[2] || t[1] == t[3] || t[2] == t[3]) {
        // A degenerate tet (a repeated node): each face's sorted corners.
        for (int k = 0; k < 4; ++k) {
          std::array<Index, 3> key = {t[kTetFaces[k][0]], t[kTetFaces[k][1]], t[kTetFaces[k][2]]};
          std::sort(key.begin(), key.end());
          if (key[0] == v) list(key[1], key[2], e, k);
        }
        continue;
      }
      // v is the smallest corner of the faces through it opposite each corner k whose other two
      // corners are above v: all three when v is the tet's smallest corner, the one opposite the
      // only corner below v when there is one, else none. Each face is listed under one node only.
      int below = 0, low = -1;
      for (int i = 0; i < 4; ++i)
        if (t[i] < v) {
          ++below;
          low = i;
        }
      if (below > 1) continue;
      for (int k = 0; k < 4; ++k) {
        if (t[k] == v || (below == 1 && k != low)) continue;
        // The face's other two corners: neither k nor v's own.
        Index b = -1, c = -1;
        for (int i = 0; i < 4; ++i)
          if (i != k && t[i] != v) (b < 0 ? b : c) = t[i];
        list(std::min(b, c), std::max(b, c), e, k);
      }
    }
    // Insertion sort: stable, and the lists are short (a node's share of its tets' faces).
    for (std::size_t i = 1; i < bucket.size(); ++i) {
      const Entry x = bucket[i];
      std::size_t j = i;
      for (; j > 0 && bucket[j - 1].key > x.key; --j) bucket[j] = bucket[j - 1];
      bucket[j] = x;
    }
    for (std::size_t i = 0; i < bucket.size();) {
      std::size_t j = i;
      while (j < bucket.size() && bucket[j].key == bucket[i].key) ++j;
      const Index f = static_cast<Index>(out.faces.size());
      const Entry& first = bucket[i];
      const TetIndices& t = mesh.tets[first.tet];
      out.faces.push_back({t[kTetFaces[first.local][0]], t[kTetFaces[first.local][1]], t[kTetFaces[first.local][2]]});
      out.face_tets.push_back({first.tet, j - i > 1 ? bucket[i + 1].tet : Index(-1)});
      for (std::size_t m = i; m < j; ++m) {
        out.tet_faces[bucket[m].tet][bucket[m].local] = f;
        if (m >= i + 2) out.overshared.push_back({f, bucket[m].tet});
      }
      i = j;
    }
  }
  return out;
}

TriSurface boundary_surface(const TetMesh& mesh, const TetFaces& faces) {
  TriSurface s;
  std::vector<Index> vertex_of_node(mesh.positions.size(), -1);
  for (Index f = 0; f < faces.num_faces(); ++f)
    if (faces.is_boundary(f))
      for (Index v : faces.faces[f]) vertex_of_node[v] = 0;
  for (Index i = 0; i < mesh.num_nodes(); ++i)
    if (vertex_of_node[i] == 0) {
      vertex_of_node[i] = static_cast<Index>(s.positions.size());
      s.positions.push_back(mesh.positions[i]);
      s.vertex_node.push_back(i);
    }
  for (Index f = 0; f < faces.num_faces(); ++f)
    if (faces.is_boundary(f)) {
      const TriIndices& t = faces.faces[f];
      s.triangles.push_back({vertex_of_node[t[0]], vertex_of_node[t[1]], vertex_of_node[t[2]]});
      s.triangle_tet.push_back(faces.face_tets[f][0]);
    }
  return s;
}

TriSurface boundary_surface(const TetMesh& mesh) { return boundary_surface(mesh, compute_faces(mesh)); }

namespace {
Index find_root(std::vector<Index>& parent, Index i) {
  while (parent[i] != i) {
    parent[i] = parent[parent[i]];
    i = parent[i];
  }
  return i;
}
}  // namespace

Components connected_components(const TetMesh& mesh) {
  // Union-find over nodes through tets, then label tets by their first node's root.
  std::vector<Index> parent(mesh.positions.size());
  std::iota(parent.begin(), parent.end(), Index(0));
  for (const TetIndices& t : mesh.tets)
    for (int k = 1; k < 4; ++k) {
      const Index a = find_root(parent, t[0]);
      const Index b = find_root(parent, t[k]);
      if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
  Components c;
  c.tet_component.resize(mesh.tets.size());
  std::vector<Index> label(mesh.positions.size(), -1);
  for (Index e = 0; e < mesh.num_tets(); ++e) {
    const Index r = find_root(parent, mesh.tets[e][0]);
    if (label[r] < 0) label[r] = c.count++;
    c.tet_component[e] = label[r];
  }
  return c;
}

namespace {
// Counting sort of (node, tet) pairs into CSR, for the nodes with wanted(v) only; tets ascend
// in each list.
template <class Wanted>
NodeTets node_tets_where(const TetMesh& mesh, Wanted wanted) {
  NodeTets n;
  n.begin.assign(mesh.positions.size() + 1, 0);
  for (const TetIndices& t : mesh.tets)
    for (Index v : t)
      if (wanted(v)) ++n.begin[v + 1];
  for (std::size_t i = 1; i < n.begin.size(); ++i) n.begin[i] += n.begin[i - 1];
  n.tets.resize(static_cast<std::size_t>(n.begin.back()));
  std::vector<Index> fill(n.begin.begin(), n.begin.end() - 1);
  for (Index e = 0; e < mesh.num_tets(); ++e)
    for (Index v : mesh.tets[e])
      if (wanted(v)) n.tets[fill[v]++] = e;
  return n;
}
}  // namespace

NodeTets node_tets(const TetMesh& mesh) {
  return node_tets_where(mesh, [](Index) { return true; });
}

NodeTets node_tets(const TetMesh& mesh, std::span<const char> wanted) {
  SHATTER_CHECK(wanted.size() == mesh.positions.size());
  return node_tets_where(mesh, [&](Index v) { return wanted[v] != 0; });
}

Index face_neighbor(const TetMesh& mesh, const NodeTets& incidence, Index e, int k) {
  const TetIndices& t = mesh.tets[e];
  // Walk the tets of the face's node with the fewest (each list is in ascending tet order) and
  // look for the other two nodes among each tet's four: no searches in the other lists.
  std::array<Index, 3> v{t[kTetFaces[k][0]], t[kTetFaces[k][1]], t[kTetFaces[k][2]]};
  for (int i = 1; i < 3; ++i)
    if (incidence.of(v[i]).size() < incidence.of(v[0]).size()) std::swap(v[0], v[i]);
  for (Index n : incidence.of(v[0])) {
    if (n == e) continue;
    const TetIndices& u = mesh.tets[n];
    const bool has1 = u[0] == v[1] || u[1] == v[1] || u[2] == v[1] || u[3] == v[1];
    const bool has2 = u[0] == v[2] || u[1] == v[2] || u[2] == v[2] || u[3] == v[2];
    if (has1 && has2) return n;
  }
  return -1;
}

}  // namespace shatter
