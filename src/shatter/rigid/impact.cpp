// Impact analysis (see impact.h and docs/impacts.md).
#include "shatter/rigid/impact.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <numeric>
#include <optional>
#include <string>
#include <utility>

#include "shatter/core/assert.h"
#include "shatter/core/clock.h"
#include "shatter/core/parallel.h"
#include "shatter/fracture/cut.h"
#include "shatter/fracture/fragments.h"
#include "shatter/fracture/stress.h"
#include "shatter/mesh/mass_properties.h"
#include "shatter/mesh/topology.h"

namespace shatter {
namespace {

// A loaded contact in the body frame.
struct LocalLoad {
  Vec3 point;      // m
  Vec3 direction;  // unit, into the body
  double impulse;  // N s
};

// Per surface vertex: its share of the surface area (a third of each triangle's), m^2, and its
// area-weighted outward normal (not unit).
struct SurfaceAreas {
  std::vector<double> area;
  std::vector<Vec3> normal;
  std::vector<double> edge;  // mean length of the edges of its triangles, m
};

SurfaceAreas surface_areas(const TriSurface& s) {
  const std::size_t nv = s.positions.size();
  SurfaceAreas a;
  a.area.assign(nv, 0.0);
  a.normal.assign(nv, Vec3::Zero());
  a.edge.assign(nv, 0.0);
  std::vector<int> edges(nv, 0);
  for (const TriIndices& t : s.triangles) {
    const Vec3& p0 = s.positions[t[0]];
    const Vec3& p1 = s.positions[t[1]];
    const Vec3& p2 = s.positions[t[2]];
    const Vec3 n = 0.5 * (p1 - p0).cross(p2 - p0);
    const double len = (p1 - p0).norm() + (p2 - p1).norm() + (p0 - p2).norm();
    for (const Index v : t) {
      a.area[v] += n.norm() / 3.0;
      a.normal[v] += n;
      a.edge[v] += len;
      edges[v] += 3;
    }
  }
  for (std::size_t v = 0; v < nv; ++v)
    if (edges[v] > 0) a.edge[v] /= edges[v];
  return a;
}

// Nodes held for the paper's mode: every node of every tet whose centroid is farther than r from
// all loads; when none is, the tets beyond 80 % of the farthest centroid distance. Nothing when
// that far field is less than a twentieth of the tets (see respond).
std::optional<std::vector<AnchorMask>> hold_far(const TetMesh& mesh, const std::vector<LocalLoad>& loads, double r) {
  const Index nt = mesh.num_tets();
  std::vector<double> distance(static_cast<std::size_t>(nt));
  double farthest = 0;
  for (Index e = 0; e < nt; ++e) {
    const TetIndices& t = mesh.tets[e];
    const Vec3 c = 0.25 * (mesh.positions[t[0]] + mesh.positions[t[1]] + mesh.positions[t[2]] + mesh.positions[t[3]]);
    double d = std::numeric_limits<double>::infinity();
    for (const LocalLoad& l : loads) d = std::min(d, (c - l.point).norm());
    distance[e] = d;
    farthest = std::max(farthest, d);
  }
  const double limit = farthest > r ? r : 0.8 * farthest;
  std::vector<AnchorMask> anchors(mesh.positions.size(), anchor_none);
  Index held = 0;
  for (Index e = 0; e < nt; ++e)
    if (distance[e] > limit || distance[e] == farthest) {
      ++held;
      for (const Index v : mesh.tets[e]) anchors[v] = anchor_all;
    }
  if (20 * held < nt) return std::nullopt;
  return anchors;
}

// Inertia relief: body forces that balance the load's force and moment about the centre of the
// lumped masses (f_i = -m_i (a + alpha x r_i)), and three far, spread nodes held.
std::vector<AnchorMask> hold_inertia_relief(const TetMesh& mesh, const FemModel& fem, const Vec3& load_point,
                                            std::vector<Vec3>& forces) {
  const std::size_t nn = mesh.positions.size();
  const MassProperties lumped = point_mass_properties(fem.node_mass, mesh.positions);
  const Vec3& centre = lumped.center;
  Vec3 force = Vec3::Zero();
  Vec3 moment = Vec3::Zero();
  for (std::size_t i = 0; i < nn; ++i) {
    force += forces[i];
    moment += (mesh.positions[i] - centre).cross(forces[i]);
  }
  const Vec3 a = force / lumped.mass;
  const Vec3 alpha = lumped.inertia.ldlt().solve(moment);
  for (std::size_t i = 0; i < nn; ++i) forces[i] -= fem.node_mass[i] * (a + alpha.cross(mesh.positions[i] - centre));
  // Three held nodes: the farthest from the load, the farthest from it, and the farthest from
  // the line through both (ties: the lower index).
  auto farthest = [&](auto&& distance) {
    Index best = 0;
    double best_d = -1;
    for (std::size_t i = 0; i < nn; ++i) {
      if (fem.node_mass[i] <= 0) continue;
      const double d = distance(mesh.positions[i]);
      if (d > best_d) {
        best_d = d;
        best = static_cast<Index>(i);
      }
    }
    return best;
  };
  const Index n0 = farthest([&](const Vec3& x) { return (x - load_point).norm(); });
  const Index n1 = farthest([&](const Vec3& x) { return (x - mesh.positions[n0]).norm(); });
  const Vec3 axis = (mesh.positions[n1] - mesh.positions[n0]).normalized();
  const Index n2 = farthest([&](const Vec3& x) {
    const Vec3 d = x - mesh.positions[n0];
    return (d - d.dot(axis) * axis).norm();
  });
  std::vector<AnchorMask> anchors(nn, anchor_none);
  for (const Index v : {n0, n1, n2}) anchors[v] = anchor_all;
  return anchors;
}

// Crack flags of a child's surface: a triangle lying on a boundary face of its parent tet keeps
// that face's flag; any other triangle was opened by this event's cracks.
std::vector<std::uint8_t> child_crack_faces(const BodyModel& parent, const std::vector<Vec3>& parent_rest,
                                            const TriSurface& child_surface, const Vec3& child_offset,
                                            const std::vector<Index>& child_parent_tet, double tolerance) {
  std::map<std::array<Index, 3>, std::uint8_t> parent_flag;
  for (std::size_t t = 0; t < parent.surface.triangles.size(); ++t) {
    if (t >= parent.crack_face.size() || !parent.crack_face[t]) continue;
    std::array<Index, 3> key;
    for (int k = 0; k < 3; ++k) key[k] = parent.surface.vertex_node[parent.surface.triangles[t][k]];
    std::sort(key.begin(), key.end());
    parent_flag[key] = 1;
  }
  std::vector<std::uint8_t> flags(child_surface.triangles.size(), 1);
  for (std::size_t t = 0; t < child_surface.triangles.size(); ++t) {
    const TriIndices& tri = child_surface.triangles[t];
    std::array<Vec3, 3> v;
    for (int k = 0; k < 3; ++k) v[k] = child_surface.positions[tri[k]] + child_offset;
    const Vec3 tn = (v[1] - v[0]).cross(v[2] - v[0]).normalized();
    const Index pt = child_parent_tet[child_surface.triangle_tet[t]];
    for (int k = 0; k < 4; ++k) {
      const Index f = parent.faces.tet_faces[pt][k];
      if (!parent.faces.is_boundary(f)) continue;
      const TriIndices& pf = parent.faces.faces[f];
      const Vec3& q0 = parent_rest[pf[0]];
      const Vec3 n = (parent_rest[pf[1]] - q0).cross(parent_rest[pf[2]] - q0).normalized();
      if (n.dot(tn) < 0.999) continue;
      if (std::abs(n.dot(v[0] - q0)) > tolerance || std::abs(n.dot(v[1] - q0)) > tolerance ||
          std::abs(n.dot(v[2] - q0)) > tolerance)
        continue;
      std::array<Index, 3> key{pf[0], pf[1], pf[2]};
      std::sort(key.begin(), key.end());
      flags[t] = parent_flag.contains(key) ? 1 : 0;
      break;
    }
  }
  return flags;
}

// Each load's force as a uniform pressure over its patch: the surface vertices within the patch
// radius that do not face away from the push (area weights); the nearest vertex alone takes it
// when no vertex qualifies. `force[k]` is load k's force, N; `radius_floor` is the smallest patch
// radius, m. Adds into `forces` (#nodes), marks `loaded`; returns the largest patch radius.
double spread_loads(const BodyModel& model, const std::vector<LocalLoad>& loads, const std::vector<double>& force,
                    double radius_floor, const ImpactSettings& settings, std::vector<Vec3>& forces,
                    std::vector<char>& loaded) {
  const TriSurface& surface = model.surface;
  const SurfaceAreas areas = surface_areas(surface);
  const std::size_t nv = surface.positions.size();
  double largest = 0;
  std::vector<std::pair<Index, double>> patch;
  for (std::size_t k = 0; k < loads.size(); ++k) {
    const LocalLoad& l = loads[k];
    Index nearest = 0;
    double nearest_d = std::numeric_limits<double>::infinity();
    for (std::size_t v = 0; v < nv; ++v) {
      const double d = (surface.positions[v] - l.point).squaredNorm();
      if (d < nearest_d) {
        nearest_d = d;
        nearest = static_cast<Index>(v);
      }
    }
    const double radius = std::max(radius_floor, settings.patch_edges * areas.edge[nearest]);
    largest = std::max(largest, radius);
    patch.clear();
    double total = 0;
    for (std::size_t v = 0; v < nv; ++v) {
      if ((surface.positions[v] - l.point).norm() > radius ||
          areas.normal[v].normalized().dot(l.direction) > settings.patch_facing)
        continue;
      patch.emplace_back(static_cast<Index>(v), areas.area[v]);
      total += areas.area[v];
    }
    if (!(total > 0)) {
      patch.assign(1, {nearest, 1.0});
      total = 1.0;
    }
    for (const auto& [v, w] : patch) {
      const Index node = surface.vertex_node[v];
      forces[node] += (force[k] * w / total) * l.direction;
      loaded[node] = 1;
    }
  }
  return largest;
}

double body_radius_of(const BodyModel& model) {
  double r = 0;
  for (const Vec3& p : model.mesh.positions) r = std::max(r, p.norm());
  return r;
}

Result<void> check_state(const BodyModel& model, const BodyState& state, const char* what) {
  const Index nt = model.mesh.num_tets();
  if (nt == 0) return make_error(std::string(what) + ": the body model has no tets");
  if (!state.plastic_strain.empty() && state.plastic_strain.size() != static_cast<std::size_t>(nt))
    return make_error(std::string(what) + ": the state has " + std::to_string(state.plastic_strain.size()) +
                      " plastic strains for " + std::to_string(nt) + " tets");
  if (!state.tensile_strength.empty() && state.tensile_strength.size() != static_cast<std::size_t>(nt))
    return make_error(std::string(what) + ": the state has " + std::to_string(state.tensile_strength.size()) +
                      " tensile strengths for " + std::to_string(nt) + " tets");
  for (const double s : state.tensile_strength)
    if (!(s > 0))
      return make_error(std::string(what) + ": a tet's tensile strength is " + format_number(s) + " Pa (expected > 0)");
  return {};
}

// The children of a cut body (fr: its fracture or slice), with the debris rules of `settings`:
// exact mass properties, eq. 22 motion, crack faces and rest coordinates for solid textures; each
// child tet keeps the tensile strength of its parent tet (`strength`, #parent tets or empty).
void make_children(const BodyModel& model, const RigidState& rigid, const FractureResult& fr,
                   const std::vector<double>& strength, double body_radius, const ImpactSettings& settings,
                   ImpactResult& result) {
  const Material& material = model.fem.material;
  // The density follows the rest volume so that the parent's mass is kept exactly
  // (plasticity may have changed the volume; a cut never does).
  double volume = 0;
  for (const Fragment& f : fr.fragments) volume += f.mass.volume;
  Material child_material = material;
  child_material.density = model.mass.mass / volume;
  // Debris rules: the heaviest max_fragments children over the size limits are kept.
  std::vector<std::size_t> order(fr.fragments.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    const double va = fr.fragments[a].mass.volume, vb = fr.fragments[b].mass.volume;
    return va != vb ? va > vb : a < b;
  });

