// Materials: physical constants of a solid (SI units) and named presets with handbook values
// (sources in docs/materials.md).
#pragma once

#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include "shatter/core/error.h"

namespace shatter {

/// +inf, for a strength or toughness that is never reached or not known.
inline constexpr double kInfinity = std::numeric_limits<double>::infinity();

/// A solid's constants. The defaults are the "porcelain" preset (a valid material, the paper's
/// china vase), so `Material{}` and `Material{.density = 2300}` are usable as they are.
struct Material {
  std::string name = "porcelain";     ///< preset name or "custom"
  double youngs_modulus = 70e9;       ///< E, Pa
  double poisson_ratio = 0.22;        ///< nu, in (-1, 0.5)
  double density = 2400;              ///< kg/m^3
  double tensile_strength = 40e6;     ///< Pa (ultimate tensile strength); +inf = never cracks
  double yield_stress = kInfinity;    ///< Pa (von Mises); +inf = perfectly elastic (brittle)
  double fracture_toughness = 1.0e6;  ///< K_Ic, Pa*sqrt(m); +inf = not known / not used
  /// Weibull modulus m of the tensile strength: 0 = every tet has tensile_strength; m > 0 = each
  /// tet of a body draws its own from Weibull's weakest-link law (sample_tensile_strengths,
  /// docs/fracture.md): the smaller m, the wider the scatter (glass and porcelain 5-15).
  double weibull_modulus = 0;
};

/// Lamé constants, Pa.
struct Lame {
  double mu = 0;      ///< shear modulus mu, Pa
  double lambda = 0;  ///< first Lame parameter lambda, Pa
};

/// mu = E / (2(1+nu)), lambda = E nu / ((1+nu)(1-2nu))  (docs/method.md §2.1).
Lame lame_parameters(const Material& m);

/// Checks the fields: E > 0 and finite, nu in (-1, 0.5), density > 0 and finite, strengths > 0
/// (may be +inf), Weibull modulus 0 or in [0.5, 1000], no NaN. The error's field names the
/// offending member ("youngs_modulus", ...).
Result<void> validate_material(const Material& m);

/// A named preset ("glass", "porcelain", "steel", ...) or an alias of one ("china", "aluminum", ...).
/// Unknown names give an error listing the valid ones.
Result<Material> material_preset(std::string_view name);

/// Names of all presets, in a fixed order.
std::vector<std::string> material_preset_names();

}  // namespace shatter
