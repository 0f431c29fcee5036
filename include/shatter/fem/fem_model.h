// FemModel: what never changes during a solve (material, tets, rest data, masses, acceleration data)
// and the global internal force / energy of a deformed state (docs/method.md §2.2, eq. 12-13; §3).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "shatter/core/types.h"
#include "shatter/fem/constitutive.h"
#include "shatter/fem/material.h"
#include "shatter/fem/tet_kernels.h"
#include "shatter/mesh/tet_mesh.h"

namespace shatter {

/// Compact per-tet data for the accelerated force path. The rest frame of each tet is rotated
/// (Q from a QR decomposition, Dm = Q^T R) so that Dm^-1 = R^-1 is upper triangular: F' = Ds R^-1
/// needs 18 multiplications instead of 27, and so does the force product. Energy and forces do not
/// depend on this rotation of the material frame (F' = F Q^T, S' = Q S Q^T, P' Dm'^-T = P Dm^-T).
struct FastTetData {
  /// Per group of 4 consecutive tets, rows of 4 lanes; padding lanes are 0. StVK and corotated: 7
  /// rows, R^-1 entries r00 r01 r02 r11 r12 r22 (1/m) of the QR-rotated rest frame and the rest
  /// volume V (m^3) (#groups x 7 x 4). Linear (not rotation invariant): 10 rows, Dm^-1 row by row
  /// (1/m) and V (#groups x 10 x 4).
  std::vector<double> packed;
  /// Fixed blocks of tets (independent of the thread count). Each block accumulates its tets'
  /// forces into its own compact node buffer in tet order; nodes then gather their entries.
  std::int64_t block_size = 0;                 ///< tets per block
  std::vector<std::int32_t> corner_slot;       ///< 4 x block-local node slot of each corner, i.e. the
                                               ///< offset of its x component (#tets x 4)
  std::vector<std::int64_t> block_slot_begin;  ///< first slot of each block in the global slot
                                               ///< array (#blocks + 1)
  std::vector<std::int64_t> node_entry_begin;  ///< CSR into node_entry_slot (#nodes + 1)
  std::vector<std::int64_t> node_entry_slot;   ///< global slot indices per node, in block order
};

/// The constant data of a FEM body (make_fem_model).
struct FemModel {
  ModelKind model = ModelKind::stvk;  ///< constitutive model
  Material material;                  ///< material constants
  Lame lame;                          ///< Lame constants of `material`, Pa
  std::vector<TetIndices> tets;       ///< node indices per tet (#tets)
  std::vector<TetRest> rest;          ///< rest data per tet (#tets)
  std::vector<double> node_mass;      ///< lumped mass, kg (#nodes): each tet gives rho V / 4 per corner
  Index num_nodes = 0;                ///< nodes of the rest mesh
  FastTetData fast;                   ///< acceleration data for internal_forces

  /// Number of tets.
  [[nodiscard]] Index num_tets() const { return static_cast<Index>(tets.size()); }
};

/// Rest data that make_fem_model may take from another model of the same kind instead of
/// computing it: `tet[e]` is a tet of `model` whose corners are tet e's corners, in the same order,
/// all moved by one translation (the rest data does not change under it), or -1. A fragment takes
/// its parent's this way for the tets the cut left whole.
struct RestSource {
  const FemModel* model = nullptr;
  std::span<const Index> tet;  ///< #tets of the new model, or empty
};

/// Builds the model from the rest mesh (positively oriented tets). The material is not validated
/// here (see validate_material).
FemModel make_fem_model(const TetMesh& rest_mesh, const Material& material, ModelKind kind,
                        const RestSource& from = {});

/// Replace the rest shape of tet e (plasticity: m := x, docs/method.md §2.4): updates rest[e] and the
/// fast path's data; node masses are kept (mass is conserved). Changing `tets` needs a new model.
void set_tet_rest(FemModel& model, Index e, const Mat34& rest_corners);

/// After a plastic update moved the rest positions of `moved_nodes` (docs/method.md §2.4): set_tet_rest
/// for every tet with a moved corner, from `rest_positions` (m, #nodes). This is the one way a
/// model follows a new rest shape in place; after a cut (new tets) build a new model instead.
void update_rest_shape(FemModel& model, const std::vector<Vec3>& rest_positions, const std::vector<Index>& moved_nodes);

/// Global internal force F(x) = sum_e F_e(x), N (#nodes), the straightforward way: per tet
/// tet_internal_forces and a serial scatter-add in tet order. x: deformed positions, m (#nodes).
void internal_forces_reference(const FemModel& model, const std::vector<Vec3>& x, std::vector<Vec3>& f);
/// Scratch memory of internal_forces: one force slot per (block, node of the block), 4 doubles each
/// (x, y, z, 0; N). Keep one per caller to avoid reallocating; its contents mean nothing between calls.
struct ForceWorkspace {
  std::vector<double> slots;  ///< 4 doubles per slot, N
};

/// The same, fast: fixed blocks of tets in parallel (stvk by specialised inline code on the compact
/// rest data, the other models per tet); the result does not depend on the thread count (bitwise)
/// and equals the reference to round-off.
void internal_forces(const FemModel& model, const std::vector<Vec3>& x, std::vector<Vec3>& f,
                     ForceWorkspace& workspace);
/// The same with a workspace of its own (allocated per call).
void internal_forces(const FemModel& model, const std::vector<Vec3>& x, std::vector<Vec3>& f);
/// Total elastic energy sum_e V_e psi(F_e), J (deterministic parallel sum).
double total_energy(const FemModel& model, const std::vector<Vec3>& x);

}  // namespace shatter
