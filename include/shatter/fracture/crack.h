// Crack planning by the maximum tensile stress criterion (docs/method.md §2.5): crack origins, planes,
// radii and the tets each crack marks; a time-averaged stress state (after Bao et al. 2007) as a
// less instantaneous criterion.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "shatter/core/types.h"
#include "shatter/fem/material.h"
#include "shatter/fracture/cut.h"
#include "shatter/fracture/stress.h"
#include "shatter/mesh/tet_mesh.h"
#include "shatter/mesh/topology.h"

namespace shatter {

/// Settings of crack planning (plan_cracks).
struct CrackOptions {
  /// k in r_frac = max(r_min, r_0 min(1, k (sigma / sigma_t - 1))). 0: from the material,
  /// k = clamp(sigma_t sqrt(pi L) / K_Ic, 0.5, 20) = clamp(sqrt(L / l_ch), 0.5, 20), with L the body
  /// size and l_ch = (K_Ic / sigma_t)^2 / pi the characteristic length: the stress intensity of a
  /// body-sized crack at the strength stress over the toughness. Glass and porcelain crack far,
  /// tough materials (steel, or K_Ic unknown: k = 0.5) little.
  double brittleness = 0;
  /// r_0 = radius_fraction x L, L = the diagonal of the mesh's bounding box.
  double radius_fraction = 1.0;
  /// r_min = min_radius_edges x the origin tet's longest edge: a crack opens at least its origin's
  /// neighbourhood.
  double min_radius_edges = 1.5;
  /// At most this many cracks per load (0: none).
  int max_cracks = 4;
  /// A further origin must lie outside every earlier crack's region and farther than
  /// separation x (that crack's r_frac) from each earlier origin.
  double separation = 1.0;
  /// Branching: a further origin may also lie inside earlier cracks' regions, as long as it is
  /// farther than separation x (that crack's r_min) from each earlier origin. Brittle bodies
  /// under an impact then split along several planes from near the blow, as they shatter (the
  /// regions are recomputed on the cut mesh, so a branch stays on its side of earlier cracks).
  bool branch = false;
  /// The tensile criterion reads a yielded tet's stress returned to the yield surface
  /// (sigma x sigma_y / sigma_vm when sigma_vm > sigma_y). An elastic solve over-states the stress
  /// of a tet that yields; with this a ductile material (yield below its strength: clay, steel)
  /// tears only by plastic strain (PlasticityOptions::max_plastic_strain), never brittly.
  bool return_to_yield = false;
};

/// One planned crack.
struct CrackPlan {
  Index origin_tet = -1;        ///< tet index in the planning mesh
  Vec3 origin = Vec3::Zero();   ///< plane point: the origin tet's centroid, m
  Vec3 normal = Vec3::UnitX();  ///< unit normal: principal direction of the largest tension
  double stress = 0;            ///< largest principal stress at the origin, Pa
  double radius = 0;            ///< r_frac, m
  bool ductile = false;         ///< origin came from exceeding the maximum plastic strain
  std::vector<Index> tets;      ///< region: tets with centroids within `radius` of `origin`,
                                ///< reachable from the origin tet through shared faces (sorted)
};

/// Derived brittleness k (see CrackOptions::brittleness) for a body of size L (m).
double material_brittleness(const Material& material, double body_size);

/// Per-tet tensile strengths scattered by Weibull's weakest-link law (docs/fracture.md): tet e of
/// volume V_e holds a tension sigma with probability exp(-ln 2 (V_e / V_mean) (sigma / sigma_t)^m),
/// with sigma_t the material's tensile_strength, m its weibull_modulus and V_mean the mean tet
/// volume of `mesh`. A tet of mean volume has median strength sigma_t; a larger tet is weaker, and a
/// finer mesh of the same body holds more weak tets (the weakest-link size effect at the tet scale).
/// Drawn in tet order from `seed` by our own generator (the same numbers on every platform). Empty
/// (every tet has sigma_t) when m is 0 or sigma_t is +inf. Pa, #tets.
std::vector<double> sample_tensile_strengths(const TetMesh& mesh, const Material& material, std::uint64_t seed);

/// r_frac rule (see CrackOptions).
double crack_radius(double stress, double strength, double brittleness, double r0, double r_min);

/// Face neighbours of a mesh's tets: [e][k] is the tet across local face k of tet e (opposite
/// corner k), -1 on the boundary, or kUnknownNeighbor where not known yet. The crack functions
/// search the unknown ones they need (face_neighbor on the node incidence) and write them in.
using FaceNeighborTable = std::vector<std::array<Index, 4>>;
inline constexpr Index kUnknownNeighbor = -2;

/// A table with every neighbour unknown (#tets).
FaceNeighborTable unknown_face_neighbors(Index num_tets);
/// The table of a mesh's face table (compute_faces): all known, except at faces of three or more
/// tets (which face_neighbor settles).
FaceNeighborTable face_neighbor_table(const TetFaces& faces);
/// The table of a cut mesh from its input's (`input_known`, #tets of `input`): a tet the cut left as
/// it was (its index, and its corners or their copies) keeps its boundary faces and each neighbour
/// that was left as it was too and still shares the face; everything else is unknown. Exact for
/// meshes whose faces have at most two tets (validate_mesh's condition). Only the tets in
/// cut.changed_tets and the entries naming them are looked at again: a pass over the table, not
/// over the tets' corners.
FaceNeighborTable carry_face_neighbors(const TetMesh& input, const FaceNeighborTable& input_known,
                                       const CutResult& cut);

/// Tets reachable from `origin_tet` through shared faces with centroids within `radius` of `center`
/// (sorted). The origin tet is always included.
std::vector<Index> crack_region(const TetMesh& mesh, const NodeTets& incidence, Index origin_tet, const Vec3& center,
                                double radius);
/// The same with the neighbours `known` (#tets), completed as the region needs.
std::vector<Index> crack_region(const TetMesh& mesh, FaceNeighborTable& known, Index origin_tet, const Vec3& center,
                                double radius);

/// Plan up to max_cracks cracks: origins are tets whose largest principal stress exceeds the
/// tensile strength, by decreasing stress (ties: lower tet index), each outside earlier regions.
/// `ductile_origins` (tets over the maximum plastic strain) come first, with radius r_min.
/// `tet_strength` gives each tet its own tensile strength (Pa, #tets; empty: the material's): a tet
/// cracks when its stress exceeds its strength, origins are taken by decreasing stress over strength,
/// and the crack radius follows the origin's own excess. `faces` (compute_faces of `mesh`, or
/// null), when the caller keeps them, gives the regions' face neighbours without a search;
/// `neighbors` (or null) receives the neighbours known once the regions are grown (for
/// carry_face_neighbors; left as it was when nothing is planned). With `regions` =
/// PlanRegions::first, a branching plan (options.branch) grows only the first crack's region and
/// leaves the later plans' `tets` empty: for callers that grow each later region on the mesh the
/// earlier cuts leave (fracture_with_stress), where a region on the uncut mesh would go unused.
/// The plans are the same either way.
enum class PlanRegions { all, first };
std::vector<CrackPlan> plan_cracks(const TetMesh& mesh, const std::vector<TetStress>& stress, const Material& material,
                                   const CrackOptions& options = {}, const std::vector<Index>& ductile_origins = {},
                                   const std::vector<double>& tet_strength = {}, const TetFaces* faces = nullptr,
                                   FaceNeighborTable* neighbors = nullptr, PlanRegions regions = PlanRegions::all);

/// Exponentially time-averaged stress per tet: sigma_avg += (1 - exp(-dt / tau)) (sigma - sigma_avg).
/// A stress must persist for about tau to count fully, so a one-step spike does not crack a body
/// that a sustained load of the same size would (the idea of Bao et al. 2007's time averaging).
class StressHistory {
 public:
  /// Zero averages for `num_tets` tets; time constant tau, s (> 0).
  StressHistory(Index num_tets, double time_constant);
  /// Fold in the stresses (Pa, #tets) held for dt seconds.
  void update(const std::vector<Mat3>& sigma, double dt);
  /// After a cut: tet e of the new mesh inherits the average of tet_parent[e].
  void remap(const std::vector<Index>& tet_parent);
  /// The averaged Cauchy stress per tet, Pa (#tets).
  [[nodiscard]] const std::vector<Mat3>& averaged() const { return average_; }
  /// tau, s.
  [[nodiscard]] double time_constant() const { return tau_; }

 private:
  std::vector<Mat3> average_;
  double tau_;
};

}  // namespace shatter