  std::vector<char> keep(fr.fragments.size(), 0);
  const double min_mass = std::max(settings.min_fragment_mass, settings.min_fragment_fraction * model.mass.mass);
  int kept = 0;
  for (const std::size_t k : order) {
    const double m = child_material.density * fr.fragments[k].mass.volume;
    if (kept < settings.max_fragments && m >= min_mass) {
      keep[k] = 1;
      ++kept;
    } else {
      ++result.debris_count;
      result.debris_mass += m;
    }
  }
  const Mat3 to_world = rigid.orientation.toRotationMatrix();
  const double tolerance = 1e-7 * std::max(body_radius, 1e-3);
  std::vector<std::size_t> kept_fragments;
  for (std::size_t k = 0; k < fr.fragments.size(); ++k)
    if (keep[k]) kept_fragments.push_back(k);
  // The children's face tables: the cut mesh's from the parent's (only what the cuts changed is
  // searched), split among the kept children in one pass.
  std::vector<TetFaces> child_faces;
  {
    const std::size_t cut_tets = fr.mesh.tets.size();
    std::vector<Index> tet_part(cut_tets, -1), local_tet(cut_tets, -1), local_node(fr.mesh.positions.size(), -1);
    std::vector<Index> part_tets;
    for (std::size_t i = 0; i < kept_fragments.size(); ++i) {
      const Fragment& f = fr.fragments[kept_fragments[i]];
      part_tets.push_back(static_cast<Index>(f.tet_map.size()));
      for (std::size_t e = 0; e < f.tet_map.size(); ++e) {
        tet_part[static_cast<std::size_t>(f.tet_map[e])] = static_cast<Index>(i);
        local_tet[static_cast<std::size_t>(f.tet_map[e])] = static_cast<Index>(e);
      }
      for (std::size_t v = 0; v < f.node_map.size(); ++v)
        local_node[static_cast<std::size_t>(f.node_map[v])] = static_cast<Index>(v);
    }
    child_faces =
        split_faces(update_faces(model.mesh, model.faces, fr.mesh), tet_part, local_tet, local_node, part_tets);
  }
  // Each child's model (faces, surface, FEM rest data, mass properties, crack flags) depends only
  // on its fragment and the parent: built side by side, each into its own slot, in fragment order.
  std::vector<ImpactChild> children(kept_fragments.size());
  parallel_for(
      0, static_cast<std::int64_t>(children.size()),
      [&](std::int64_t i) {
        const Fragment& f = fr.fragments[kept_fragments[static_cast<std::size_t>(i)]];
        ImpactChild& child = children[static_cast<std::size_t>(i)];
        const Vec3 c = f.mass.center;
        auto m = std::make_shared<BodyModel>();
        m->mesh = f.mesh;
        for (Vec3& p : m->mesh.positions) p -= c;
        m->faces = std::move(child_faces[static_cast<std::size_t>(i)]);
        m->surface = boundary_surface(m->mesh, m->faces);
        // Tets the cut and plasticity left as they were keep the parent's rest data.
        std::vector<Index> same_rest(f.tet_map.size());
        for (std::size_t e = 0; e < f.tet_map.size(); ++e) {
          const Index pt = fr.tet_parent[f.tet_map[e]];
          bool same = true;
          for (int corner = 0; corner < 4 && same; ++corner)
            same = f.mesh.positions[f.mesh.tets[e][corner]] == model.mesh.positions[model.mesh.tets[pt][corner]];
          same_rest[e] = same ? pt : -1;
        }
        m->fem = make_fem_model(m->mesh, child_material, model.fem.model, {.model = &model.fem, .tet = same_rest});
        m->mass = mass_properties(m->mesh, child_material.density);
        m->material_origin = model.material_origin + c;
        child.origin = c;
        child.parent_tet.resize(f.tet_map.size());
        child.plastic_strain.resize(f.tet_map.size());
        for (std::size_t e = 0; e < f.tet_map.size(); ++e) {
          child.parent_tet[e] = fr.tet_parent[f.tet_map[e]];
          child.plastic_strain[e] = fr.plastic_strain[f.tet_map[e]];
        }
        child.unchanged_parent_tet = std::move(same_rest);
        if (!strength.empty())
          for (const Index e : child.parent_tet)
            child.tensile_strength.push_back(strength[static_cast<std::size_t>(e)]);
        m->crack_face = child_crack_faces(model, fr.plastic.rest_positions, m->surface, c, child.parent_tet, tolerance);
        // Eq. 22: the child keeps the velocity of the parent's material at its centre.
        child.rigid.orientation = rigid.orientation;
        child.rigid.position = rigid.position + to_world * c;
        child.rigid.angular_velocity = rigid.angular_velocity;
        child.rigid.linear_velocity =
            rigid.linear_velocity + rigid.angular_velocity.cross(child.rigid.position - rigid.position);
        child.model = std::move(m);
      },
      2);
  for (ImpactChild& child : children) result.children.push_back(std::move(child));
}

// Steps 3-6 of the analysis (impact.h): hold, solve, stresses, plasticity, cracks, children, for
// the nodal `forces` (N, body frame) of `loads`.
Result<void> respond(const BodyModel& model, BodyState& state, const std::vector<LocalLoad>& loads,
                     std::vector<Vec3> forces, double body_radius, const ImpactSettings& settings,
                     ImpactResult& result) {
  const std::size_t nn = model.mesh.positions.size();
  const Index nt = model.mesh.num_tets();
  const RigidState& rigid = state.rigid;
  const Material& material = model.fem.material;
  double total_weight = 0;
  for (const LocalLoad& l : loads) total_weight += l.impulse;
  // Hold the body and solve its static response.
  StaticProblem problem;
  // Contacts along most of a long piece (landing flat) leave only its end beyond r_coll: that end
  // would clamp the piece rather than stand in for its inertia, and the piece would swing about it
  // under the load. Such a piece is held by inertia relief instead.
  std::optional<std::vector<AnchorMask>> far;
  if (settings.hold == ImpactHold::anchor_far)
    far = hold_far(model.mesh, loads, settings.collision_radius * body_radius);
  if (far) {
    result.collision_radius = settings.collision_radius * body_radius;
    problem.anchors = std::move(*far);
  } else {
    Vec3 local_load_point = Vec3::Zero();
    for (const LocalLoad& l : loads) local_load_point += (l.impulse / total_weight) * l.point;
    problem.anchors = hold_inertia_relief(model.mesh, model.fem, local_load_point, forces);
  }
  for (std::size_t i = 0; i < nn; ++i)
    if (problem.anchors[i] != anchor_none) ++result.held_nodes;
  problem.external_forces = std::move(forces);
  if (!state.solver) state.solver = std::make_shared<StaticSolver>();
  // Held at three nodes, the body is all but free to bend as a whole: PCG with Gauss-Seidel would
  // spend its first 50 iterations finding that out.
  StaticSolverOptions solver_options = settings.solver;
  solver_options.ill_conditioned = !far;
  state.solver->set_options(solver_options);
  std::vector<Vec3> x = model.mesh.positions;
  auto t0 = Clock::now();
  SHATTER_TRY(report, state.solver->solve(model.fem, problem, x));
  result.solve = *report;
  result.solve_ms = ms_since(t0);

  // Stresses, then plasticity and cracks only where a limit is passed.
  t0 = Clock::now();
  // Tets held whole by the far field stay at rest: their stress is zero, not computed.
  std::vector<TetStress> stress;
  if (far) {
    std::vector<char> at_rest(static_cast<std::size_t>(nt), 0);
    for (Index e = 0; e < nt; ++e) {
      const TetIndices& t = model.mesh.tets[e];
      at_rest[e] = problem.anchors[t[0]] == anchor_all && problem.anchors[t[1]] == anchor_all &&
                   problem.anchors[t[2]] == anchor_all && problem.anchors[t[3]] == anchor_all;
    }
    stress = compute_stresses(model.fem, x, at_rest);
  } else {
    stress = compute_stresses(model.fem, x);
  }
  result.display_stress.resize(stress.size());
  result.principal_stress.resize(stress.size());
  for (std::size_t e = 0; e < stress.size(); ++e) {
    result.display_stress[e] = stress[e].display;
    result.principal_stress[e] = stress[e].principal[0];
  }
  for (const TetStress& s : stress) {
    result.max_principal_stress = std::max(result.max_principal_stress, s.principal[0]);
    result.max_von_mises = std::max(result.max_von_mises, s.von_mises);
  }
  const FractureOptions& fo = settings.fracture;
  // Some tet over its strength, by the tension the crack criterion reads (plan_cracks).
  bool over_strength = false;
  for (std::size_t e = 0; e < stress.size() && !over_strength; ++e) {
    const TetStress& s = stress[e];
    const double tension = fo.crack.return_to_yield && s.von_mises > material.yield_stress
                               ? s.principal[0] * (material.yield_stress / s.von_mises)
                               : s.principal[0];
    over_strength = tension > (state.tensile_strength.empty() ? material.tensile_strength : state.tensile_strength[e]);
  }
  const bool may_crack = fo.crack.max_cracks > 0 && over_strength;
  const bool may_yield = fo.plasticity.enabled && result.max_von_mises > material.yield_stress;
  if (!may_crack && !may_yield) {
    result.fracture_ms = ms_since(t0);
    return {};
  }
  FractureOptions options = fo;
  options.plastic_strain = result.plastic_strain;
  options.tensile_strength = state.tensile_strength;
  options.faces = &model.faces;
  FractureResult fr = fracture_with_stress(model.mesh, model.fem, x, std::move(stress), options);
  result.cracks = fr.events;
  result.dented = !fr.plastic.moved_nodes.empty();

  if (fr.events.empty()) {
    result.plastic_strain = fr.plastic.plastic_strain;
    if (result.dented) {
      ImpactChild child;
      auto dented = std::make_shared<BodyModel>(model);
      BodyState moved;
      moved.rigid = rigid;
      child.origin = apply_plastic_update(*dented, moved, fr.plastic);
      child.model = std::move(dented);
      child.rigid = moved.rigid;
      child.plastic_strain = fr.plastic.plastic_strain;
      child.tensile_strength = state.tensile_strength;
      child.parent_tet.resize(static_cast<std::size_t>(nt));
      std::iota(child.parent_tet.begin(), child.parent_tet.end(), Index(0));
      result.children.push_back(std::move(child));
    }
    result.fracture_ms = ms_since(t0);
    return {};
  }

  make_children(model, rigid, fr, state.tensile_strength, body_radius, settings, result);
  result.fracture_ms = ms_since(t0);
  return {};
}

}  // namespace

