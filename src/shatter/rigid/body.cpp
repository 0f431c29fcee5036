// Body model and state (see body.h).
#include "shatter/rigid/body.h"

#include <span>
#include <string>
#include <utility>

#include "shatter/core/hash.h"
#include "shatter/core/parallel.h"
#include "shatter/mesh/validate.h"

namespace shatter {

Result<BodyModel> make_body_model(const TetMesh& world_mesh, const Material& material, ModelKind model,
                                  RigidState* rigid) {
  if (world_mesh.num_tets() == 0) return make_error("the body's mesh has no tetrahedra");
  SHATTER_TRY(valid_material, validate_material(material));
  const ValidationReport report = validate_mesh(world_mesh);
  if (report.has_errors()) return make_error("the body's mesh is not valid: " + report.problems.front().message);
  for (Index e = 0; e < world_mesh.num_tets(); ++e)
    if (!(signed_volume(world_mesh, e) > 0))
      return make_error("tet " + std::to_string(e) + " of the body's mesh is not positively oriented (signed volume " +
                        std::to_string(signed_volume(world_mesh, e)) + " m^3)");
  BodyModel b;
  b.mesh = world_mesh;
  const MassProperties world_mass = mass_properties(world_mesh, material.density);
  if (!(world_mass.volume > 0)) return make_error("the body's mesh has no positive volume");
  // Body frame: origin at the centre of mass, axes as the world's.
  for (Vec3& p : b.mesh.positions) p -= world_mass.center;
  b.faces = compute_faces(b.mesh);
  b.surface = boundary_surface(b.mesh, b.faces);
  b.fem = make_fem_model(b.mesh, material, model);
  b.mass = mass_properties(b.mesh, material.density);
  b.crack_face.assign(b.surface.triangles.size(), 0);
  b.material_origin = world_mass.center;
  if (rigid) {
    *rigid = RigidState{};
    rigid->position = world_mass.center;
  }
  return b;
}

BodyState make_body_state(const BodyModel& model, const RigidState& rigid) {
  BodyState s;
  s.rigid = rigid;
  s.plastic_strain.assign(static_cast<std::size_t>(model.mesh.num_tets()), 0.0);
  s.solver = std::make_shared<StaticSolver>();
  return s;
}

std::uint64_t surface_hash(const BodyModel& model) {
  Hasher h;
  h.add(std::span<const Vec3>(model.surface.positions));
  h.add(std::span<const TriIndices>(model.surface.triangles));
  h.add(std::span<const std::uint8_t>(model.crack_face));
  h.add_bytes(model.material_origin.data(), 3 * sizeof(double));
  return h.digest();
}

std::vector<Vec3> world_positions(const BodyModel& model, const RigidState& rigid) {
  const Mat3 R = rigid.orientation.toRotationMatrix();
  std::vector<Vec3> x(model.mesh.positions.size());
  for (std::size_t i = 0; i < x.size(); ++i) x[i] = rigid.position + R * model.mesh.positions[i];
  return x;
}

Vec3 apply_plastic_update(BodyModel& model, BodyState& state, const PlasticResult& plastic) {
  SHATTER_CHECK(plastic.rest_positions.size() == model.mesh.positions.size());
  SHATTER_CHECK(plastic.plastic_strain.size() == model.mesh.tets.size());
  state.plastic_strain = plastic.plastic_strain;
  if (plastic.moved_nodes.empty()) return Vec3::Zero();
  // The new shape at the kept mass: its density follows the volume change (mass properties are
  // linear in the density).
  const double mass = model.mass.mass;
  model.mesh.positions = plastic.rest_positions;
  MassProperties m = mass_properties(model.mesh, 1.0);
  m.inertia *= mass / m.volume;
  m.mass = mass;
  // Re-centre the body frame on the new centre of mass; the world pose moves with it. Every node
  // moves, so every tet's rest data is recomputed (as make_fem_model would).
  const Vec3 dc = m.center;
  for (Vec3& p : model.mesh.positions) p -= dc;
  model.material_origin += dc;
  state.rigid.position += state.rigid.orientation * dc;
  m.center = Vec3::Zero();
  model.mass = m;
  // Each tet's on its own (about 0.5 us: two 3x3 inverses and a QR), on threads: a clay teddy's
  // 3.6k tets took 1.4-2 ms, most of a dent's cost.
  parallel_for(
      0, model.mesh.num_tets(), [&](std::int64_t e) { set_tet_rest(model.fem, e, model.mesh.corners(e)); }, 512);
  // Same faces in the same order: the crack flags stay valid.
  model.surface = boundary_surface(model.mesh, model.faces);
  return dc;
}

}  // namespace shatter
