// Rigid-body mass properties of a tet mesh of constant density: volume, mass, centre of mass and
// inertia tensor, exact for the union of the tets or lumped at the nodes as in the paper (eq. 21).
#pragma once

#include <span>

#include "shatter/core/types.h"
#include "shatter/mesh/tet_mesh.h"

namespace shatter {

/// Mass properties of a solid of constant density.
struct MassProperties {
  double volume = 0;            ///< m^3
  double mass = 0;              ///< kg
  Vec3 center = Vec3::Zero();   ///< centre of mass, m
  Mat3 inertia = Mat3::Zero();  ///< inertia tensor about the centre of mass, kg m^2
};

/// Exact mass properties of the union of the mesh's tets at `density` (kg/m^3): each tet's second
/// moment integral C = V/20 (sum_i r_i r_i^T + s s^T), s = sum_i r_i (equivalent to Tonon 2004's
/// closed form), summed about a reference point, then I = tr(C) I3 - C about the centre of mass.
MassProperties mass_properties(const TetMesh& mesh, double density);

/// The same with lumped nodal masses (each tet gives rho V / 4 to each corner; docs/method.md eq. 21):
/// I = sum m_i (r_i^T r_i I3 - r_i r_i^T). Approximate; for comparison with the paper.
MassProperties lumped_mass_properties(const TetMesh& mesh, double density);

/// Mass, centre and inertia (about the centre) of point masses m_i at x_i, e.g. a body's lumped
/// nodes where they are now (volume 0; an empty or massless set gives zeros).
MassProperties point_mass_properties(std::span<const double> masses, std::span<const Vec3> positions);

}  // namespace shatter
