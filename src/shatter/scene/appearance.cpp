#include "shatter/scene/appearance.h"

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <string>

namespace shatter {
namespace {

bool has(const std::string& name, std::initializer_list<const char*> words) {
  return std::any_of(words.begin(), words.end(), [&](const char* w) { return name.find(w) != std::string::npos; });
}

}  // namespace

Appearance appearance_for(const Material& m) {
  using G = Appearance::Grain;
  const std::string& n = m.name;
  if (has(n, {"porcelain", "china"})) return {{0.78, 0.8, 0.84}, {0.86, 0.83, 0.76}, 0.85, G::porcelain};
  if (has(n, {"glass", "acrylic", "pmma"})) return {{0.55, 0.72, 0.7}, {0.75, 0.88, 0.85}, 0.95, G::glass};
  if (has(n, {"terracotta", "fired_clay"})) return {{0.55, 0.25, 0.13}, {0.62, 0.3, 0.16}, 0.1, G::clay};
  if (has(n, {"clay", "plasticine"})) return {{0.42, 0.24, 0.13}, {0.38, 0.22, 0.12}, 0.15, G::clay};
  if (has(n, {"concrete", "cinder"})) return {{0.2, 0.19, 0.17}, {0.34, 0.32, 0.29}, 0.05, G::stone};
  if (has(n, {"granite", "marble", "stone"})) return {{0.62, 0.6, 0.58}, {0.7, 0.68, 0.66}, 0.3, G::stone};
  if (has(n, {"steel", "alumin", "lead", "iron"})) return {{0.55, 0.56, 0.58}, {0.7, 0.7, 0.72}, 0.7, G::metal};
  if (has(n, {"abs", "plastic"})) return {{0.7, 0.15, 0.12}, {0.72, 0.2, 0.16}, 0.4, G::none};
  // By properties.
  const bool brittle = !std::isfinite(m.yield_stress);
  if (brittle) return {{0.6, 0.58, 0.56}, {0.68, 0.66, 0.63}, 0.2, G::stone};
  if (m.youngs_modulus < 1e8) return {{0.55, 0.36, 0.22}, {0.5, 0.33, 0.2}, 0.15, G::clay};
  return {{0.55, 0.56, 0.58}, {0.7, 0.7, 0.72}, 0.7, G::metal};
}

}  // namespace shatter
