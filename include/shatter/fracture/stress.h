// Per-tet stress analysis of a deformed state: Cauchy stress, principal stresses and directions, and
// the signed display stress (docs/method.md §2.5; tension positive).
#pragma once

#include <vector>

#include "shatter/core/types.h"
#include "shatter/fem/fem_model.h"

namespace shatter {

/// The stress of one tet and what is derived from it.
struct TetStress {
  Mat3 sigma = Mat3::Zero();           ///< Cauchy stress, Pa
  Vec3 principal = Vec3::Zero();       ///< principal stresses, Pa, descending (tension positive)
  Mat3 directions = Mat3::Identity();  ///< unit principal directions as columns (same order)
  /// The larger in magnitude of the largest tensile and largest compressive principal stress,
  /// signed (Pa): positive = tension (drawn red), negative = compression (green).
  double display = 0;
  double von_mises = 0;  ///< von Mises equivalent stress, Pa
};

/// Principal values, directions, display and von Mises stress of one Cauchy stress tensor.
TetStress analyze_stress(const Mat3& sigma);

/// Per tet of the model (#tets): the Cauchy stress of the deformed positions `deformed` (m, #nodes)
/// under the model's constitutive law and rest data, analysed as above. The one per-tet stress path:
/// static results, fracture and plasticity all use it. Parallel over tets; the result does not
/// depend on the thread count.
std::vector<TetStress> compute_stresses(const FemModel& model, const std::vector<Vec3>& deformed);

/// The same where the tets with at_rest[e] != 0 (#tets) are known to be undeformed (all four
/// corners held at their rest positions, as the far field of an impact): their stress is exactly
/// zero (TetStress{}) and is not computed. The other tets get the bits compute_stresses gives.
std::vector<TetStress> compute_stresses(const FemModel& model, const std::vector<Vec3>& deformed,
                                        const std::vector<char>& at_rest);

/// The same from given stress tensors (Pa, #tets), e.g. from another solver or a test field.
std::vector<TetStress> analyze_stresses(const std::vector<Mat3>& sigma);

}  // namespace shatter
