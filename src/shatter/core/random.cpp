#include "shatter/core/random.h"

#include <cmath>

namespace shatter {

Vec3 Random::unit_vec3() {
  // Archimedes: z uniform in [-1, 1], azimuth uniform.
  const double z = uniform(-1.0, 1.0);
  const double phi = uniform(0.0, 2.0 * M_PI);
  const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
  return {r * std::cos(phi), r * std::sin(phi), z};
}

}  // namespace shatter
