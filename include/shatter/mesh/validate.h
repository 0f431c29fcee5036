// Mesh validation: every problem found, each naming the file ids of the nodes/tets involved.
#pragma once

#include <string>
#include <vector>

#include "shatter/core/error.h"
#include "shatter/mesh/tet_mesh.h"

namespace shatter {

/// The kinds of problem validate_mesh reports.
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
/// The enumerator's name ("degenerate_tet", ...).
const char* to_string(MeshProblemKind kind);

/// error: the mesh cannot be used; warning: it can (inverted tets, unused nodes).
enum class Severity { warning, error };

/// One problem found in a mesh.
struct MeshProblem {
  MeshProblemKind kind;  ///< what is wrong
  Severity severity;     ///< whether it makes the mesh unusable
  std::string message;   ///< names file ids: "tet 17 (nodes 3 4 9 12): volume -1.2e-06 < 0"
};

/// Thresholds and limits of validate_mesh.
struct ValidateOptions {
  /// A tet whose |volume| <= relative_volume_epsilon * (mean edge length)^3 is degenerate.
  double relative_volume_epsilon = 1e-12;
  /// Report at most this many problems of each kind (the counts stay exact).
  int max_reports_per_kind = 20;
};

/// Every problem validate_mesh found.
struct ValidationReport {
  std::vector<MeshProblem> problems;  ///< capped per kind
  std::vector<std::size_t> counts;    ///< exact count per MeshProblemKind
  /// Whether any reported problem has error severity.
  [[nodiscard]] bool has_errors() const;
  /// Exact number of problems of `kind` (0 for an empty report).
  [[nodiscard]] std::size_t count(MeshProblemKind kind) const;
};

/// Check everything; never modifies the mesh. An attribute array of the wrong length ends the
/// checks there (the ids in further messages would be wrong).
ValidationReport validate_mesh(const TetMesh& mesh, const ValidateOptions& options = {});

/// Swap two corners of every negatively oriented tet. Returns the number reoriented.
Index fix_orientation(TetMesh& mesh);

/// Validate, reorient inverted tets (with one warning naming them), and fail on any other error.
/// Unreferenced nodes are a warning. The error message lists the first problems found.
Result<void> check_and_repair(TetMesh& mesh, const std::string& source_name, const ValidateOptions& options = {});

}  // namespace shatter
