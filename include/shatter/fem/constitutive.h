// Constitutive models of an isotropic elastic solid as pure functions of the deformation gradient F:
// energy density psi(F) (J/m^3), first Piola-Kirchhoff stress P = dpsi/dF (Pa) and its differential.
#pragma once

#include <string_view>

#include "shatter/core/error.h"
#include "shatter/core/types.h"
#include "shatter/fem/material.h"

namespace shatter {

/// stvk: St. Venant-Kirchhoff, Green strain E = (F^T F - I)/2 (docs/method.md §2.1), rotation invariant.
/// linear: small-strain Hooke, eps = (F + F^T)/2 - I; NOT rotation invariant: a rigid rotation gives
///         spurious stress (of order the rotation angle squared times E for small angles).
/// corotated: linear elasticity in the rotated frame of the polar decomposition F = R S,
///         psi = mu |F - R|^2 + lambda/2 tr(S - I)^2 (McAdams et al. 2011), rotation invariant.
enum class ModelKind { stvk, linear, corotated };

/// "stvk" | "linear" | "corotated"; anything else is an error listing those.
Result<ModelKind> parse_model_kind(std::string_view name);
/// "stvk", "linear" or "corotated".
const char* to_string(ModelKind kind);

/// psi(F), J/m^3.
double energy_density(ModelKind kind, const Lame& lame, const Mat3& F);
/// P = dpsi/dF, Pa.
Mat3 first_piola(ModelKind kind, const Lame& lame, const Mat3& F);
/// dP = (d^2 psi / dF^2) : dF, Pa.
Mat3 first_piola_differential(ModelKind kind, const Lame& lame, const Mat3& F, const Mat3& dF);

/// The factors of a polar decomposition F = R S.
struct Polar {
  Mat3 R;  ///< rotation (det +1)
  Mat3 S;  ///< symmetric stretch
};
/// Polar decomposition F = R S with R a rotation (det +1) and S symmetric. For det F < 0 (an
/// inverted element) S has one negative eigenvalue (the one of smallest magnitude). For det F > 0
/// by Higham's scaled Newton iteration on R (a few 3x3 cofactor inverses; smooth, deterministic,
/// and well defined at equal singular values, F near a rotation); for inverted or nearly singular F
/// from Eigen's JacobiSVD (MPL2).
Polar polar_decomposition(const Mat3& F);
/// The corotated model's psi(F) and P(F) from F's polar decomposition p, bit for bit what
/// energy_density and first_piola compute: callers that need several quantities of one F find p once.
double corotated_energy_density(const Lame& lame, const Mat3& F, const Polar& p);
Mat3 corotated_first_piola(const Lame& lame, const Mat3& F, const Polar& p);

}  // namespace shatter
