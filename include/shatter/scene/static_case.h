// A static load case (CASE.json, docs/static_case.md): material, model, anchors, loads, gravity
// and solver settings for a plain static analysis of one mesh, and its resolution against a mesh
// into per-node held components, prescribed displacements and external forces.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "shatter/core/error.h"
#include "shatter/core/types.h"
#include "shatter/fem/constitutive.h"
#include "shatter/fem/material.h"
#include "shatter/fracture/fracture.h"
#include "shatter/mesh/node_selection.h"
#include "shatter/mesh/tet_mesh.h"
#include "shatter/solve/static_solver.h"

namespace shatter {

/// Nodes whose components are held at their rest position plus `displacement`.
struct AnchorSpec {
  NodeSelector where;                ///< the nodes
  std::uint8_t components = 7;       ///< bit c (0 = x, 1 = y, 2 = z) set = component held
  Vec3 displacement = Vec3::Zero();  ///< prescribed displacement of the held components, m
  std::string field;                 ///< JSON path, for messages ("anchors[1]")
};

/// External force on nodes: `force` on each selected node, or `total_force` spread over them.
struct LoadSpec {
  NodeSelector where;         ///< the nodes
  Vec3 force = Vec3::Zero();  ///< N: per node (per_node) or in total
  bool per_node = true;       ///< "force" (true) or "total_force" (false)
  /// How a total force is spread: equally per node, or by lumped boundary area (each boundary
  /// triangle whose three corners are selected gives a third of its area to each corner).
  enum class Distribution { equal, area } distribution = Distribution::equal;
  std::string field;  ///< JSON path ("loads[0]")
};

/// Solver settings as given in the case (absent = the solver's default).
struct CaseSolverSettings {
  std::optional<LinearSolverKind> linear_solver;      ///< "direct" | "pcg-jacobi" | "pcg-gauss-seidel"
  std::optional<double> tolerance;                    ///< relative residual tolerance of Newton
  std::optional<double> linear_tolerance;             ///< relative tolerance of an iterative linear solver
  std::optional<std::int64_t> linear_max_iterations;  ///< iteration limit of an iterative linear solver
  std::optional<std::int64_t> max_iterations;         ///< Newton iterations (per load step)
  std::optional<std::int64_t> load_steps;             ///< load increments
  std::optional<bool> line_search;                    ///< energy line search on / off
  std::optional<TangentKind> tangent;                 ///< "on-demand" | "projected" | "exact"
};

/// A parsed load case.
struct StaticCase {
  std::string file;                   ///< the case file (for messages)
  std::string name;                   ///< "name", or the case file's stem
  Material material;                  ///< validated
  ModelKind model = ModelKind::stvk;  ///< constitutive model
  std::vector<AnchorSpec> anchors;    ///< at least one
  std::vector<LoadSpec> loads;        ///< external forces (may be empty)
  Vec3 gravity = Vec3::Zero();        ///< m/s^2; zero = off ("gravity": true gives (0, -9.81, 0))
  CaseSolverSettings solver;          ///< the "solver" section
  /// The "fracture" section (crack, cut and plasticity options); used by `shatter static --fracture`.
  FractureOptions fracture;
  bool fracture_given = false;  ///< the case has a "fracture" section
};

/// Parse a case from JSON text; `file` names it in messages and gives the default name.
Result<StaticCase> parse_static_case(std::string_view json_text, const std::string& file);
/// Read and parse a case file.
Result<StaticCase> read_static_case(const std::string& path);

/// A case applied to a mesh.
struct ResolvedStaticCase {
  std::vector<std::uint8_t> held;  ///< held components per node, bits as AnchorSpec (#nodes)
  std::vector<Vec3> prescribed;    ///< rest position + prescribed displacement, m (#nodes)
  std::vector<Vec3> forces;        ///< external nodal forces without gravity, N (#nodes)
  /// Sum of the applied part of `forces` (free components of nodes some tet uses), N.
  Vec3 total_load = Vec3::Zero();
  Index num_held_nodes = 0;  ///< nodes with at least one held component
  /// Loads (partly or wholly) on held components or on nodes no tet uses, whose force there is not
  /// applied: one line each, naming the file and the load.
  std::vector<std::string> warnings;
};

/// Select the nodes of every anchor and load. Errors name the case file and the JSON path: an id
/// not in the mesh, a selection with no node, a load spread by area over nodes that span no
/// boundary triangle, and anchors that leave a rigid motion free (per connected piece of the mesh).
/// Where several anchors hold one node, the held components are united (a later anchor's
/// displacement wins for the components it holds).
Result<ResolvedStaticCase> resolve_static_case(const StaticCase& c, const TetMesh& mesh);

/// The solver's problem: anchors, prescribed positions, forces and gravity.
StaticProblem make_static_problem(const StaticCase& c, const ResolvedStaticCase& resolved);
/// The solver's options: its defaults, overridden by what the case sets.
StaticSolverOptions make_solver_options(const CaseSolverSettings& settings);

}  // namespace shatter
