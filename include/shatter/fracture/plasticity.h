// Plasticity from a static solution (docs/method.md §2.4): tets whose von Mises stress exceeds the yield
// stress let the rest shape absorb part of their deformation (dents); tets past a maximum plastic
// strain become ductile crack origins (dents first, then tears).
#pragma once

#include <vector>

#include "shatter/core/types.h"
#include "shatter/fem/fem_model.h"
#include "shatter/fracture/stress.h"

namespace shatter {

/// Settings of the plastic update.
struct PlasticityOptions {
  bool enabled = true;  ///< false: no plasticity (none either when the yield stress is +inf)
  /// Fraction in [0, 1] of a yielded tet's excess absorbed per event: its weight is
  /// w_e = creep (1 - sigma_y / sigma_vm). 1 with sigma_y -> 0 is the paper's m := x.
  double creep = 0.5;
  /// A tet whose accumulated plastic strain exceeds this becomes a crack origin.
  double max_plastic_strain = 0.05;
  /// A rest tet never shrinks below this fraction of its volume before the update (the nodes'
  /// weights are halved until it holds).
  double min_volume_fraction = 0.2;
};

/// The outcome of one plastic event.
struct PlasticResult {
  std::vector<Vec3> rest_positions;    ///< updated rest positions, m (#nodes)
  std::vector<double> plastic_strain;  ///< accumulated equivalent plastic strain per tet (#tets)
  std::vector<Index> yielded;          ///< tets over yield this time (sorted)
  std::vector<Index> failed;           ///< tets over max_plastic_strain (sorted)
  std::vector<Index> moved_nodes;      ///< nodes whose rest position changed (sorted)
  Mat3 rotation = Mat3::Identity();    ///< best-fit rotation removed from the deformed shape
};

/// One plastic event of the body `model` (tets, material; its rest data is not read) whose rest
/// positions are `rest_positions` (m, #nodes), deformed to `deformed` (m, #nodes) with per-tet
/// stresses `stress` (#tets). `plastic_strain` is the accumulated strain per tet before it (empty:
/// zeros). Steps: (1) yielded tets get w_e = creep (1 - sigma_y / sigma_vm) and a plastic strain
/// increment w_e sigma_vm / E; (2) the best-fit rigid motion of deformed onto rest (the rotation of
/// the best-fit affine map, as in shape matching, weighted by the volume of the tets that stayed
/// elastic, or of all tets if all yielded) is removed; (3) each node's weight is the volume-weighted
/// mean of w_e over its tets (0 for tets that did not yield); (4) rest_i += w_i (x_i - rest_i);
/// (5) weights of nodes of any tet that would fall below min_volume_fraction of its volume are
/// halved (and finally zeroed) until none does. Afterwards update the model's rest data with
/// update_rest_shape (fem_model.h).
PlasticResult apply_plasticity(const FemModel& model, const std::vector<Vec3>& rest_positions,
                               const std::vector<Vec3>& deformed, const std::vector<TetStress>& stress,
                               const std::vector<double>& plastic_strain, const PlasticityOptions& options = {});

}  // namespace shatter
