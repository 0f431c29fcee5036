// Fracture and plasticity of a body from a static solution (docs/method.md §2.4-2.5): stresses, plastic
// rest-shape update, crack planning, cutting and the resulting fragments, in one call.
#pragma once

#include <vector>

#include "shatter/core/types.h"
#include "shatter/fem/fem_model.h"
#include "shatter/fracture/crack.h"
#include "shatter/fracture/cut.h"
#include "shatter/fracture/fragments.h"
#include "shatter/fracture/plasticity.h"
#include "shatter/fracture/stress.h"
#include "shatter/mesh/tet_mesh.h"

namespace shatter {

/// Settings of fracture(): crack planning, cutting and plasticity.
struct FractureOptions {
  CrackOptions crack;            ///< crack planning
  CutOptions cut;                ///< cutting
  PlasticityOptions plasticity;  ///< plastic update
  /// Accumulated plastic strain per tet of the rest mesh from earlier events (empty: zeros).
  std::vector<double> plastic_strain;
  /// Tensile strength per tet of the rest mesh, Pa (empty: the material's; see
  /// sample_tensile_strengths).
  std::vector<double> tensile_strength;
  /// The rest mesh's faces (compute_faces; the same tets), when the caller keeps them: the cracks
  /// planned on the rest mesh then find their regions' neighbours in it. Null: searched.
  const TetFaces* faces = nullptr;
};

/// One crack: its plan (origin, normal, radius; its `tets`, the region on the uncut mesh, only for
/// the first crack and for cracks that do not branch: a branch's region is grown on the mesh the
/// earlier cuts left, and counted in tets_marked) and what the cut did.
struct CrackEvent {
  CrackPlan plan;              ///< the planned crack
  Index tets_marked = 0;       ///< tets in the crack region when it was cut
  Index tets_split = 0;        ///< tets split along the plane
  Index edge_nodes = 0;        ///< nodes made on crossed edges
  Index nodes_duplicated = 0;  ///< node copies made to open the crack
  Index faces_cut = 0;         ///< faces disconnected
};

/// Everything fracture() produced.
struct FractureResult {
  TetMesh mesh;                        ///< rest mesh after plasticity and every cut
  std::vector<Vec3> deformed;          ///< deformed positions of mesh's nodes, m (#nodes)
  std::vector<Index> node_parent;      ///< input node each node came from (a node made on a split
                                       ///< edge: its nearer end) (#nodes)
  std::vector<Index> tet_parent;       ///< input tet of each tet (#tets)
  std::vector<double> plastic_strain;  ///< accumulated plastic strain per tet of mesh (#tets)
  std::vector<TetStress> stress;       ///< stress per input tet (#tets of the input)
  PlasticResult plastic;               ///< the plastic event on the input mesh
  std::vector<CrackEvent> events;      ///< cracks in the order cut
  std::vector<Fragment> fragments;     ///< components of mesh (maps index into mesh); one if unbroken
};

/// Fracture and plasticity of the body `model` (material, model kind, rest data) whose rest mesh is
/// `rest` (the tets of `model`): stresses of `deformed` (m, #nodes of rest) by compute_stresses, then
/// plasticity, cracks and fragments.
FractureResult fracture(const TetMesh& rest, const FemModel& model, const std::vector<Vec3>& deformed,
                        const FractureOptions& options = {});

/// The same from given per-tet stresses (#tets; e.g. already computed, or a time-averaged
/// StressHistory).
FractureResult fracture_with_stress(const TetMesh& rest, const FemModel& model, const std::vector<Vec3>& deformed,
                                    std::vector<TetStress> stress, const FractureOptions& options = {});

}  // namespace shatter
