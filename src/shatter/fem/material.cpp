// Material presets (values and their sources: docs/materials.md) and parameter checks.
#include "shatter/fem/material.h"

#include <array>
#include <cmath>

namespace shatter {
namespace {

constexpr double kGPa = 1e9;
constexpr double kMPa = 1e6;

// Typical room-temperature handbook values; see docs/materials.md for the sources of each row.
// name, E, nu, density, tensile (ultimate) strength, yield (inf = brittle), K_Ic (Pa sqrt(m)).
const std::array<Material, 12>& presets() {
  static const std::array<Material, 12> table = {{
      {"glass", 72 * kGPa, 0.22, 2500, 50 * kMPa, kInfinity, 0.75 * kMPa},
      {"porcelain", 70 * kGPa, 0.22, 2400, 40 * kMPa, kInfinity, 1.0 * kMPa},
      {"concrete", 30 * kGPa, 0.20, 2400, 3 * kMPa, kInfinity, 0.9 * kMPa},
      {"granite", 50 * kGPa, 0.25, 2700, 10 * kMPa, kInfinity, 1.5 * kMPa},
      {"marble", 55 * kGPa, 0.27, 2700, 7 * kMPa, kInfinity, 1.0 * kMPa},
      {"terracotta", 20 * kGPa, 0.20, 1900, 5 * kMPa, kInfinity, 0.8 * kMPa},
      {"modelling_clay", 1 * kMPa, 0.45, 1700, 0.1 * kMPa, 0.03 * kMPa, kInfinity},
      {"steel", 200 * kGPa, 0.30, 7850, 400 * kMPa, 250 * kMPa, 50 * kMPa},
      {"aluminium", 68.9 * kGPa, 0.33, 2700, 310 * kMPa, 276 * kMPa, 29 * kMPa},
      {"lead", 16 * kGPa, 0.44, 11340, 17 * kMPa, 5.5 * kMPa, kInfinity},
      {"abs", 2.3 * kGPa, 0.35, 1050, 44 * kMPa, 40 * kMPa, 3 * kMPa},
      {"acrylic", 3.2 * kGPa, 0.37, 1180, 70 * kMPa, kInfinity, 1.0 * kMPa},
  }};
  return table;
}

struct Alias {
  std::string_view alias;
  std::string_view name;
};
constexpr std::array<Alias, 9> kAliases = {{
    {"china", "porcelain"},
    {"fired_clay", "terracotta"},
    {"clay", "modelling_clay"},
    {"plasticine", "modelling_clay"},
    {"aluminum", "aluminium"},
    {"pmma", "acrylic"},
    {"soda_lime_glass", "glass"},
    {"structural_steel", "steel"},
    {"aluminium_6061_t6", "aluminium"},
}};

}  // namespace

Lame lame_parameters(const Material& m) {
  const double E = m.youngs_modulus;
  const double nu = m.poisson_ratio;
  return {.mu = E / (2.0 * (1.0 + nu)), .lambda = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))};
}

Result<void> validate_material(const Material& m) {
  const std::string who = m.name.empty() ? std::string("material") : "material '" + m.name + "'";
  if (!(m.youngs_modulus > 0) || !std::isfinite(m.youngs_modulus))
    return field_error("youngs_modulus", who + ": Young's modulus must be a finite number > 0 Pa, got " +
                                             format_number(m.youngs_modulus));
  if (!(m.poisson_ratio > -1.0 && m.poisson_ratio < 0.5))
    return field_error("poisson_ratio",
                       who + ": Poisson ratio must lie in (-1, 0.5), got " + format_number(m.poisson_ratio));
  if (!(m.density > 0) || !std::isfinite(m.density))
    return field_error("density",
                       who + ": density must be a finite number > 0 kg/m^3, got " + format_number(m.density));
  if (!(m.tensile_strength > 0))
    return field_error("tensile_strength", who + ": tensile strength must be > 0 Pa (inf: never cracks), got " +
                                               format_number(m.tensile_strength));
  if (!(m.yield_stress > 0))
    return field_error("yield_stress", who + ": yield stress must be > 0 Pa (inf: perfectly elastic), got " +
                                           format_number(m.yield_stress));
  if (!(m.fracture_toughness > 0))
    return field_error("fracture_toughness", who + ": fracture toughness must be > 0 Pa*sqrt(m) (inf: not used), got " +
                                                 format_number(m.fracture_toughness));
  if (!(m.weibull_modulus == 0 || (m.weibull_modulus >= 0.5 && m.weibull_modulus <= 1000)))
    return field_error("weibull_modulus", who +
                                              ": Weibull modulus must be 0 (one strength for every tet) or in "
                                              "[0.5, 1000], got " +
                                              format_number(m.weibull_modulus));
  return {};
}

Result<Material> material_preset(std::string_view name) {
  std::string_view key = name;
  for (const Alias& a : kAliases)
    if (a.alias == name) key = a.name;
  for (const Material& m : presets())
    if (m.name == key) return m;
  std::string list;
  for (const std::string& n : material_preset_names()) list += (list.empty() ? "" : ", ") + n;
  return field_error("material", "unknown material preset '" + std::string(name) + "'; valid: " + list);
}

std::vector<std::string> material_preset_names() {
  std::vector<std::string> names;
  for (const Material& m : presets()) names.push_back(m.name);
  return names;
}

}  // namespace shatter
