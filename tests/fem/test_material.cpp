#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "shatter/fem/material.h"
#include "support/test_support.h"

namespace shatter {
namespace {

TEST(Material, PresetsAreValidAndConsistent) {
  const std::vector<std::string> names = material_preset_names();
  EXPECT_GE(names.size(), 12u);
  for (const std::string& name : names) {
    const Result<Material> m = material_preset(name);
    ASSERT_OK(m);
    EXPECT_EQ(m->name, name);
    EXPECT_OK(validate_material(*m));
    // Brittle: never yields. Ductile: yields before it breaks.
    if (std::isfinite(m->yield_stress)) {
      EXPECT_LT(m->yield_stress, m->tensile_strength) << name;
    }
  }
  for (const char* brittle : {"glass", "porcelain", "concrete", "granite", "marble", "terracotta", "acrylic"})
    EXPECT_TRUE(std::isinf(material_preset(brittle)->yield_stress)) << brittle;
  for (const char* ductile : {"steel", "aluminium", "lead", "modelling_clay", "abs"})
    EXPECT_TRUE(std::isfinite(material_preset(ductile)->yield_stress)) << ductile;
  // Spot values (docs/materials.md).
  EXPECT_EQ(material_preset("steel")->youngs_modulus, 200e9);
  EXPECT_EQ(material_preset("aluminium")->poisson_ratio, 0.33);
  EXPECT_EQ(material_preset("china")->name, "porcelain");
}

TEST(Material, UnknownPresetListsValidNames) {
  const Result<Material> m = material_preset("unobtainium");
  ASSERT_FALSE(m.ok());
  EXPECT_NE(m.error().message.find("unobtainium"), std::string::npos);
  for (const std::string& name : material_preset_names())
    EXPECT_NE(m.error().message.find(name), std::string::npos) << name;
}

TEST(Material, LameParameters) {
  const Material m{.name = "custom", .youngs_modulus = 10.0, .poisson_ratio = 0.25, .density = 1};
  const Lame l = lame_parameters(m);
  EXPECT_DOUBLE_EQ(l.mu, 4.0);      // 10 / 2.5
  EXPECT_DOUBLE_EQ(l.lambda, 4.0);  // 2.5 / (1.25 * 0.5)
  // Back to E and nu.
  EXPECT_DOUBLE_EQ(l.mu * (3 * l.lambda + 2 * l.mu) / (l.lambda + l.mu), 10.0);
  EXPECT_DOUBLE_EQ(l.lambda / (2 * (l.lambda + l.mu)), 0.25);
}

TEST(Material, ValidationNamesTheField) {
  const Material good = *material_preset("glass");
  const double nan = std::numeric_limits<double>::quiet_NaN();
  struct FieldCase {
    const char* field;
    void (*edit)(Material&, double);
    double value;
  };
  const FieldCase cases[] = {
      {"youngs_modulus", [](Material& m, double v) { m.youngs_modulus = v; }, 0.0},
      {"youngs_modulus", [](Material& m, double v) { m.youngs_modulus = v; }, -1e9},
      {"youngs_modulus", [](Material& m, double v) { m.youngs_modulus = v; }, nan},
      {"youngs_modulus", [](Material& m, double v) { m.youngs_modulus = v; }, kInfinity},
      {"poisson_ratio", [](Material& m, double v) { m.poisson_ratio = v; }, 0.5},
      {"poisson_ratio", [](Material& m, double v) { m.poisson_ratio = v; }, -1.0},
      {"poisson_ratio", [](Material& m, double v) { m.poisson_ratio = v; }, nan},
      {"density", [](Material& m, double v) { m.density = v; }, 0.0},
      {"density", [](Material& m, double v) { m.density = v; }, nan},
      {"tensile_strength", [](Material& m, double v) { m.tensile_strength = v; }, 0.0},
      {"tensile_strength", [](Material& m, double v) { m.tensile_strength = v; }, nan},
      {"yield_stress", [](Material& m, double v) { m.yield_stress = v; }, -5.0},
      {"fracture_toughness", [](Material& m, double v) { m.fracture_toughness = v; }, nan},
  };
  for (const FieldCase& c : cases) {
    Material m = good;
    c.edit(m, c.value);
    const Result<void> r = validate_material(m);
    ASSERT_FALSE(r.ok()) << c.field << " = " << c.value;
    EXPECT_EQ(r.error().field, c.field);
  }
  Material inf_ok = good;
  inf_ok.tensile_strength = kInfinity;
  EXPECT_OK(validate_material(inf_ok));
}

TEST(Material, DefaultIsThePorcelainPreset) {
  const Material d{};
  EXPECT_OK(validate_material(d));
  const Material p = material_preset("porcelain").value();
  EXPECT_EQ(d.name, p.name);
  EXPECT_EQ(d.youngs_modulus, p.youngs_modulus);
  EXPECT_EQ(d.poisson_ratio, p.poisson_ratio);
  EXPECT_EQ(d.density, p.density);
  EXPECT_EQ(d.tensile_strength, p.tensile_strength);
  EXPECT_EQ(d.yield_stress, p.yield_stress);
  EXPECT_EQ(d.fracture_toughness, p.fracture_toughness);
  // Designated initializers change one value and keep the rest valid.
  EXPECT_OK(validate_material(Material{.density = 2300}));
}

}  // namespace
}  // namespace shatter