const char* to_string(ImpactHold hold) {
  switch (hold) {
    case ImpactHold::anchor_far: return "anchor-far";
    case ImpactHold::inertia_relief: return "inertia-relief";
  }
  return "?";
}

StaticSolverOptions default_impact_solver_options() {
  StaticSolverOptions o;
  o.warm_start = false;
  // An impact's stresses decide cracks at a few per cent: 1e-5 of the load is plenty. In the
  // reference scenes every analysed stress is within 1e-5 of what 1e-6 gives, with the same cracks,
  // and many impacts save a Newton iteration (the lower cinder block's: 1.1e-6 after two).
  o.relative_residual_tolerance = 1e-5;
  // StVK bodies use the projected stiffness: under a contact's concentrated load the exact one is
  // indefinite in many iterations, and the exact steps carry the solve further into StVK's
  // compressive softening (docs/solver.md: a StVK clay teddy's first drop tears instead of
  // denting). The corotated and linear models do not soften: their exact stiffness, projected only
  // on demand, converges quadratically (a corotated clay teddy's drop: 6 iterations).
  o.tangent = TangentKind::by_model;
  // An impact's time is bounded: a large deformation that Newton cannot follow within these ends
  // at the load fraction reached (the report says so) instead of taking seconds.
  o.max_newton_iterations = 12;
  o.max_load_halvings = 3;
  // ... and so is one whose load steps each converge, slowly (a thin flap of a fragment bending
  // far under the load took 174 iterations in as many as 14 load steps).
  o.max_total_newton_iterations = 60;
  o.abandon_slow_load_steps = true;
  o.limit_resolution = 0.125;
  // Near the solution a step reuses the last tangent and its factorization: an impact's second
  // Newton step then costs a triangular solve instead of a refill (and a factorization).
  o.chord_tolerance = 1e-2;
  return o;
}

