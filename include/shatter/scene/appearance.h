// How a material looks, for the renderer and the glTF files of scene runs (docs/viewer.md).
#pragma once

#include <cstdint>

#include "shatter/core/types.h"
#include "shatter/fem/material.h"

namespace shatter {

/// Colours are linear RGB. Faces a crack opened show `inside`, with a solid texture of kind
/// `grain` evaluated in rest coordinates, so every fragment of a body shows one continuous
/// interior.
struct Appearance {
  enum class Grain : std::int32_t { none = 0, stone = 1, porcelain = 2, clay = 3, glass = 4, metal = 5 };
  Vec3 outside{0.7, 0.7, 0.7};
  Vec3 inside{0.6, 0.6, 0.6};
  double gloss = 0.2;  ///< 0 matte .. 1 glazed
  Grain grain = Grain::none;
};

/// The look of a material: by its preset name (porcelain, glass, concrete, clay, steel, ...), else
/// by its properties (brittle: stone; yielding and soft: clay; yielding and stiff: metal).
Appearance appearance_for(const Material& material);

}  // namespace shatter
