#include "shatter/fracture/crack.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include "shatter/core/assert.h"
#include "shatter/core/random.h"
#include "shatter/mesh/topology.h"

namespace shatter {
namespace {
Vec3 centroid(const TetMesh& mesh, Index e) {
  const TetIndices& t = mesh.tets[e];
  return (mesh.positions[t[0]] + mesh.positions[t[1]] + mesh.positions[t[2]] + mesh.positions[t[3]]) / 4.0;
}
double longest_edge(const TetMesh& mesh, Index e) {
  const Mat34 x = mesh.corners(e);
  double l = 0;
  for (int a = 0; a < 4; ++a)
    for (int b = a + 1; b < 4; ++b) l = std::max(l, (x.col(a) - x.col(b)).norm());
  return l;
}
}  // namespace

double material_brittleness(const Material& material, double body_size) {
  if (!std::isfinite(material.fracture_toughness) || !(material.tensile_strength > 0)) return 0.5;
  // beta = sigma_t sqrt(pi L) / K_Ic = sqrt(L / l_ch): the stress intensity of a body-sized crack at
  // the strength stress over the toughness.
  const double beta = material.tensile_strength * std::sqrt(std::numbers::pi * body_size) / material.fracture_toughness;
  return std::clamp(beta, 0.5, 20.0);
}

std::vector<double> sample_tensile_strengths(const TetMesh& mesh, const Material& material, std::uint64_t seed) {
  std::vector<double> out;
  const double m = material.weibull_modulus;
  if (m == 0 || !std::isfinite(material.tensile_strength) || mesh.tets.empty()) return out;
  std::vector<double> volume(mesh.tets.size());
  double sum = 0;
  for (Index e = 0; e < mesh.num_tets(); ++e) sum += volume[e] = std::abs(signed_volume(mesh, e));
  const double mean = sum / static_cast<double>(mesh.tets.size());
  Random rng(seed);
  out.resize(mesh.tets.size());
  for (std::size_t e = 0; e < out.size(); ++e) {
    // u in (0, 1) from the top 53 bits (never 0 or 1); the inverse of the survival law
    // exp(-ln 2 (V_e / V_mean) (s / sigma_t)^m) = 1 - u.
    const double u = (static_cast<double>(rng.next_u64() >> 11) + 0.5) * 0x1.0p-53;
    const double weakness = volume[e] > 0 ? mean / volume[e] : 1.0;
    out[e] = material.tensile_strength * std::pow(weakness * -std::log1p(-u) / std::numbers::ln2, 1.0 / m);
  }
  return out;
}

double crack_radius(double stress, double strength, double brittleness, double r0, double r_min) {
  const double excess = std::max(0.0, stress / strength - 1.0);
  return std::max(r_min, r0 * std::min(1.0, brittleness * excess));
}

namespace {

// The face neighbours of a mesh's tets as they are asked for: from `known`, else by face_neighbor
// on the node incidence (built at the first search), written into `known`.
class FaceNeighbors {
 public:
  FaceNeighbors(const TetMesh& mesh, FaceNeighborTable& known, const NodeTets* incidence = nullptr)
      : mesh_(mesh), known_(known), incidence_(incidence) {
    SHATTER_CHECK(known.size() == mesh.tets.size());
  }
  Index operator()(Index e, int k) {
    Index& n = known_[static_cast<std::size_t>(e)][static_cast<std::size_t>(k)];
    if (n == kUnknownNeighbor) {
      if (incidence_ == nullptr) {
        own_incidence_ = node_tets(mesh_);
        incidence_ = &own_incidence_;
      }
      n = face_neighbor(mesh_, *incidence_, e, k);
    }
    return n;
  }