FractureOptions default_impact_fracture_options() {
  FractureOptions o;
  o.crack.branch = true;
  o.crack.return_to_yield = true;
  return o;
}

double hertz_effective_modulus(const Material& a, const Material& b) {
  const double ca = (1 - a.poisson_ratio * a.poisson_ratio) / a.youngs_modulus;
  const double cb = std::isinf(b.youngs_modulus) ? 0.0 : (1 - b.poisson_ratio * b.poisson_ratio) / b.youngs_modulus;
  return 1.0 / (ca + cb);
}

HertzImpact hertz_impact(double effective_mass, double speed, double radius, double effective_modulus) {
  HertzImpact h;
  if (!(effective_mass > 0) || !(speed > 0) || !(radius > 0) || !(effective_modulus > 0)) return h;
  const double sqrt_r = std::sqrt(radius);
  h.max_approach = std::pow(15.0 * effective_mass * speed * speed / (16.0 * effective_modulus * sqrt_r), 0.4);
  h.contact_time = 2.94 * h.max_approach / speed;
  h.contact_radius = std::sqrt(radius * h.max_approach);
  h.peak_force = 4.0 / 3.0 * effective_modulus * sqrt_r * std::pow(h.max_approach, 1.5);
  return h;
}

ElasticPlasticImpact elastic_plastic_impact(double effective_mass, double speed, double radius,
                                            double effective_modulus, double limit_pressure) {
  ElasticPlasticImpact p;
  const HertzImpact h = hertz_impact(effective_mass, speed, radius, effective_modulus);
  p.max_approach = h.max_approach;
  p.contact_radius = h.contact_radius;
  p.peak_force = h.peak_force;
  p.yield_approach = kInfinity;
  if (!(h.max_approach > 0) || !(limit_pressure > 0) || std::isinf(limit_pressure)) return p;
  // Hertz's peak pressure 2 E* a / (pi R) with a = sqrt(R delta) reaches p_y at delta_y.
  const double ratio = std::numbers::pi * limit_pressure / (2.0 * effective_modulus);
  p.yield_approach = radius * ratio * ratio;
  if (h.max_approach <= p.yield_approach) return p;
  // Past delta_y the force grows linearly with stiffness k = pi p_y R; the work up to delta_y is
  // Hertz's (8/15) E* sqrt(R) delta_y^(5/2) = (2/5) F_y delta_y. The rest of the energy E - W_y =
  // F_y x + k x^2 / 2 over the further approach x gives the peak F_y + k x = sqrt(F_y^2 + 2 k (E - W_y)).
  const double k = std::numbers::pi * limit_pressure * radius;
  const double force_y = 4.0 / 3.0 * effective_modulus * std::sqrt(radius) * std::pow(p.yield_approach, 1.5);
  const double work_y = 0.4 * force_y * p.yield_approach;
  const double energy = 0.5 * effective_mass * speed * speed;
  p.peak_force = std::sqrt(force_y * force_y + 2.0 * k * std::max(energy - work_y, 0.0));
  p.max_approach = p.yield_approach + (p.peak_force - force_y) / k;
  p.contact_radius = std::sqrt(radius * p.max_approach);
  p.yielded = true;
  return p;
}

