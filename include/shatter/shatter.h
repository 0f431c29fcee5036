// Everything a program needs to use shatter as a library: meshes and their files, materials,
// meshing, static analysis, fracture and plasticity, results and errors (docs/api.md).
// Each header below can also be included on its own.
#pragma once

// Core: math types, Result/Error, assertions, log sink, threads, hashing, random numbers.
#include "shatter/core/assert.h"
#include "shatter/core/error.h"
#include "shatter/core/hash.h"
#include "shatter/core/log.h"
#include "shatter/core/memory.h"
#include "shatter/core/parallel.h"
#include "shatter/core/random.h"
#include "shatter/core/types.h"

// Meshes: the tet mesh, topology, checks, quality, mass properties, node selection, generators, files.
#include "shatter/mesh/generate.h"
#include "shatter/mesh/io/mesh_io.h"
#include "shatter/mesh/mass_properties.h"
#include "shatter/mesh/node_selection.h"
#include "shatter/mesh/quality.h"
#include "shatter/mesh/tet_mesh.h"
#include "shatter/mesh/topology.h"
#include "shatter/mesh/validate.h"

// Meshing: shapes (signed distances), shape files, the meshers.
#include "shatter/meshing/box_csg_mesher.h"
#include "shatter/meshing/mesh_shape.h"
#include "shatter/meshing/revolve_mesher.h"
#include "shatter/meshing/sdf.h"
#include "shatter/meshing/shape_json.h"
#include "shatter/meshing/stuffing.h"
#include "shatter/meshing/surface_sdf.h"

// Finite elements: materials, constitutive models, tet kernels, the FEM model, stiffness.
#include "shatter/fem/assembly.h"
#include "shatter/fem/constitutive.h"
#include "shatter/fem/fem_model.h"
#include "shatter/fem/material.h"
#include "shatter/fem/tet_kernels.h"

// Solvers and fracture.
#include "shatter/fracture/crack.h"
#include "shatter/fracture/cut.h"
#include "shatter/fracture/fracture.h"
#include "shatter/fracture/fragments.h"
#include "shatter/fracture/plasticity.h"
#include "shatter/fracture/stress.h"
#include "shatter/solve/dynamic_solver.h"
#include "shatter/solve/linear_solvers.h"
#include "shatter/solve/static_solver.h"

// Bodies: one body's model (constant) and state (changing); rigid-body integration; the contact
// solver.
#include "shatter/rigid/body.h"
#include "shatter/rigid/contact_solver.h"
#include "shatter/rigid/impact.h"
#include "shatter/rigid/integrate.h"

// Collision detection: the broad phase, convex hulls and pieces, contact manifolds, the tet mode.
#include "shatter/collide/broad_phase.h"
#include "shatter/collide/contact.h"
#include "shatter/collide/convex_decomposition.h"
#include "shatter/collide/convex_hull.h"
#include "shatter/collide/tet_contact.h"

// The world: bodies, contacts and the fixed step.
#include "shatter/world/world.h"

// Static analysis of a mesh under a load case, and its result files.
#include "shatter/scene/scene.h"
#include "shatter/scene/static_analysis.h"
#include "shatter/scene/static_case.h"
#include "shatter/scene/static_fracture.h"
#include "shatter/scene/static_results.h"