 private:
  const TetMesh& mesh_;
  FaceNeighborTable& known_;
  const NodeTets* incidence_;
  NodeTets own_incidence_;
};

std::vector<Index> grow_region(const TetMesh& mesh, FaceNeighbors& neighbors, Index origin_tet, const Vec3& center,
                               double radius) {
  // seen: 1 looked at, 2 in the region.
  std::vector<char> seen(mesh.tets.size(), 0);
  std::vector<Index> out{origin_tet};
  seen[origin_tet] = 2;
  const double r2 = radius * radius;
  for (std::size_t i = 0; i < out.size(); ++i)
    for (int k = 0; k < 4; ++k) {
      const Index n = neighbors(out[i], k);
      if (n < 0 || seen[n]) continue;
      seen[n] = 1;
      if ((centroid(mesh, n) - center).squaredNorm() <= r2) {
        seen[n] = 2;
        out.push_back(n);
      }
    }
  // In increasing order: a sort when the region is a small part of the mesh, else a scan.
  if (out.size() * 16 < mesh.tets.size()) {
    std::sort(out.begin(), out.end());
  } else {
    std::size_t j = 0;
    for (Index e = 0; e < mesh.num_tets(); ++e)
      if (seen[e] == 2) out[j++] = e;
  }
  return out;
}

}  // namespace

FaceNeighborTable unknown_face_neighbors(Index num_tets) {
  return FaceNeighborTable(static_cast<std::size_t>(num_tets),
                           {kUnknownNeighbor, kUnknownNeighbor, kUnknownNeighbor, kUnknownNeighbor});
}

FaceNeighborTable face_neighbor_table(const TetFaces& faces) {
  FaceNeighborTable table(faces.tet_faces.size());
  for (std::size_t e = 0; e < table.size(); ++e)
    for (int k = 0; k < 4; ++k) table[e][k] = faces.neighbor(static_cast<Index>(e), k);
  // A face of three or more tets: which of the others face_neighbor names depends on the incidence.
  if (!faces.overshared.empty()) {
    std::vector<char> shared_by_more(faces.faces.size(), 0);
    for (const auto& [f, tet] : faces.overshared) shared_by_more[static_cast<std::size_t>(f)] = 1;
    for (std::size_t e = 0; e < table.size(); ++e)
      for (int k = 0; k < 4; ++k)
        if (shared_by_more[static_cast<std::size_t>(faces.tet_faces[e][k])]) table[e][k] = kUnknownNeighbor;
  }
  return table;
}

FaceNeighborTable carry_face_neighbors(const TetMesh& input, const FaceNeighborTable& input_known,
                                       const CutResult& cut) {
  SHATTER_CHECK(input_known.size() == input.tets.size());
  const TetMesh& mesh = cut.mesh;
  const Index n_input = std::min(input.num_tets(), mesh.num_tets());
  // Only the tets whose corners changed (cut.changed_tets) and the entries that name them are
  // looked at again; every other entry stands as it was.
  FaceNeighborTable table = input_known;
  table.resize(mesh.tets.size(), {kUnknownNeighbor, kUnknownNeighbor, kUnknownNeighbor, kUnknownNeighbor});
  // changed: 1 = corners changed but each the input's or a copy of it (kept: its faces are where
  // they were); 2 = not kept (split, or its index no longer holds its input tet).
  std::vector<char> changed(static_cast<std::size_t>(n_input), 0);
  for (const Index e : cut.changed_tets) {
    if (e >= n_input) continue;
    bool same = cut.tet_parent[e] == e;
    for (int c = 0; c < 4 && same; ++c) {
      const NodeOrigin& o = cut.node_origin[mesh.tets[e][c]];
      same = o.a == o.b && o.a == input.tets[e][c];
    }
    changed[e] = same ? 1 : 2;
  }
  for (Index e = 0; e < n_input; ++e) {
    const char ce = changed[e];
    for (int k = 0; k < 4; ++k) {
      const Index n = input_known[e][k];
      const bool names_changed = n >= 0 && n < n_input && changed[n];
      if (!ce && !names_changed) continue;
      Index& entry = table[e][k];
      entry = kUnknownNeighbor;
      if (ce == 2) continue;
      if (n == -1) {
        entry = -1;  // a cut opens faces, it never closes one
        continue;
      }
      if (n < 0 || n >= n_input || changed[n] == 2) continue;
      const TetIndices& t = mesh.tets[e];
      const TetIndices& u = mesh.tets[n];
      bool shares = true;
      for (int j = 0; j < 3 && shares; ++j) {
        const Index v = t[kTetFaces[k][j]];
        shares = u[0] == v || u[1] == v || u[2] == v || u[3] == v;
      }
      if (shares) entry = n;
    }
  }
  return table;
}

std::vector<Index> crack_region(const TetMesh& mesh, const NodeTets& incidence, Index origin_tet, const Vec3& center,
                                double radius) {
  FaceNeighborTable known = unknown_face_neighbors(mesh.num_tets());
  FaceNeighbors neighbors(mesh, known, &incidence);
  return grow_region(mesh, neighbors, origin_tet, center, radius);
}

std::vector<Index> crack_region(const TetMesh& mesh, FaceNeighborTable& known, Index origin_tet, const Vec3& center,
                                double radius) {
  FaceNeighbors neighbors(mesh, known);
  return grow_region(mesh, neighbors, origin_tet, center, radius);
}

std::vector<CrackPlan> plan_cracks(const TetMesh& mesh, const std::vector<TetStress>& stress, const Material& material,
                                   const CrackOptions& options, const std::vector<Index>& ductile_origins,
                                   const std::vector<double>& tet_strength, const TetFaces* faces,
                                   FaceNeighborTable* neighbors, PlanRegions regions) {
  SHATTER_CHECK(stress.size() == mesh.tets.size());
  SHATTER_CHECK(tet_strength.empty() || tet_strength.size() == mesh.tets.size());
  std::vector<CrackPlan> plans;
  if (options.max_cracks <= 0 || mesh.tets.empty()) return plans;
  const double strength = material.tensile_strength;
  const double body = mesh.bounds().extent().norm();
  const double k = options.brittleness > 0 ? options.brittleness : material_brittleness(material, body);
  const double r0 = options.radius_fraction * body;

  // Candidates: ductile origins first (in the given order), then tets over strength by decreasing
  // largest principal stress (ties: lower index).
  // The largest principal stress the criterion reads per tet (returned to the yield surface when
  // asked).
  const double yield = material.yield_stress;
  auto tension = [&](Index e) {
    const TetStress& s = stress[e];
    if (options.return_to_yield && s.von_mises > yield) return s.principal[0] * (yield / s.von_mises);
    return s.principal[0];
  };
  const bool per_tet = !tet_strength.empty();
  auto strength_of = [&](Index e) { return per_tet ? tet_strength[e] : strength; };
  std::vector<Index> over;
  if (per_tet || std::isfinite(strength))
    for (Index e = 0; e < mesh.num_tets(); ++e)
      if (tension(e) > strength_of(e)) over.push_back(e);
  // By decreasing stress over strength (with one strength: by decreasing stress, the same order).
  auto rank = [&](Index e) { return per_tet ? tension(e) / tet_strength[e] : tension(e); };
  std::sort(over.begin(), over.end(), [&](Index a, Index b) {
    const double sa = rank(a), sb = rank(b);
    return sa != sb ? sa > sb : a < b;
  });
  if (over.empty() && ductile_origins.empty()) return plans;

  SHATTER_CHECK(faces == nullptr || faces->tet_faces.size() == mesh.tets.size());
  FaceNeighborTable known = faces != nullptr ? face_neighbor_table(*faces) : unknown_face_neighbors(mesh.num_tets());
  FaceNeighbors face_neighbors(mesh, known);  // shared by the plans' regions
  std::vector<char> taken(mesh.tets.size(), 0);
  auto consider = [&](Index e, bool ductile) {
    if (static_cast<int>(plans.size()) >= options.max_cracks || (taken[e] && !options.branch)) return;
    const Vec3 c = centroid(mesh, e);
    const double r_min = options.min_radius_edges * longest_edge(mesh, e);
    const double r = ductile ? r_min : crack_radius(tension(e), strength_of(e), k, r0, r_min);
    for (const CrackPlan& p : plans) {
      const double keep_off = options.branch ? options.min_radius_edges * longest_edge(mesh, p.origin_tet) : p.radius;
      if ((c - p.origin).norm() <= options.separation * keep_off) return;
    }
    CrackPlan p;
    p.origin_tet = e;
    p.origin = c;
    p.normal = stress[e].directions.col(0).normalized();
    p.stress = tension(e);
    p.radius = r;
    p.ductile = ductile;
    // Without branching, later origins must lie outside every region: each is grown. A branching
    // plan's regions matter only to the caller.
    if (plans.empty() || regions == PlanRegions::all || !options.branch) {
      p.tets = grow_region(mesh, face_neighbors, e, c, r);
      for (Index t : p.tets) taken[t] = 1;
    }
    plans.push_back(std::move(p));
  };
  for (Index e : ductile_origins) consider(e, true);
  for (Index e : over) consider(e, false);
  if (neighbors != nullptr) *neighbors = std::move(known);
  return plans;
}

StressHistory::StressHistory(Index num_tets, double time_constant)
    : average_(static_cast<std::size_t>(num_tets), Mat3::Zero()), tau_(time_constant) {
  SHATTER_CHECK(time_constant > 0);
}

void StressHistory::update(const std::vector<Mat3>& sigma, double dt) {
  SHATTER_CHECK(sigma.size() == average_.size() && dt >= 0);
  const double alpha = 1.0 - std::exp(-dt / tau_);
  for (std::size_t e = 0; e < sigma.size(); ++e) average_[e] += alpha * (sigma[e] - average_[e]);
}

void StressHistory::remap(const std::vector<Index>& tet_parent) {
  std::vector<Mat3> next(tet_parent.size());
  for (std::size_t e = 0; e < tet_parent.size(); ++e) next[e] = average_[tet_parent[e]];
  average_ = std::move(next);
}

}  // namespace shatter