Result<ImpactResult> analyze_impact(const BodyModel& model, BodyState& state, std::span<const ImpactContact> contacts,
                                    const ImpactSettings& settings) {
  SHATTER_TRY(checked, check_state(model, state, "analyze_impact"));
  const std::size_t nn = model.mesh.positions.size();
  const Index nt = model.mesh.num_tets();
  for (std::size_t k = 0; k < contacts.size(); ++k) {
    const ImpactContact& c = contacts[k];
    if (!c.point.allFinite() || !c.normal.allFinite() || !std::isfinite(c.normal_impulse) ||
        !std::isfinite(c.approach_speed) || c.normal_impulse < 0 || !(c.normal.norm() > 0))
      return make_error("analyze_impact: contact " + std::to_string(k) +
                        " is not finite, has a zero normal or a negative impulse");
  }

  ImpactResult result;
  result.plastic_strain = state.plastic_strain;
  if (result.plastic_strain.empty()) result.plastic_strain.assign(static_cast<std::size_t>(nt), 0.0);

  // Loads in the body frame; the impact's speed is that of its fastest loaded contact.
  const RigidState& rigid = state.rigid;
  const Mat3 to_body = rigid.orientation.toRotationMatrix().transpose();
  std::vector<LocalLoad> loads;
  Vec3 weighted_point = Vec3::Zero();
  for (const ImpactContact& c : contacts) {
    if (!(c.normal_impulse > 0)) continue;
    loads.push_back({to_body * (c.point - rigid.position), to_body * c.normal.normalized(), c.normal_impulse});
    result.impulse += c.normal_impulse;
    result.approach_speed = std::max(result.approach_speed, c.approach_speed);
    weighted_point += c.normal_impulse * c.point;
  }
  if (loads.empty() || result.approach_speed < settings.min_approach_speed) return result;
  result.analysed = true;
  result.load_point = weighted_point / result.impulse;

  // The load: Hertz's contact time for the effective mass the impulse implies, and the impulse
  // delivered as a half-sine pulse of that duration, whose peak is (pi/2) J / T_c. Where the
  // contact yields, Thornton's law lowers that peak by the ratio of its peak force to Hertz's and
  // widens the patch to its contact radius.
  const double body_radius = body_radius_of(model);
  const Material& material = model.fem.material;
  const Material& other = settings.other_material.value_or(material);
  const double e_star = hertz_effective_modulus(material, other);
  const double curvature = settings.curvature_radius * body_radius;
  result.effective_mass = result.impulse / ((1 + settings.restitution) * result.approach_speed);
  const HertzImpact hertz = hertz_impact(result.effective_mass, result.approach_speed, curvature, e_star);
  result.contact_time = std::clamp(hertz.contact_time, settings.min_contact_time, settings.max_contact_time);
  result.force = 0.5 * std::numbers::pi * result.impulse / result.contact_time;
  double contact_radius = hertz.contact_radius;
  if (settings.hardness_factor > 0) {
    result.limit_pressure = settings.hardness_factor * std::min(material.yield_stress, other.yield_stress);
    const ElasticPlasticImpact plastic =
        elastic_plastic_impact(result.effective_mass, result.approach_speed, curvature, e_star, result.limit_pressure);
    if (plastic.yielded) {
      result.yield_scale = plastic.peak_force / hertz.peak_force;
      result.force *= result.yield_scale;
      contact_radius = plastic.contact_radius;
    }
  }

  // Each contact's share of the load, in proportion to its impulse, spread over its patch.
  std::vector<Vec3> forces(nn, Vec3::Zero());
  std::vector<char> loaded(nn, 0);
  std::vector<double> shares;
  shares.reserve(loads.size());
  for (const LocalLoad& l : loads) shares.push_back(result.force * l.impulse / result.impulse);
  result.patch_radius =
      spread_loads(model, loads, shares, std::max(contact_radius, settings.min_patch_radius * body_radius), settings,
                   forces, loaded);
  result.loaded_nodes = static_cast<Index>(std::count(loaded.begin(), loaded.end(), 1));
  SHATTER_TRY(done, respond(model, state, loads, std::move(forces), body_radius, settings, result));
  return result;
}

