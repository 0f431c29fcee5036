// Mesh validation: every problem found, each naming the file ids of the nodes/tets involved.
#pragma once

#include <string>
#include <vector>

#include "shatter/core/error.h"
#include "shatter/mesh/tet_mesh.h"

namespace shatter {

enum class MeshProblemKind {
  node_not_finite,     ///< NaN or Inf coordinate
  index_out_of_range,  ///< tet references a node that does not exist
  repeated_node,       ///< tet lists a node twice
  degenerate_tet,      ///< |volume| below the threshold
  inverted_tet,        ///< negative orientation (fixable by reorienting)
  overshared_face,     ///< face shared by more than two tets
  unreferenced_node,   ///< node used by no tet
  attribute_size,      ///< an optional attribute array has the wrong length
};
const char* to_string(MeshProblemKind kind);

enum class Severity { warning, error };

struct MeshProblem {
  MeshProblemKind kind;
  Severity severity;
  std::string message;  ///< names file ids: "tet 17 (nodes 3 4 9 12): volume -1.2e-06 < 0"
};

struct ValidateOptions {
  /// A tet whose |volume| < relative_volume_epsilon * (mean edge length)^3 is degenerate.
  double relative_volume_epsilon = 1e-12;
  /// Report at most this many problems of each kind (the counts stay exact).
  int max_reports_per_kind = 20;
};

struct ValidationReport {
  std::vector<MeshProblem> problems;  ///< capped per kind
  std::vector<std::size_t> counts;    ///< exact count per MeshProblemKind
  [[nodiscard]] bool has_errors() const;
  [[nodiscard]] std::size_t count(MeshProblemKind kind) const;
};

/// Check everything; never modifies the mesh.
ValidationReport validate_mesh(const TetMesh& mesh, const ValidateOptions& options = {});

/// Swap two corners of every negatively oriented tet. Returns the number reoriented.
Index fix_orientation(TetMesh& mesh);

/// Validate, reorient inverted tets (with one warning naming them), and fail on any other error.
/// Unreferenced nodes are a warning. The error message lists the first problems found.
Result<void> check_and_repair(TetMesh& mesh, const std::string& source_name, const ValidateOptions& options = {});

}  // namespace shatter
