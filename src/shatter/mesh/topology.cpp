#include "shatter/mesh/topology.h"

#include <algorithm>
#include <numeric>

#include "shatter/core/assert.h"
#include "shatter/core/parallel.h"

namespace shatter {

namespace {

// One face from the run of list entries (each with .tet and .local) that share it, in (tet, local)
// order: its corners as the run's first tet sees them, its first two tets, any further ones as
// overshared; each entry's slot of tet_faces gets the face's number (faces' size before).
template <class Entry>
void add_face(const TetMesh& mesh, std::span<const Entry> run, std::vector<TriIndices>& faces,
              std::vector<std::array<Index, 2>>& face_tets, std::vector<std::array<Index, 4>>& tet_faces,
              std::vector<std::array<Index, 2>>& overshared) {
  const Index f = static_cast<Index>(faces.size());
  const TetIndices& t = mesh.tets[run[0].tet];
  const auto& corners = kTetFaces[run[0].local];
  faces.push_back({t[corners[0]], t[corners[1]], t[corners[2]]});
  face_tets.push_back({run[0].tet, run.size() > 1 ? run[1].tet : Index(-1)});
  for (std::size_t m = 0; m < run.size(); ++m) {
    tet_faces[run[m].tet][run[m].local] = f;
    if (m >= 2) overshared.push_back({f, run[m].tet});
  }
}

}  // namespace

TetFaces compute_faces(const TetMesh& mesh) {
  // Each face is listed under its smallest corner v. The tets with a face there are among v's
  // incident tets, which node_tets gives in increasing order: walking them, and each tet's faces
  // in local order, lists v's faces in (tet, local) order without a global sort. A stable sort of
  // that short list by the other two corners then gives the order of (key, tet, local).
  //
  // On several threads the nodes go in blocks (about eight per thread). Each block lists its
  // nodes' faces into its own arrays, numbered from 0, side by side; the arrays are then joined in
  // block order and each tet's face numbers moved by its block's offset. The faces come in node
  // order however the nodes are blocked, so the table is the same on any thread count.
  struct Entry {
    std::int64_t key;  // the two larger corners, (b << 32) | c
    Index tet;
    int local;
  };
  struct Block {
    std::vector<TriIndices> faces;
    std::vector<std::array<Index, 2>> face_tets;
    std::vector<std::array<Index, 2>> overshared;
  };
  const Index nt = mesh.num_tets();
  const Index nn = mesh.num_nodes();
  const NodeTets incidence = node_tets(mesh);
  TetFaces out;
  out.tet_faces.assign(static_cast<std::size_t>(nt), {-1, -1, -1, -1});
  // Below about 16k tets (0.5 ms) the join's extra pass and waking the workers cost more than the
  // second thread saves.
  const int threads = nt >= 16384 && !detail::in_parallel_region() ? num_threads() : 1;
  const Index num_blocks = threads > 1 ? std::min<Index>(8 * threads, std::max<Index>(1, nn / 256)) : 1;
  const Index block_nodes = (nn + num_blocks - 1) / num_blocks;
  std::vector<Block> blocks(static_cast<std::size_t>(num_blocks));
  auto list_block = [&](std::int64_t block_index) {
    Block& block = blocks[static_cast<std::size_t>(block_index)];
    const Index first_node = std::min(nn, static_cast<Index>(block_index) * block_nodes);
    const Index last_node = std::min(nn, first_node + block_nodes);
    // About 2 faces per tet, and each tet is listed under its 4 corners: half a face per entry.
    const auto block_tets = static_cast<std::size_t>(incidence.begin[last_node] - incidence.begin[first_node]);
    block.faces.reserve(block_tets / 2 + 16);
    block.face_tets.reserve(block_tets / 2 + 16);
    std::vector<Entry> bucket;
    auto list = [&](Index b, Index c, Index e, int k) {
      bucket.push_back({(static_cast<std::int64_t>(b) << 32) | static_cast<std::uint32_t>(c), e, k});
    };
    for (Index v = first_node; v < last_node; ++v) {
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
      // Each (tet, local face) is listed under exactly one node, so blocks never write the same
      // entry of tet_faces.
      for (std::size_t i = 0; i < bucket.size();) {
        std::size_t j = i;
        while (j < bucket.size() && bucket[j].key == bucket[i].key) ++j;
        add_face(mesh, std::span<const Entry>(bucket).subspan(i, j - i), block.faces, block.face_tets, out.tet_faces,
                 block.overshared);
        i = j;
      }
    }
  };
  parallel_for(0, num_blocks, [&](std::int64_t b) { list_block(b); }, 2);

  // Join the blocks in order.
  std::vector<Index> offset(static_cast<std::size_t>(num_blocks) + 1, 0);
  for (Index b = 0; b < num_blocks; ++b)
    offset[b + 1] = offset[b] + static_cast<Index>(blocks[static_cast<std::size_t>(b)].faces.size());
  if (num_blocks == 1) {
    out.faces = std::move(blocks[0].faces);
    out.face_tets = std::move(blocks[0].face_tets);
    out.overshared = std::move(blocks[0].overshared);
    return out;
  }
  out.faces.resize(static_cast<std::size_t>(offset.back()));
  out.face_tets.resize(static_cast<std::size_t>(offset.back()));
  parallel_for(
      0, num_blocks,
      [&](std::int64_t b) {
        const Block& block = blocks[static_cast<std::size_t>(b)];
        std::copy(block.faces.begin(), block.faces.end(), out.faces.begin() + offset[b]);
        std::copy(block.face_tets.begin(), block.face_tets.end(), out.face_tets.begin() + offset[b]);
      },
      2);
  for (Index b = 0; b < num_blocks; ++b)
    for (const auto& [f, e] : blocks[static_cast<std::size_t>(b)].overshared)
      out.overshared.push_back({f + offset[b], e});
  // A tet's local face k was numbered in the block of the face's smallest corner.
  parallel_for(
      0, nt,
      [&](std::int64_t e) {
        const TetIndices& t = mesh.tets[e];
        for (int k = 0; k < 4; ++k) {
          const Index v = std::min({t[kTetFaces[k][0]], t[kTetFaces[k][1]], t[kTetFaces[k][2]]});
          out.tet_faces[e][k] += offset[v / block_nodes];
        }
      },
      4096);
  return out;
}

namespace {

// A face's corners sorted, as compute_faces orders the faces: the smallest, then the other two.
struct FaceKey {
  Index v = 0;
  std::int64_t rest = 0;  // (b << 32) | c, b <= c
  friend bool operator==(const FaceKey&, const FaceKey&) = default;
  friend bool operator<(const FaceKey& x, const FaceKey& y) { return x.v != y.v ? x.v < y.v : x.rest < y.rest; }
};

FaceKey face_key(Index a, Index b, Index c) {
  if (a > b) std::swap(a, b);
  if (b > c) std::swap(b, c);
  if (a > b) std::swap(a, b);
  return {a, (static_cast<std::int64_t>(b) << 32) | static_cast<std::uint32_t>(c)};
}

FaceKey face_key(const TetIndices& t, int k) {
  return face_key(t[kTetFaces[k][0]], t[kTetFaces[k][1]], t[kTetFaces[k][2]]);
}

}  // namespace

TetFaces update_faces(const TetMesh& before, const TetFaces& before_faces, const TetMesh& after) {
  const Index nb = before.num_tets();
  const Index na = after.num_tets();
  const Index nf = before_faces.num_faces();
  if (!before_faces.overshared.empty() || static_cast<Index>(before_faces.tet_faces.size()) != nb)
    return compute_faces(after);
  // Tets of `after` with before's corners at the same index keep their faces.
  std::vector<char> same(static_cast<std::size_t>(na), 0);
  for (Index e = 0; e < std::min(na, nb); ++e) same[e] = after.tets[e] == before.tets[e];
  const auto kept = [&](Index e) { return e < na && same[e] != 0; };

  // The faces to search again: every face of a changed or new tet, and the faces of kept tets
  // whose neighbour in `before` changed. In (key, tet, local) order, as compute_faces lists them.
  struct Entry {
    FaceKey key;
    Index tet;
    int local;
  };
  std::vector<Entry> searched;
  for (Index e = 0; e < na; ++e)
    if (!same[e])
      for (int k = 0; k < 4; ++k) searched.push_back({face_key(after.tets[e], k), e, k});
  // A face of before between a kept tet and a changed one: the kept tet's side is searched. (By
  // face, in order: a pass over the tets' neighbours would read the face table at random.)
  std::vector<char> kept_face(static_cast<std::size_t>(nf), 0);  // both tets (or its only one) kept
  for (Index f = 0; f < nf; ++f) {
    const auto& ft = before_faces.face_tets[f];
    const bool kept0 = kept(ft[0]);
    const bool kept1 = ft[1] < 0 ? kept0 : kept(ft[1]);
    kept_face[f] = kept0 && kept1;
    if (kept0 == kept1) continue;
    const Index e = kept0 ? ft[0] : ft[1];
    int k = 0;
    while (k < 4 && before_faces.tet_faces[e][k] != f) ++k;
    if (k == 4) return compute_faces(after);  // not reached for a valid before_faces
    searched.push_back({face_key(after.tets[e], k), e, k});
  }
  std::sort(searched.begin(), searched.end(), [](const Entry& x, const Entry& y) {
    if (!(x.key == y.key)) return x.key < y.key;
    return x.tet != y.tet ? x.tet < y.tet : x.local < y.local;
  });

  // Merge the kept faces (both tets kept, in before's order) with the searched ones by key.
  TetFaces out;
  out.tet_faces.assign(static_cast<std::size_t>(na), {-1, -1, -1, -1});
  out.faces.reserve(static_cast<std::size_t>(nf) + searched.size() / 2 + 16);
  out.face_tets.reserve(out.faces.capacity());
  std::vector<Index> new_of_old(static_cast<std::size_t>(nf), -1);
  Index f = 0;
  std::size_t d = 0;
  while (true) {
    while (f < nf && !kept_face[f]) ++f;
    if (f == nf && d == searched.size()) break;
    bool take_kept = d == searched.size();
    if (f < nf && !take_kept) {
      const TriIndices& c = before_faces.faces[f];
      const FaceKey key = face_key(c[0], c[1], c[2]);
      // A kept face that a changed tet also has: more than two tets on it.
      if (key == searched[d].key) return compute_faces(after);
      take_kept = key < searched[d].key;
    }
    if (take_kept) {
      new_of_old[f] = out.num_faces();
      out.faces.push_back(before_faces.faces[f]);
      out.face_tets.push_back(before_faces.face_tets[f]);
      ++f;
      continue;
    }
    std::size_t j = d;
    while (j < searched.size() && searched[j].key == searched[d].key) ++j;
    add_face(after, std::span<const Entry>(searched).subspan(d, j - d), out.faces, out.face_tets, out.tet_faces,
             out.overshared);
    d = j;
  }
  for (Index e = 0; e < na; ++e) {
    if (!same[e]) continue;
    for (int k = 0; k < 4; ++k) {
      if (out.tet_faces[e][k] >= 0) continue;
      out.tet_faces[e][k] = new_of_old[before_faces.tet_faces[e][k]];
      if (out.tet_faces[e][k] < 0) return compute_faces(after);  // not reached for a valid before_faces
    }
  }
  return out;
}

std::vector<TetFaces> split_faces(const TetFaces& faces, std::span<const Index> tet_part,
                                  std::span<const Index> local_tet, std::span<const Index> local_node,
                                  std::span<const Index> part_tets) {
  SHATTER_CHECK(tet_part.size() == faces.tet_faces.size() && local_tet.size() == tet_part.size());
  std::vector<TetFaces> out(part_tets.size());
  std::vector<std::size_t> part_faces(part_tets.size(), 0);
  for (const auto& ft : faces.face_tets) {
    const Index p = tet_part[static_cast<std::size_t>(ft[0])];
    if (p >= 0) ++part_faces[static_cast<std::size_t>(p)];
  }
  for (std::size_t p = 0; p < out.size(); ++p) {
    out[p].tet_faces.resize(static_cast<std::size_t>(part_tets[p]));
    out[p].faces.reserve(part_faces[p]);
    out[p].face_tets.reserve(part_faces[p]);
  }
  // Each face's index in its part, in the order of `faces` (the order compute_faces gives a part:
  // its node and tet numbers keep their order).
  std::vector<Index> local_face(static_cast<std::size_t>(faces.num_faces()), -1);
  for (Index f = 0; f < faces.num_faces(); ++f) {
    const auto& ft = faces.face_tets[f];
    const Index p = tet_part[static_cast<std::size_t>(ft[0])];
    if (p < 0) continue;
    SHATTER_CHECK(ft[1] < 0 || tet_part[static_cast<std::size_t>(ft[1])] == p);  // parts share no face
    TetFaces& part = out[static_cast<std::size_t>(p)];
    local_face[f] = part.num_faces();
    const TriIndices& c = faces.faces[f];
    part.faces.push_back({local_node[static_cast<std::size_t>(c[0])], local_node[static_cast<std::size_t>(c[1])],
                          local_node[static_cast<std::size_t>(c[2])]});
    part.face_tets.push_back({local_tet[static_cast<std::size_t>(ft[0])],
                              ft[1] < 0 ? Index(-1) : local_tet[static_cast<std::size_t>(ft[1])]});
  }
  for (std::size_t e = 0; e < tet_part.size(); ++e) {
    const Index p = tet_part[e];
    if (p < 0) continue;
    auto& tf = out[static_cast<std::size_t>(p)].tet_faces[static_cast<std::size_t>(local_tet[e])];
    for (int k = 0; k < 4; ++k) tf[k] = local_face[faces.tet_faces[e][k]];
  }
  for (const auto& [f, e] : faces.overshared) {
    const Index p = tet_part[static_cast<std::size_t>(e)];
    if (p >= 0 && local_face[f] >= 0)
      out[static_cast<std::size_t>(p)].overshared.push_back({local_face[f], local_tet[static_cast<std::size_t>(e)]});
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