Result<ImpactResult> analyze_load(const BodyModel& model, BodyState& state, std::span<const SurfaceLoad> loads,
                                  const ImpactSettings& settings) {
  SHATTER_TRY(checked, check_state(model, state, "analyze_load"));
  const std::size_t nn = model.mesh.positions.size();
  for (std::size_t k = 0; k < loads.size(); ++k)
    if (!loads[k].point.allFinite() || !loads[k].force.allFinite() || !std::isfinite(loads[k].radius) ||
        loads[k].radius < 0)
      return make_error("analyze_load: load " + std::to_string(k) + " is not finite or has a negative radius");
  ImpactResult result;
  result.plastic_strain = state.plastic_strain;
  if (result.plastic_strain.empty()) result.plastic_strain.assign(static_cast<std::size_t>(model.mesh.num_tets()), 0.0);
  const Mat3 to_body = state.rigid.orientation.toRotationMatrix().transpose();
  std::vector<LocalLoad> local;
  std::vector<double> magnitude;
  Vec3 weighted_point = Vec3::Zero();
  for (const SurfaceLoad& l : loads) {
    const double f = l.force.norm();
    if (!(f > 0)) continue;
    local.push_back({to_body * (l.point - state.rigid.position), to_body * (l.force / f), f});
    magnitude.push_back(f);
    result.force += f;
    weighted_point += f * l.point;
  }
  if (local.empty()) return result;
  result.analysed = true;
  result.load_point = weighted_point / result.force;
  const double body_radius = body_radius_of(model);
  std::vector<Vec3> forces(nn, Vec3::Zero());
  std::vector<char> loaded(nn, 0);
  // One spread per load, each with its own radius floor.
  for (std::size_t k = 0; k < local.size(); ++k) {
    const double floor = std::max(loads[k].radius, settings.min_patch_radius * body_radius);
    result.patch_radius =
        std::max(result.patch_radius, spread_loads(model, {local[k]}, {magnitude[k]}, floor, settings, forces, loaded));
  }
  result.loaded_nodes = static_cast<Index>(std::count(loaded.begin(), loaded.end(), 1));
  SHATTER_TRY(done, respond(model, state, local, std::move(forces), body_radius, settings, result));
  return result;
}

