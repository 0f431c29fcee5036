// Collision shapes for non-convex bodies: a compound of convex pieces, each the hull of a cluster of
// the body's own face-connected tets (docs/method.md §2.8). The clusters grow while the hull
// over-fills the tets it covers by no more than a set fraction, so a convex body is one piece and a
// curved shard a handful. Being built from the tets, the pieces follow the body through every crack
// and plastic dent at run time.
#pragma once

#include <vector>

#include "shatter/collide/convex_hull.h"
#include "shatter/core/error.h"
#include "shatter/mesh/tet_mesh.h"
#include "shatter/mesh/topology.h"

namespace shatter {

/// One convex piece of a body.
struct ConvexPiece {
  ConvexHull hull;          ///< in the mesh's frame (the body frame)
  std::vector<Index> tets;  ///< the tets it covers, sorted
  double tet_volume = 0;    ///< their total volume, m^3
};

/// Settings of the decomposition.
struct DecompositionOptions {
  /// Largest allowed (hull volume - tet volume) / tet volume of a piece.
  double max_overfill = 0.15;
  /// Upper bound on pieces; when the over-fill rule would make more, clusters are merged (least
  /// merged over-fill first) until this many remain. 0: no bound.
  Index max_pieces = 64;
  /// Meshes of up to this many tets are grown tet by tet. Finer ones are grown from about `groups`
  /// groups of neighbouring tets (face-connected tets whose centres share a cell of a grid), which
  /// bounds the time; the hulls stay exact (the hull of the nodes of a piece's tets). 0: always
  /// tet by tet.
  Index group_above = 4096;
  /// How many groups, about, when grouping (>= 1).
  Index groups = 1024;
};

/// Convex pieces covering every tet of `mesh` once (pieces in order of their lowest tet), each
/// hull holding its tets' nodes. Deterministic: the same mesh gives the same pieces in the same
/// order. max_overfill steers the growth, which counts the unassigned tets a hull already encloses
/// as material the piece will take; when neighbours take some of it, or leftovers are merged in, a
/// piece can end above max_overfill (within 2x in the tests; 3x when grown from groups).
/// Errors: a mesh with no tets; a piece whose points span no volume (degenerate tets).
Result<std::vector<ConvexPiece>> decompose_convex(const TetMesh& mesh, const TetFaces& faces,
                                                  const DecompositionOptions& options = {});

}  // namespace shatter
