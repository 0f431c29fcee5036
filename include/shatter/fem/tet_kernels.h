// Constant-strain tetrahedron kernels (docs/method.md §2.2-2.3) as pure functions of the rest data and the
// deformed corners; stress analysis helpers (Cauchy stress, principal stresses, von Mises).
#pragma once

#include <span>

#include "shatter/core/types.h"
#include "shatter/fem/constitutive.h"

namespace shatter {

/// Rest data of one tet with corners m0..m3: Dm = [m1-m0, m2-m0, m3-m0] (columns are edges from
/// corner 0, so det Dm = 6 V > 0 for the mesh's positive orientation), Dm_inv = Dm^-1 (1/m),
/// volume V (m^3).
struct TetRest {
  Mat3 Dm_inv = Mat3::Zero();  ///< Dm^-1, 1/m
  double volume = 0;           ///< rest volume V, m^3
};
/// rest_corners: 3x4, column k = corner k, m.
TetRest tet_rest(const Mat34& rest_corners);

/// Gradients of the 4 barycentric (shape) functions, 1/m: row j = grad b_j (the paper's B, the
/// first three columns of beta). Rows sum to zero.
Mat43 shape_gradients(const TetRest& rest);

/// F = Ds Dm^-1 with Ds = [x1-x0, x2-x0, x3-x0]; x: 3x4 deformed corners, m.
Mat3 deformation_gradient(const TetRest& rest, const Mat34& x);
/// U_e = V psi(F), J.
double tet_energy(ModelKind kind, const Lame& lame, const TetRest& rest, const Mat34& x);
/// dU_e/dx_i, N (3x4, column i = corner i): the paper's F_e, the force the material needs to hold
/// the shape (the negative of the elastic force on the nodes). [f1 f2 f3] = V P Dm^-T,
/// f0 = -(f1 + f2 + f3).
Mat34 tet_internal_forces(ModelKind kind, const Lame& lame, const TetRest& rest, const Mat34& x);
/// The same from the first Piola-Kirchhoff stress P of the tet's F (bit for bit).
Mat34 tet_forces_from_stress(const TetRest& rest, const Mat3& P);
/// d^2 U_e / dx^2, N/m, 12x12 with ordering [x0; x1; x2; x3], each xyz. Column 3i+a is the
/// differential of the forces along the unit displacement of corner i in axis a. Every model uses a
/// closed form per 3x3 block: symmetric to round-off for stvk and linear, to the last bit for
/// corotated. May be indefinite for stvk/corotated under compression.
Mat12 tet_stiffness(ModelKind kind, const Lame& lame, const TetRest& rest, const Mat34& x);
/// The same from 12 evaluations of first_piola_differential (any model; slower; a cross-check).
Mat12 tet_stiffness_from_differential(ModelKind kind, const Lame& lame, const TetRest& rest, const Mat34& x);
/// Symmetric part of K with negative eigenvalues clamped to 0. When that symmetric part is
/// already positive semi-definite it is returned as is.
Mat12 project_psd(const Mat12& K);
/// StVK's tet_stiffness with the negative part of S = 2 mu E + lambda tr(E) I removed from its
/// geometric term V (B S B^T) (x) I (the material term is positive semi-definite): positive
/// semi-definite, exact where S is. Symmetric to the last bit.
Mat12 stvk_projected_stiffness(const Lame& lame, const TetRest& rest, const Mat34& x);
/// The corotated tet_stiffness with the negative eigenvalues of its Hessian in F (9x9, a closed-form
/// eigensystem) clamped to 0: positive semi-definite, and bit for bit the exact one where those
/// eigenvalues are clearly non-negative. Symmetric to the last bit. (Not project_psd: the clamp is
/// in F, as projected Newton methods for hyperelasticity do, and needs a 3x3 eigenproblem at most.)
Mat12 corotated_projected_stiffness(const Lame& lame, const TetRest& rest, const Mat34& x);
/// The corotated tet_stiffness and corotated_projected_stiffness from the polar decomposition of the
/// tet's F (bit for bit), for callers that found it already.
Mat12 corotated_stiffness(const Lame& lame, const TetRest& rest, const Polar& polar);
Mat12 corotated_projected_stiffness(const Lame& lame, const TetRest& rest, const Polar& polar);

/// Cauchy (true) stress sigma = P F^T / det F, Pa; for the linear model the small-strain stress
/// 2 mu eps + lambda tr(eps) I.
Mat3 cauchy_stress(ModelKind kind, const Lame& lame, const Mat3& F);

/// Eigen-decomposition of a symmetric 3x3 tensor (Pa).
struct Principal {
  Vec3 values;   ///< descending
  Mat3 vectors;  ///< unit eigenvectors as columns; right-handed (det +1)
};
/// Cyclic Jacobi rotations: deterministic, exact when the input is diagonal (including repeated
/// eigenvalues such as diag(a,a,b) or a*I), accurate to round-off otherwise. Sign rule: the
/// largest-magnitude component of columns 0 and 1 is positive (first such index on ties); column 2
/// = column 0 x column 1. Only the upper triangle of `symmetric` is read.
Principal principal_stresses(const Mat3& m);
/// The same for many tensors (out.size() == m.size()), four at a time: the same bits as one by one,
/// about three times the throughput (the rotations' divisions and square roots overlap).
void principal_stresses(std::span<const Mat3> m, std::span<Principal> out);
/// von Mises equivalent stress, Pa: sqrt(3/2 s:s) with s the deviatoric part of sigma.
double von_mises(const Mat3& sigma);

}  // namespace shatter