Result<ImpactResult> slice_body(const BodyModel& model, const BodyState& state, const Vec3& point, const Vec3& normal,
                                const ImpactSettings& settings) {
  if (!point.allFinite() || !normal.allFinite() || !(normal.norm() > 0))
    return make_error("slice_body: the plane needs a finite point and a non-zero normal");
  SHATTER_TRY(checked, check_state(model, state, "slice_body"));
  const Index nt = model.mesh.num_tets();
  const auto t0 = Clock::now();
  ImpactResult result;
  result.analysed = true;
  result.load_point = point;
  const Quat to_body = state.rigid.orientation.conjugate();
  const CutPlane plane{.point = to_body * (point - state.rigid.position), .normal = (to_body * normal).normalized()};
  std::vector<Index> all(static_cast<std::size_t>(nt));
  std::iota(all.begin(), all.end(), Index(0));
  // Every crossed tet is split (no minimum piece volume: with one, a single sliver would keep its
  // neighbours whole too, to stay conforming, and the cut would follow the faces); nodes within a
  // tenth of an edge of the plane count as on it, which keeps the slivers away.
  CutResult cut =
      cut_mesh(model.mesh, plane, all, {.split_tets = true, .snap_fraction = 0.1, .min_volume_fraction = 0});
  FractureResult fr;
  fr.mesh = std::move(cut.mesh);
  fr.tet_parent = std::move(cut.tet_parent);
  fr.plastic_strain.resize(fr.tet_parent.size(), 0.0);
  if (!state.plastic_strain.empty())
    for (std::size_t e = 0; e < fr.tet_parent.size(); ++e)
      fr.plastic_strain[e] = state.plastic_strain[static_cast<std::size_t>(fr.tet_parent[e])];
  fr.plastic.rest_positions = model.mesh.positions;
  fr.fragments = extract_fragments(fr.mesh, model.fem.material.density);
  if (fr.fragments.size() < 2) {  // the plane misses the body (or only grazes it)
    result.fracture_ms = ms_since(t0);
    return result;
  }
  const double body_radius = body_radius_of(model);
  CrackEvent event;
  event.plan.origin = plane.point;
  event.plan.normal = plane.normal;
  event.plan.radius = 2 * body_radius;  // through the whole body
  event.tets_marked = nt;
  event.tets_split = cut.tets_split;
  event.edge_nodes = cut.edge_nodes;
  event.nodes_duplicated = cut.nodes_duplicated;
  event.faces_cut = cut.faces_cut;
  result.cracks.push_back(event);
  make_children(model, state.rigid, fr, state.tensile_strength, body_radius, settings, result);
  result.fracture_ms = ms_since(t0);
  return result;
}

}  // namespace shatter
