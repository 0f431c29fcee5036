// The world's step (see world.h).
#include "shatter/world/world.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <mutex>
#include <numeric>
#include <optional>
#include <tuple>
#include <utility>

#include "shatter/core/clock.h"
#include "shatter/core/hash.h"
#include "shatter/core/log.h"
#include "shatter/core/parallel.h"
#include "shatter/fem/constitutive.h"
#include "shatter/mesh/mass_properties.h"

namespace shatter {
namespace {

// An impact event is analysed at the latest this many steps after it opened.
constexpr int kMaxImpactSteps = 3;

Transform transform_of(const RigidState& r) { return {r.orientation.toRotationMatrix(), r.position}; }

// Whether a push along `push` (on a body, from another dynamic body) presses it into its supports,
// whose contact normals into it sum to `support_normal`: against them, within 60 degrees.
bool presses_into(const Vec3& push, const Vec3& support_normal) {
  return push.dot(support_normal) < -0.5 * support_normal.norm();
}

// World box of a body-frame box under a rigid placement.
Aabb transform_box(const Aabb& local, const Transform& t) {
  if (local.empty()) return local;
  const Vec3 centre = t.apply(0.5 * (local.min + local.max));
  const Vec3 half = t.rotation.cwiseAbs() * (0.5 * (local.max - local.min));
  Aabb out;
  out.min = centre - half;
  out.max = centre + half;
  return out;
}

Aabb grow(Aabb box, double margin) {
  if (box.empty()) return box;
  box.min.array() -= margin;
  box.max.array() += margin;
  return box;
}

auto contact_key(const Contact& c) { return std::tie(c.body_a, c.body_b, c.piece_a, c.piece_b); }

// The pair's placement for a contact origin: B's centre of mass in A's frame, and B's orientation
// relative to A's.
void relative_placement(const RigidState& a, const RigidState& b, Vec3& offset, Quat& rotation) {
  const Quat a_inverse = a.orientation.conjugate();
  offset = a_inverse * (b.position - a.position);
  rotation = a_inverse * b.orientation;
}

// How far any point of one body can have moved relative to the other since `o` was recorded, m.
// In A's frame a point r of B (body frame) sits at R r + t, so it moved by at most
// |t - t0| + |R - R0| |r| <= |t - t0| + 2 sin(dθ/2) radius_B, where cos(dθ/2) = |q . q0| for the
// relative rotation dθ between R0 and R. The same in B's frame with A's radius; the smaller bound
// holds. A radius < 0 (a plane) leaves that frame out.
double relative_motion(const ContactOrigin& o, const Vec3& offset, const Quat& rotation, double radius_a,
                       double radius_b) {
  const double c = std::min(1.0, std::abs(rotation.dot(o.rotation)));
  const double chord = 2 * std::sqrt(std::max(0.0, 1 - c * c));  // 2 sin(dθ/2)
  double moved = std::numeric_limits<double>::infinity();
  if (radius_b >= 0) moved = (offset - o.offset).norm() + chord * radius_b;
  if (radius_a >= 0) {
    // A's centre of mass in B's frame: -R^T t.
    const Vec3 a_in_b = rotation.conjugate() * offset;
    const Vec3 a_in_b0 = o.rotation.conjugate() * o.offset;
    moved = std::min(moved, (a_in_b - a_in_b0).norm() + chord * radius_a);
  }
  return moved;
}

bool key_less(const Contact& x, const Contact& y) { return contact_key(x) < contact_key(y); }

// A pair's coefficients from its two surfaces: friction their geometric mean, restitution the
// larger (Box2D's mixing).
double mixed_friction(const SurfaceMaterial& a, const SurfaceMaterial& b) { return std::sqrt(a.friction * b.friction); }
double mixed_restitution(const SurfaceMaterial& a, const SurfaceMaterial& b) {
  return std::max(a.restitution, b.restitution);
}

// The point of c with the feature pair `feature` (its index), or -1.
int point_with(const ContactConstraint& c, std::uint32_t feature) {
  for (int k = 0; k < c.count; ++k)
    if (c.points[k].feature == feature) return k;
  return -1;
}

// `cc` aimed along `normal` with `points` (at least one), its rows prepared at the bodies' poses
// now. A point cc held (by feature) keeps its impulses, totals and approach speed; what a point it
// no longer has carried joins the totals of the new point nearest it (never its approach speed:
// restitution acts on a point's own). The friction and twist impulses stay.
ContactConstraint aimed(const ContactConstraint& cc, const Vec3& normal, std::span<const ManifoldPoint> points,
                        std::span<const SolverBody> bodies, double speculative_distance) {
  ContactConstraint now = cc;
  now.normal = normal;
  now.count = 0;
  for (const ManifoldPoint& q : points)
    now.points[now.count++] = {.position = q.point, .separation = q.separation, .feature = q.feature};
  prepare_contact(now, bodies, speculative_distance);
  for (int k = 0; k < now.count; ++k) {
    const int j = point_with(cc, now.points[k].feature);
    if (j < 0) continue;
    ContactPoint& p = now.points[k];
    const ContactPoint& was = cc.points[j];
    p.normal_impulse = was.normal_impulse;
    p.total_normal_impulse = was.total_normal_impulse;
    p.max_normal_impulse = was.max_normal_impulse;
    p.approach_speed = std::max(p.approach_speed, was.approach_speed);
  }
  for (int j = 0; j < cc.count; ++j) {
    const ContactPoint& was = cc.points[j];
    if (point_with(now, was.feature) >= 0) continue;
    int near = 0;
    for (int k = 1; k < now.count; ++k)
      if ((now.points[k].position - was.position).squaredNorm() <
          (now.points[near].position - was.position).squaredNorm())
        near = k;
    now.points[near].total_normal_impulse += was.total_normal_impulse;
    now.points[near].max_normal_impulse = std::max(now.points[near].max_normal_impulse, was.max_normal_impulse);
  }
  now.friction_impulse = cc.friction_impulse;
  now.twist_impulse = cc.twist_impulse;
  now.total_friction_impulse = cc.total_friction_impulse;
  now.total_twist_impulse = cc.total_twist_impulse;
  return now;
}

// Warm start of a manifold's friction and twist from the same manifold's last step `old`: its
// impulses re-expressed in cc's tangents (set before) and about cc's normal.
struct CarriedFriction {
  Vec2 impulse;  ///< along the new tangents, N s
  double twist;  ///< about the new normal, N m s
};
CarriedFriction carried_friction(const ContactConstraint& old, const Vec3& normal,
                                 const std::array<Vec3, 2>& tangents) {
  const Vec3 f = old.friction_impulse.x() * old.tangents[0] + old.friction_impulse.y() * old.tangents[1];
  return {{f.dot(tangents[0]), f.dot(tangents[1])}, old.twist_impulse * old.normal.dot(normal)};
}
void carry_friction(ContactConstraint& cc, const ContactConstraint& old) {
  const CarriedFriction carried = carried_friction(old, cc.normal, cc.tangents);
  cc.friction_impulse = carried.impulse;
  cc.twist_impulse = carried.twist;
}

// Union-find root with path halving.
Index find_root(std::vector<Index>& parent, Index i) {
  while (parent[i] != i) {
    parent[i] = parent[parent[i]];
    i = parent[i];
  }
  return i;
}

void unite(std::vector<Index>& parent, Index a, Index b) {
  a = find_root(parent, a);
  b = find_root(parent, b);
  if (a == b) return;
  if (a < b) std::swap(a, b);  // the lower index is the root: independent of the contact order
  parent[a] = b;
}

bool contains_pair(const std::vector<std::array<Index, 2>>& sorted, Index a, Index b) {
  return std::binary_search(sorted.begin(), sorted.end(), std::array<Index, 2>{a, b});
}

void insert_pair(std::vector<std::array<Index, 2>>& sorted, Index a, Index b) {
  const std::array<Index, 2> key{std::min(a, b), std::max(a, b)};
  const auto it = std::lower_bound(sorted.begin(), sorted.end(), key);
  if (it == sorted.end() || *it != key) sorted.insert(it, key);
}

}  // namespace

/// Everything a snapshot holds.
struct World::State {
  std::uint64_t world_id = 0;
  std::vector<Body> bodies;
  std::vector<Contact> contacts;
  std::vector<std::array<Index, 2>> excluded;
  std::vector<std::array<Index, 2>> until_apart;
  std::vector<World::OpenImpact> open_impacts;
  std::vector<World::Tool> tools;
  std::int64_t step_count = 0;
};

World::World(const WorldSettings& settings) : settings_(settings) {
  // A negative limit would turn bodies around, NaN would not limit at all.
  SHATTER_CHECK(settings.max_linear_speed > 0 && settings.max_rotation > 0);
  static std::atomic<std::uint64_t> next_id{1};
  world_id_ = next_id.fetch_add(1);
}

void World::set_shape(Body& b, std::shared_ptr<const Shape> shape) {
  SHATTER_CHECK(shape != nullptr);
  b.local_bounds = shape->local_bounds;
  b.radius = shape->radius;
  b.is_plane = shape->is_plane;
  b.shape = std::move(shape);
}

Index World::add(const BodyDef& def, std::shared_ptr<const Shape> shape, std::shared_ptr<const BodyModel> model) {
  Body body;
  body.type = def.type;
  body.model = std::move(model);
  set_shape(body, std::move(shape));
  if (def.type == BodyType::dynamic) body.inertia = rigid_inertia(body.model->mass);
  body.rigid = def.rigid;
  body.rigid.orientation.normalize();
  body.surface = def.surface;
  body.filter = def.filter;
  body.can_sleep = def.can_sleep;
  body.awake = def.awake;
  body.breakable = def.breakable;
  body.impact = def.impact;
  if (body.model) {
    body.root_mass = body.model->mass.mass;
    body.plastic_strain.assign(body.model->mesh.tets.size(), 0.0);
    body.solver = std::make_shared<StaticSolver>();
  }
  if (body.type == BodyType::static_body) {
    body.rigid.linear_velocity.setZero();
    body.rigid.angular_velocity.setZero();
    body.awake = false;
  }
  if (def.deformable && body.model && body.type == BodyType::dynamic) {
    const DeformableSettings& ds = *def.deformable;
    Body::Deformation d;
    d.substeps = ds.substeps;
    d.model = std::make_shared<BodyModel>(*body.model);
    d.rest = std::make_shared<const std::vector<Vec3>>(body.model->mesh.positions);
    d.solver = std::make_shared<DynamicSolver>(DynamicSolverOptions{.time_step = settings_.time_step / ds.substeps,
                                                                    .gravity = settings_.gravity,
                                                                    .mass_damping = ds.mass_damping,
                                                                    .stiffness_damping = ds.stiffness_damping,
                                                                    .contact_stiffness = ds.contact_stiffness,
                                                                    .max_newton_iterations = ds.max_newton_iterations});
    const Mat3 R = body.rigid.orientation.toRotationMatrix();
    for (const Vec3& r : *d.rest) {
      d.nodes.x.emplace_back(body.rigid.position + R * r);
      d.nodes.v.emplace_back(body.rigid.linear_velocity + body.rigid.angular_velocity.cross(R * r));
    }
    // Contact impulses are spread over about two surface edges around their point.
    const TriSurface& surf = body.model->surface;
    double edges = 0;
    for (const TriIndices& t : surf.triangles)
      for (int k = 0; k < 3; ++k) edges += (surf.positions[t[k]] - surf.positions[t[(k + 1) % 3]]).norm();
    d.patch_radius = surf.triangles.empty() ? 0 : 2 * edges / (3 * static_cast<double>(surf.triangles.size()));
    // The contact solver sees it as a rigid body with the nodes' mass distribution.
    const Mat3 inertia = point_mass_properties(body.model->fem.node_mass, *d.rest).inertia;
    body.inertia.inertia_body = inertia;
    body.inertia.inverse_inertia_body = inertia.inverse();
    body.model = d.model;
    body.breakable = false;
    body.solver.reset();
    body.deform = std::move(d);
  }
  // A slot that restore() freed gets a new generation, so ids of the body it held are stale.
  const auto slot = static_cast<Index>(bodies_.size());
  if (slot < static_cast<Index>(generations_.size()))
    body.generation = ++generations_[slot];
  else
    generations_.push_back(0);
  bodies_.push_back(std::move(body));
  return slot;
}

BodyId World::body_id(Index slot) const {
  SHATTER_CHECK(slot >= 0 && slot < body_count());
  return {slot, bodies_[slot].generation};
}

const World::Body& World::body(BodyId id) const {
  SHATTER_CHECK(valid(id));
  return bodies_[id.index];
}

Result<Index> World::live_slot(BodyId id, const char* what) const {
  if (!valid(id))
    return make_error(std::string(what) + ": body id (" + std::to_string(id.index) + ", generation " +
                      std::to_string(id.generation) + ") is not a body of this world (stale or never made)");
  if (bodies_[id.index].removed)
    return make_error(std::string(what) + ": body " + std::to_string(id.index) + " was removed (it broke)");
  return id.index;
}

BodyId World::parent(BodyId id) const {
  const Index p = body(id).parent;
  return p < 0 ? BodyId{} : body_id(p);
}

BodySurface World::surface(BodyId id) const {
  const Body& b = body(id);
  BodySurface out;
  if (!b.model) return out;
  const TriSurface& s = b.model->surface;
  const Mat3 R = b.rigid.orientation.toRotationMatrix();
  out.positions.reserve(s.positions.size());
  out.rest.reserve(s.positions.size());
  for (const Vec3& p : s.positions) {
    out.positions.emplace_back(b.rigid.position + R * p);
    out.rest.emplace_back(b.model->material_origin + p);
  }
  out.triangles = s.triangles;
  out.crack_face = b.model->crack_face;
  out.crack_face.resize(s.triangles.size(), 0);
  return out;
}

Result<BodyId> World::add_body(std::shared_ptr<const BodyModel> model, const BodyDef& def) {
  if (!model) return make_error("add_body: no body model given");
  if (model->mesh.tets.empty()) return make_error("add_body: the body model has no tets");
  if (def.type == BodyType::dynamic && !(model->mass.mass > 0))
    return make_error("add_body: a dynamic body needs a positive mass (check the material density)");
  if (def.deformable) {
    const DeformableSettings& d = *def.deformable;
    if (def.type != BodyType::dynamic)
      return make_error("add_body: only a dynamic body can be deformable (static and kinematic bodies do not deform)");
    if (!std::isfinite(d.mass_damping) || d.mass_damping < 0 || !std::isfinite(d.stiffness_damping) ||
        d.stiffness_damping < 0 || !std::isfinite(d.contact_stiffness) || !(d.contact_stiffness > 0) ||
        d.max_newton_iterations < 1 || d.substeps < 1 || d.substeps > 1000)
      return make_error(
          "add_body: deformable settings: the dampings must be finite and >= 0, the contact stiffness finite and > 0, "
          "max_newton_iterations >= 1 and substeps in [1, 1000]");
  }
  auto shape = shared_tet_shape(model);
  if (!shape) return make_error("add_body: " + shape.error().message);
  const Index slot = add(def, std::move(*shape), std::move(model));
  // The body's flaws: its own stream, started at the hash of (world seed, slot). (Starts a fixed
  // step apart would give shifted copies of one SplitMix64 sequence: body n + 1 would draw body n's
  // strengths one tet later.)
  Body& b = bodies_[slot];
  const std::array<std::uint64_t, 2> key{settings_.seed, static_cast<std::uint64_t>(slot)};
  b.tensile_strength =
      sample_tensile_strengths(b.model->mesh, b.model->fem.material, hash_bytes(key.data(), sizeof(key)));
  return body_id(slot);
}

void World::finish_tet_shape(Shape& shape, const BodyModel& model) const {
  if (settings_.contact_mode == ContactMode::tet_vertices)
    shape.tet.push_back(make_tet_contact_shape(model.mesh, model.faces));
  for (const Vec3& x : model.mesh.positions) {
    shape.local_bounds.extend(x);
    shape.radius = std::max(shape.radius, x.norm());
  }
}

Result<std::shared_ptr<const World::Shape>> World::make_tet_shape(const BodyModel& model) const {
  auto shape = std::make_shared<Shape>();
  auto pieces = decompose_convex(model.mesh, model.faces, settings_.decomposition);
  if (!pieces) return make_error("the convex pieces could not be built: " + pieces.error().message);
  for (ConvexPiece& p : *pieces) {
    shape->pieces.push_back(std::move(p.hull));
    shape->piece_tets.push_back(std::move(p.tets));
  }
  finish_tet_shape(*shape, model);
  return std::shared_ptr<const Shape>(std::move(shape));
}

Result<std::shared_ptr<const World::Shape>> World::shared_tet_shape(
    const std::shared_ptr<const BodyModel>& model) const {
  // Keyed by the model's address, checked against a weak reference so that a new model at a
  // reused address is not mistaken for the old one.
  struct Entry {
    std::weak_ptr<const BodyModel> model;
    DecompositionOptions options;
    ContactMode mode;
    std::shared_ptr<const Shape> shape;
  };
  static std::mutex mutex;
  static std::vector<Entry> cache;
  {
    const std::lock_guard<std::mutex> lock(mutex);
    std::erase_if(cache, [](const Entry& e) { return e.model.expired(); });
    for (const Entry& e : cache)
      if (e.model.lock() == model && e.mode == settings_.contact_mode &&
          e.options.max_overfill == settings_.decomposition.max_overfill &&
          e.options.max_pieces == settings_.decomposition.max_pieces &&
          e.options.group_above == settings_.decomposition.group_above &&
          e.options.groups == settings_.decomposition.groups)
        return e.shape;
  }
  auto shape = make_tet_shape(*model);
  if (!shape) return shape.error();
  const std::lock_guard<std::mutex> lock(mutex);
  cache.push_back({model, settings_.decomposition, settings_.contact_mode, *shape});
  return *shape;
}

Result<std::shared_ptr<const World::Shape>> World::shape_from_clusters(std::vector<std::vector<Index>> clusters,
                                                                       const BodyModel& model,
                                                                       const std::vector<const ConvexHull*>& moved,
                                                                       const Vec3& shift) const {
  SHATTER_CHECK(moved.empty() || moved.size() == clusters.size());
  auto shape = std::make_shared<Shape>();
  std::vector<Vec3> points;
  std::vector<char> seen(model.mesh.positions.size(), 0);
  for (std::size_t c = 0; c < clusters.size(); ++c) {
    if (!moved.empty() && moved[c]) {
      shape->pieces.push_back(translated_hull(*moved[c], shift));
      continue;
    }
    const std::vector<Index>& tets = clusters[c];
    points.clear();
    for (const Index e : tets)
      for (const Index v : model.mesh.tets[e])
        if (!seen[v]) {
          seen[v] = 1;
          points.push_back(model.mesh.positions[v]);
        }
    for (const Index e : tets)
      for (const Index v : model.mesh.tets[e]) seen[v] = 0;
    auto hull = build_convex_hull(points);
    if (!hull) return make_error("a convex piece could not be built: " + hull.error().message);
    shape->pieces.push_back(std::move(*hull));
  }
  shape->piece_tets = std::move(clusters);
  finish_tet_shape(*shape, model);
  return std::shared_ptr<const Shape>(std::move(shape));
}

Result<std::shared_ptr<const World::Shape>> World::inherit_shape(const Shape& parent, const ImpactChild& child) const {
  const std::vector<Index>& parent_tet = child.parent_tet;
  const BodyModel& model = *child.model;
  Index parent_tets = 0;
  for (const auto& tets : parent.piece_tets)
    for (const Index e : tets) parent_tets = std::max(parent_tets, e + 1);
  std::vector<Index> piece_of(static_cast<std::size_t>(parent_tets), -1);
  for (std::size_t p = 0; p < parent.piece_tets.size(); ++p)
    for (const Index e : parent.piece_tets[p]) piece_of[e] = static_cast<Index>(p);
  std::vector<Index> slot(parent.piece_tets.size(), -1);
  std::vector<Index> slot_piece;
  std::vector<std::vector<Index>> clusters;
  for (std::size_t e = 0; e < parent_tet.size(); ++e) {
    const Index pt = parent_tet[e];
    const Index p = pt >= 0 && pt < parent_tets ? piece_of[pt] : -1;
    if (p < 0) return make_error("a fragment tet has no parent piece");
    if (slot[p] < 0) {
      slot[p] = static_cast<Index>(clusters.size());
      clusters.emplace_back();
      slot_piece.push_back(p);
    }
    clusters[slot[p]].push_back(static_cast<Index>(e));
  }
  // A cluster is its parent piece moved when it has each of the piece's tets once, each left
  // unchanged by the cut and plasticity (ImpactChild::unchanged_parent_tet: its corners are the
  // parent's, bitwise, so in the child's frame the parent's less the origin): then its nodes are
  // the piece's nodes moved, and so is their hull. A child without that list rebuilds every hull.
  std::vector<const ConvexHull*> moved(clusters.size(), nullptr);
  const std::vector<Index>& unchanged = child.unchanged_parent_tet;
  std::vector<char> taken(static_cast<std::size_t>(parent_tets), 0);
  const std::size_t kept_candidates = unchanged.size() == parent_tet.size() ? clusters.size() : 0;
  for (std::size_t c = 0; c < kept_candidates; ++c) {
    const Index p = slot_piece[c];
    if (clusters[c].size() != parent.piece_tets[p].size()) continue;
    bool same = true;
    for (const Index e : clusters[c]) {
      const Index pt = parent_tet[e];
      same = same && !taken[pt] && unchanged[e] == pt;
      taken[pt] = 1;
      if (!same) break;
    }
    for (const Index e : clusters[c]) taken[parent_tet[e]] = 0;
    if (same) moved[c] = &parent.pieces[p];
  }
  return shape_from_clusters(std::move(clusters), model, moved, -child.origin);
}

Result<BodyId> World::add_hull(ConvexHull hull, const BodyDef& def) {
  if (def.type == BodyType::dynamic)
    return make_error(
        "add_hull: a hull body must be static or kinematic (a dynamic body needs a tet mesh and a material)");
  if (hull.vertices.empty()) return make_error("add_hull: the hull is empty");
  if (def.deformable) return make_error("add_hull: a hull cannot be deformable (give a tet body instead)");
  auto shape = std::make_shared<Shape>();
  shape->local_bounds = hull.bounds;
  for (const Vec3& v : hull.vertices) shape->radius = std::max(shape->radius, v.norm());
  shape->pieces.push_back(std::move(hull));
  return body_id(add(def, std::move(shape)));
}

Result<BodyId> World::add_box(const Vec3& half_extents, const BodyDef& def) {
  if (!(half_extents.array() > 0).all() || !half_extents.allFinite())
    return make_error("add_box: half extents must be positive and finite");
  std::array<Vec3, 8> corners;
  for (int i = 0; i < 8; ++i)
    corners[i] = Vec3((i & 1) ? half_extents.x() : -half_extents.x(), (i & 2) ? half_extents.y() : -half_extents.y(),
                      (i & 4) ? half_extents.z() : -half_extents.z());
  auto hull = build_convex_hull(corners);
  if (!hull) return hull.error();
  return add_hull(std::move(*hull), def);
}

BodyId World::add_plane(const Plane& plane, const SurfaceMaterial& surface, const CollisionFilter& filter) {
  auto shape = std::make_shared<Shape>();
  shape->is_plane = true;
  shape->plane = plane;
  shape->plane.normal.normalize();
  return body_id(add({.type = BodyType::static_body, .surface = surface, .filter = filter}, std::move(shape)));
}

std::span<const ConvexHull> World::pieces(BodyId id) const { return body(id).shape->pieces; }

Result<void> World::set_rigid_state(BodyId id, const RigidState& rigid) {
  SHATTER_TRY(slot, live_slot(id, "set_rigid_state"));
  if (!rigid.position.allFinite() || !rigid.orientation.coeffs().allFinite() || !rigid.linear_velocity.allFinite() ||
      !rigid.angular_velocity.allFinite() || !(rigid.orientation.norm() > 0))
    return make_error("set_rigid_state: the state is not finite, or the orientation is zero");
  Body& b = bodies_[*slot];
  const RigidState old = b.rigid;
  b.rigid = rigid;
  b.rigid.orientation.normalize();
  if (b.type == BodyType::static_body) {
    b.rigid.linear_velocity.setZero();
    b.rigid.angular_velocity.setZero();
    return {};
  }
  if (b.deform) {  // the nodes follow rigidly, keeping their deformation
    const Mat3 turn = (b.rigid.orientation * old.orientation.conjugate()).toRotationMatrix();
    DynamicState& nodes = b.deform->nodes;
    for (std::size_t i = 0; i < nodes.x.size(); ++i) {
      const Vec3 r = turn * (nodes.x[i] - old.position);
      nodes.x[i] = b.rigid.position + r;
      nodes.v[i] = b.rigid.linear_velocity + b.rigid.angular_velocity.cross(r);
    }
    fit_deformable(*slot);
  }
  wake_slot(*slot);
  return {};
}

Result<void> World::apply_impulse(BodyId id, const Vec3& impulse, const Vec3& point) {
  SHATTER_TRY(slot, live_slot(id, "apply_impulse"));
  if (!impulse.allFinite() || !point.allFinite())
    return make_error("apply_impulse: the impulse or point is not finite");
  Body& b = bodies_[*slot];
  if (b.type != BodyType::dynamic) return {};
  if (b.deform) {
    turn_nodes(*slot, spread_impulse(*slot, impulse, point));
    fit_deformable(*slot);
    wake_slot(*slot);
    return {};
  }
  b.rigid.linear_velocity += b.inertia.inverse_mass * impulse;
  b.rigid.angular_velocity +=
      world_inverse_inertia(b.inertia, b.rigid.orientation) * (point - b.rigid.position).cross(impulse);
  wake_slot(*slot);
  return {};
}

Result<void> World::wake(BodyId id) {
  SHATTER_TRY(slot, live_slot(id, "wake"));
  wake_slot(*slot);
  return {};
}

void World::wake_slot(Index slot) {
  Body& b = bodies_[slot];
  if (b.type == BodyType::static_body || b.removed) return;
  b.awake = true;
  b.sleep_time = 0;
}

Aabb World::bounds(BodyId id) const {
  SHATTER_CHECK(valid(id));
  return slot_bounds(id.index);
}

Aabb World::slot_bounds(Index slot) const {
  const Body& b = bodies_[slot];
  if (b.is_plane) {
    Aabb all;
    all.min.setConstant(-std::numeric_limits<double>::infinity());
    all.max.setConstant(std::numeric_limits<double>::infinity());
    return all;
  }
  Aabb box = transform_box(b.local_bounds, transform_of(b.rigid));
  if (b.deform) {  // the nodes, and the rest pieces at the best-fit pose the contact solver sees
    box.min = box.min.cwiseMin(b.deform->box.min);
    box.max = box.max.cwiseMax(b.deform->box.max);
  }
  return box;
}

Result<void> World::exclude_pair(BodyId a, BodyId b) {
  if (!valid(a) || !valid(b) || a == b) return make_error("exclude_pair: needs two different valid body ids");
  insert_pair(excluded_, a.index, b.index);
  return {};
}

Result<void> World::exclude_until_apart(BodyId a, BodyId b) {
  if (!valid(a) || !valid(b) || a == b) return make_error("exclude_until_apart: needs two different valid body ids");
  insert_pair(until_apart_, a.index, b.index);
  return {};
}

bool World::pair_excluded(Index a, Index b) const { return contains_pair(excluded_, a, b); }

double World::motion_bound(const Body& b) const {
  if (b.type == BodyType::static_body || !b.awake) return 0;
  if (b.deform) return settings_.time_step * b.deform->max_speed;
  const double dt = settings_.time_step;
  if (b.pressed) {  // what the press adds within the step, within the speed limits
    const double v = b.rigid.linear_velocity.norm() + dt * b.inertia.inverse_mass * b.press_force.norm();
    const double w = b.rigid.angular_velocity.norm() +
                     dt * (world_inverse_inertia(b.inertia, b.rigid.orientation) * b.press_torque).norm();
    return dt * (std::min(v, settings_.max_linear_speed) + std::min(w, settings_.max_rotation / dt) * b.radius);
  }
  return dt * (b.rigid.linear_velocity.norm() + b.rigid.angular_velocity.norm() * b.radius);
}

void World::find_pairs(std::vector<PairRef>& pairs) {
  const Index n = body_count();
  const double half_margin = 0.5 * settings_.speculative_distance;
  boxes_.resize(n);
  bounds_.resize(static_cast<std::size_t>(n));
  double fastest = 0;
  for (Index i = 0; i < n; ++i) {
    const Body& b = bodies_[i];
    bounds_[i] = motion_bound(b);
    fastest = std::max(fastest, bounds_[i]);
    boxes_[i] = b.is_plane || b.removed ? Aabb{} : grow(slot_bounds(i), half_margin + bounds_[i]);
  }
  // The grid runs on the boxes grown by a margin, and its pairs are kept while every box stays
  // inside its grown box: two boxes that overlap then have grown boxes that overlap, so the kept
  // pairs whose boxes overlap now are exactly the pairs the grid would find on the boxes (the
  // same pairs, in the same order). Bodies at rest keep their grown boxes step after step.
  bool keep = grown_boxes_.size() == boxes_.size();
  for (Index i = 0; i < n && keep; ++i) {
    const Aabb& b = boxes_[i];
    const Aabb& g = grown_boxes_[i];
    keep = valid_box(b) ? (g.min.array() <= b.min.array()).all() && (b.max.array() <= g.max.array()).all()
                        : b.empty() && g.empty();
  }
  if (!keep) {
    // Never shrunk (a box must lie inside its grown box), never infinite (the grid skips those).
    const double growth = std::isfinite(settings_.broad_phase_growth) && settings_.broad_phase_growth > 0
                              ? settings_.broad_phase_growth
                              : 0.0;
    grown_boxes_.resize(n);
    for (Index i = 0; i < n; ++i) {
      grown_boxes_[i] = Aabb{};
      if (!valid_box(boxes_[i])) continue;
      grown_boxes_[i] = grow(boxes_[i], growth * boxes_[i].extent().maxCoeff());
      if (!valid_box(grown_boxes_[i])) grown_boxes_[i] = boxes_[i];
    }
    grown_pairs_.clear();
    for (const BodyPair& p : broad_phase_.find_pairs(grown_boxes_)) grown_pairs_.push_back({p.first, p.second});
  }
  stats_.grid_kept = keep;
  pairs.clear();
  for (const PairRef& p : grown_pairs_)
    if (boxes_overlap(boxes_[p.a], boxes_[p.b])) pairs.push_back(p);
  // A body struck by a faster one within the step moves about as fast: a slow piece that a blow
  // drives down reaches the ground in this step although its own motion does not (a 26 g piece
  // 9 cm up, hit at 16 m/s, went 4.5 cm through the ground). Each body reaches toward the planes
  // as far as the fastest body its box overlaps, through chains of such bodies.
  // A reach within the speculative distance pushes nothing: a resting stack needs no passes.
  pushed_.assign(static_cast<std::size_t>(n), 0.0);
  if (const double slow = settings_.speculative_distance; fastest > slow) {
    // Each body's reach starts at its own bound and takes that of a faster body it overlaps
    // (copied, so that equal reaches end the passes exactly); pushed_ is what it gained.
    std::vector<double>& reach = pushed_;
    reach = bounds_;
    const auto pushable = [&](Index i) { return bodies_[i].type == BodyType::dynamic && bodies_[i].awake; };
    for (bool changed = true; changed;) {
      changed = false;
      for (const PairRef& p : pairs) {
        if (pushable(p.a) && reach[p.b] > reach[p.a] && reach[p.b] > slow) {
          reach[p.a] = reach[p.b];
          changed = true;
        } else if (pushable(p.b) && reach[p.a] > reach[p.b] && reach[p.a] > slow) {
          reach[p.b] = reach[p.a];
          changed = true;
        }
      }
    }
    for (Index i = 0; i < n; ++i) reach[i] -= bounds_[i];
  }
  for (Index p = 0; p < n; ++p) {
    if (!bodies_[p].is_plane) continue;
    const Plane& plane = bodies_[p].shape->plane;
    for (Index i = 0; i < n; ++i) {
      if (bodies_[i].is_plane || boxes_[i].empty() || bodies_[i].type == BodyType::static_body) continue;
      const Vec3 centre = 0.5 * (boxes_[i].min + boxes_[i].max);
      const Vec3 half = 0.5 * (boxes_[i].max - boxes_[i].min);
      const double lowest = plane.normal.dot(centre) - plane.normal.cwiseAbs().dot(half) - plane.offset;
      if (lowest <= half_margin + pushed_[i]) pairs.push_back({std::min(p, i), std::max(p, i)});
    }
  }
  // Keep pairs with at least one dynamic body and one awake, that the filters allow.
  std::erase_if(pairs, [&](const PairRef& pr) {
    const Body& a = bodies_[pr.a];
    const Body& b = bodies_[pr.b];
    if (a.type != BodyType::dynamic && b.type != BodyType::dynamic) return true;
    if (!(a.filter.group & b.filter.mask) || !(b.filter.group & a.filter.mask)) return true;
    return pair_excluded(pr.a, pr.b);
  });
  std::sort(pairs.begin(), pairs.end(),
            [](const PairRef& x, const PairRef& y) { return std::tie(x.a, x.b) < std::tie(y.a, y.b); });
}

void World::narrow_phase(const std::vector<PairRef>& pairs) {
  const std::vector<Contact>& old = contacts_;
  pair_contacts_.resize(pairs.size());
  pair_reused_.resize(pairs.size());
  // Each pair's contacts of the last step, by one merge of the two sorted lists (a binary search
  // per pair strode through kilobyte-sized contacts, a cache miss per probe).
  old_ranges_.resize(pairs.size());
  for (std::size_t k = 0, o = 0; k < pairs.size(); ++k) {
    const std::array<Index, 2> key{pairs[k].a, pairs[k].b};
    while (o < old.size() && std::array<Index, 2>{old[o].body_a, old[o].body_b} < key) ++o;
    const std::size_t first = o;
    while (o < old.size() && old[o].body_a == key[0] && old[o].body_b == key[1]) ++o;
    old_ranges_[k] = {first, o};
  }
  const bool tet_mode = settings_.contact_mode == ContactMode::tet_vertices;
  parallel_for(
      0, static_cast<std::int64_t>(pairs.size()),
      [&](std::int64_t k) {
        std::vector<Contact>& out = pair_contacts_[k];
        out.clear();
        pair_reused_[k] = 0;
        const Index ia = pairs[k].a;
        const Index ib = pairs[k].b;
        const Body& a = bodies_[ia];
        const Body& b = bodies_[ib];
        const auto first_old = old.begin() + static_cast<std::ptrdiff_t>(old_ranges_[k][0]);
        const auto old_end = old.begin() + static_cast<std::ptrdiff_t>(old_ranges_[k][1]);
        if (!a.awake && !b.awake) {  // both asleep or static: nothing moved, keep what was found
          out.assign(first_old, old_end);
          return;
        }
        // Toward a plane, a body reaches as far as a body pushing it can take it (find_pairs).
        const double pushed = (a.is_plane ? pushed_[ib] : 0.0) + (b.is_plane ? pushed_[ia] : 0.0);
        const double spec = settings_.speculative_distance + bounds_[ia] + bounds_[ib] + pushed;
        const Transform ta = transform_of(a.rigid);
        const Transform tb = transform_of(b.rigid);
        Vec3 offset;
        Quat rotation;
        relative_placement(a.rigid, b.rigid, offset, rotation);
        auto push_manifold = [&](const ContactManifold& m, Index pa, Index pb, const SatCache& sat,
                                 const ContactOrigin& origin) -> Contact& {
          Contact& c = out.emplace_back();
          c.body_a = ia;
          c.body_b = ib;
          c.piece_a = pa;
          c.piece_b = pb;
          c.sat = sat;
          c.origin = origin;
          c.constraint.normal = m.normal;
          c.constraint.count = m.count;
          for (int i = 0; i < m.count; ++i) {
            c.constraint.points[i].position = m.points[i].point;
            c.constraint.points[i].separation = m.points[i].separation;
            c.constraint.points[i].feature = m.points[i].feature;
          }
          return c;
        };
        // The pair barely moved relative to each other since its contacts were found: move them
        // with the bodies. Sound while every gap within this step's speculative distance was within
        // the margin they were found with (a point moved at most `moved` closer since).
        const double reuse = std::isfinite(settings_.contact_reuse_distance) ? settings_.contact_reuse_distance : 0.0;
        if (reuse > 0 && first_old != old_end && !a.deform && !b.deform && first_old->origin.margin >= 0) {
          const double moved = relative_motion(first_old->origin, offset, rotation, a.is_plane ? -1 : a.radius,
                                               b.is_plane ? -1 : b.radius);
          if (moved <= reuse && spec + moved <= first_old->origin.margin) {
            pair_reused_[k] = 1;  // moved into place by the gather (move_kept_contacts)
            return;
          }
        }
        // Found afresh, their origin recorded. A pair slow enough that its contacts may be reused
        // next step gets them for gaps `reuse` wider (a pair that moves more cannot reuse them, and
        // would pay for the wider margin in vain).
        const double margin = reuse > 0 && bounds_[ia] + bounds_[ib] <= reuse ? spec + reuse : spec;
        auto add_manifold = [&](const ContactManifold& m, Index pa, Index pb, const SatCache& sat) {
          if (m.count == 0) return;
          ContactOrigin origin;
          if (reuse > 0 && !a.deform && !b.deform) {
            origin.offset = offset;
            origin.rotation = rotation;
            // Reused while the pair's own motion stays within it: what a push added is for this
            // step only.
            origin.margin = margin - pushed;
            origin.normal_a = ta.rotation.transpose() * m.normal;
            for (int i = 0; i < m.count; ++i) {
              const Vec3 half_gap = 0.5 * m.points[i].separation * m.normal;
              origin.point_a[i] = ta.apply_inverse(m.points[i].point - half_gap);
              origin.point_b[i] = tb.apply_inverse(m.points[i].point + half_gap);
            }
          }
          push_manifold(m, pa, pb, sat, origin);
        };
        auto add_points = [&](const std::vector<PointContact>& points) {
          for (const PointContact& p : points) {
            ContactManifold m;
            m.normal = p.normal;
            m.count = 1;
            m.points[0] = {p.point, p.separation, p.feature};
            add_manifold(m, -1, -1, {});
          }
        };
        if (a.shape->is_plane || b.shape->is_plane) {
          const bool plane_first = a.shape->is_plane;
          const Body& body = plane_first ? b : a;
          const Transform& tbody = plane_first ? tb : ta;
          const Plane& plane = (plane_first ? a : b).shape->plane;
          if (tet_mode && !body.shape->tet.empty()) {
            thread_local std::vector<PointContact> points;  // scratch per worker thread
            points.clear();
            collide_tet_shape_plane(body.shape->tet[0], tbody, plane, margin, points);
            if (plane_first)
              for (PointContact& p : points) p.normal = -p.normal;
            add_points(points);
            return;
          }
          const auto& pieces = body.shape->pieces;
          const HullMotion motion{
              .linear_velocity = body.rigid.linear_velocity,
              .angular_velocity = body.rigid.angular_velocity,
              .dt = settings_.time_step,
              .depth = 0.25 * settings_.speculative_distance,
              .inverse_mass = body.type == BodyType::dynamic ? body.inertia.inverse_mass : 0.0,
              .inverse_inertia = body.type == BodyType::dynamic ? body.inertia.inverse_inertia_body : Mat3::Zero()};
          const bool moving = body.awake && body.type != BodyType::static_body;
          for (Index i = 0; i < static_cast<Index>(pieces.size()); ++i) {
            ContactManifold m = collide_hull_plane(pieces[i], tbody, plane, margin, moving ? &motion : nullptr);
            if (plane_first) m.normal = -m.normal;  // from the plane (A) to the hull (B)
            add_manifold(m, plane_first ? -1 : i, plane_first ? i : -1, {});
          }
          return;
        }
        if (tet_mode && !a.shape->tet.empty() && !b.shape->tet.empty()) {
          thread_local std::vector<PointContact> points;  // scratch per worker thread
          points.clear();
          collide_tet_shapes(a.shape->tet[0], ta, b.shape->tet[0], tb, margin, points);
          add_points(points);
          return;
        }
        const auto& pa = a.shape->pieces;
        const auto& pb = b.shape->pieces;
        // B's pieces' boxes (grown by the margin) once per pair, and around them all: a piece of A
        // away from all of B is passed over.
        thread_local std::vector<Aabb> boxes_b;  // scratch per worker thread
        boxes_b.clear();
        Aabb all_b;
        for (const ConvexHull& piece : pb) {
          boxes_b.push_back(grow(transform_box(piece.bounds, tb), margin));
          if (!boxes_b.back().empty()) {
            all_b.extend(boxes_b.back().min);
            all_b.extend(boxes_b.back().max);
          }
        }
        auto old_it = first_old;
        for (Index i = 0; i < static_cast<Index>(pa.size()); ++i) {
          const Aabb box_a = transform_box(pa[i].bounds, ta);
          if (!boxes_overlap(box_a, all_b)) continue;
          for (Index j = 0; j < static_cast<Index>(pb.size()); ++j) {
            if (!boxes_overlap(box_a, boxes_b[j])) continue;
            SatCache sat;
            while (old_it != old_end && std::tie(old_it->piece_a, old_it->piece_b) < std::tie(i, j)) ++old_it;
            if (old_it != old_end && old_it->piece_a == i && old_it->piece_b == j) sat = old_it->sat;
            const ContactManifold m = collide_hulls(pa[i], ta, pb[j], tb, margin, &sat);
            add_manifold(m, i, j, sat);
          }
        }
      },
      settings_.parallel_min_pairs);

  // Gather in pair order, carry the impulses of matching features (warm start), and settle the
  // pairs waiting to come apart: first where each pair's contacts go, then each pair's into place.
  // Into the buffer of the step before last: the contacts are about two kilobytes each, and a fresh
  // vector every step went through the allocator's mmap path (page faults) for large scenes.
  std::vector<Contact>& next = next_contacts_;
  std::vector<std::array<Index, 2>> still_together;
  pair_offsets_.resize(pairs.size() + 1);
  std::size_t total = 0;
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    pair_offsets_[k] = total;
    const std::vector<Contact>& found = pair_contacts_[k];
    if (contains_pair(until_apart_, pairs[k].a, pairs[k].b)) {
      // Both asleep, nothing moved: they are as together as they were. (Their contacts are never
      // kept, so the narrow phase had none to carry over, and they would have counted as apart:
      // woken, pieces still overlapping along their crack would then be pushed apart at speed.)
      const bool asleep = !bodies_[pairs[k].a].awake && !bodies_[pairs[k].b].awake;
      if (!found.empty() || asleep) still_together.push_back({pairs[k].a, pairs[k].b});
      pair_reused_[k] = 2;  // gathers nothing
      continue;
    }
    total += pair_reused_[k] == 1 ? old_ranges_[k][1] - old_ranges_[k][0] : found.size();
  }
  pair_offsets_[pairs.size()] = total;
  // Every pair's contacts where they were last step, as many (pairs at rest): updated in place.
  bool in_place = total == old.size();
  for (std::size_t k = 0; k < pairs.size() && in_place; ++k)
    in_place =
        pair_reused_[k] == 2 || (pair_offsets_[k] == old_ranges_[k][0] &&
                                 pair_offsets_[k + 1] - pair_offsets_[k] == old_ranges_[k][1] - old_ranges_[k][0]);
  if (!in_place) next.resize(total);
  Contact* const gathered = in_place ? contacts_.data() : next.data();
  parallel_for(
      0, static_cast<std::int64_t>(pairs.size()),
      [&](std::int64_t k) {
        if (pair_reused_[k] == 2) return;
        Contact* out = gathered + pair_offsets_[k];
        const auto pair_old = old.begin() + static_cast<std::ptrdiff_t>(old_ranges_[k][0]);
        const auto pair_old_end = old.begin() + static_cast<std::ptrdiff_t>(old_ranges_[k][1]);
        if (pair_reused_[k] == 1) {
          move_kept_contacts(std::span(pair_old, pair_old_end), out);
          return;
        }
        // All matched before any is written: in place, `out` is the pair's old contacts.
        for (Contact& c : pair_contacts_[k]) {
          const auto [lo, hi] = std::equal_range(pair_old, pair_old_end, c, key_less);
          ContactConstraint& cc = c.constraint;
          cc.tangents = tangent_basis(cc.normal);
          bool manifold_matched = false;
          for (int i = 0; i < cc.count; ++i) {
            ContactPoint& p = cc.points[i];
            for (auto it = lo; it != hi; ++it) {
              const ContactConstraint& oc = it->constraint;
              const auto match = std::find_if(oc.points.begin(), oc.points.begin() + oc.count,
                                              [&](const ContactPoint& q) { return q.feature == p.feature; });
              if (match == oc.points.begin() + oc.count) continue;
              // Same feature pair: keep its normal impulse; the manifold's friction and twist carry
              // over when it is the same manifold (re-expressed in the new tangents).
              p.normal_impulse = match->normal_impulse;
              if (!manifold_matched) {
                manifold_matched = true;
                carry_friction(cc, oc);
              }
              break;
            }
          }
        }
        for (Contact& c : pair_contacts_[k]) *out++ = std::move(c);
      },
      settings_.parallel_min_pairs);
  until_apart_ = std::move(still_together);
  if (!in_place) contacts_.swap(next);
  stats_.reused_pairs = std::count(pair_reused_.begin(), pair_reused_.end(), char{1});
}

void World::move_kept_contacts(std::span<const Contact> old, Contact* out) const {
  const Body& a = bodies_[old.front().body_a];
  const Body& b = bodies_[old.front().body_b];
  const Transform ta = transform_of(a.rigid);
  const Transform tb = transform_of(b.rigid);
  for (const Contact& kept : old) {
    // The last step's contact (its pieces, separating-axis cache, origin and impulses), moved with
    // the bodies; the step's totals start again from zero, as a new contact's would (prepare_contact
    // sets the rest). `out` may be `old` itself (in place): what is read from `kept` is read first.
    const Vec3 normal = ta.rotation * kept.origin.normal_a;
    // Warm start from its own impulses (as the gather does for contacts found afresh).
    const std::array<Vec3, 2> tangents = tangent_basis(normal);
    const CarriedFriction carried = carried_friction(kept.constraint, normal, tangents);
    Contact& c = *out++;
    if (&c != &kept) c = kept;
    ContactConstraint& cc = c.constraint;
    const ContactOrigin& o = c.origin;
    cc.normal = normal;
    cc.tangents = tangents;
    cc.friction_impulse = carried.impulse;
    cc.twist_impulse = carried.twist;
    cc.total_friction_impulse.setZero();
    cc.total_twist_impulse = 0;
    for (int i = 0; i < cc.count; ++i) {
      ContactPoint& p = cc.points[i];
      const Vec3 on_a = ta.apply(o.point_a[i]);
      const Vec3 on_b = tb.apply(o.point_b[i]);
      p.position = 0.5 * (on_a + on_b);
      p.separation = cc.normal.dot(on_b - on_a);
      p.approach_speed = 0;
      p.max_normal_impulse = 0;
      p.total_normal_impulse = 0;
    }
  }
}

void World::update_islands_and_wake() {
  const Index n = body_count();
  island_parent_.resize(n);
  std::iota(island_parent_.begin(), island_parent_.end(), 0);
  for (const Contact& c : contacts_) {
    const Body& a = bodies_[c.body_a];
    const Body& b = bodies_[c.body_b];
    if (a.type == BodyType::dynamic && b.type == BodyType::dynamic) unite(island_parent_, c.body_a, c.body_b);
    // A moving kinematic body wakes what it touches.
    auto moving = [](const Body& k) {
      return k.type == BodyType::kinematic &&
             (k.rigid.linear_velocity.squaredNorm() > 0 || k.rigid.angular_velocity.squaredNorm() > 0);
    };
    if (moving(a)) wake_slot(c.body_b);
    if (moving(b)) wake_slot(c.body_a);
  }
  // An island with one awake body is awake as a whole.
  std::vector<char> island_awake(n, 0);
  for (Index i = 0; i < n; ++i)
    if (bodies_[i].type == BodyType::dynamic && bodies_[i].awake) island_awake[find_root(island_parent_, i)] = 1;
  stats_.islands = 0;
  island_of_.assign(n, -1);
  for (Index i = 0; i < n; ++i) {
    if (bodies_[i].type != BodyType::dynamic) continue;
    const Index root = find_root(island_parent_, i);
    island_of_[i] = root;
    if (root == i) ++stats_.islands;
    if (island_awake[root] && !bodies_[i].awake) wake_slot(i);
  }
}

void World::solve() {
  const Index n = body_count();
  const double h = settings_.time_step / settings_.substeps;
  const double inverse_h = 1.0 / h;

  // The bodies that do not move (static, asleep) are read by the constraints and never written;
  // each group sets up its own moving bodies (solve_group).
  solver_bodies_.resize(n);
  support_normal_.resize(n);
  pressed_into_support_.resize(n);
  std::vector<Index> moving;
  for (Index i = 0; i < n; ++i) {
    const Body& b = bodies_[i];
    if (moves_in_solve(b)) {
      moving.push_back(i);
      continue;
    }
    SolverBody& s = solver_bodies_[i];
    s.linear_velocity.setZero();
    s.angular_velocity.setZero();
    s.inverse_mass = 0;
    s.inverse_inertia.setZero();
    s.position = b.rigid.position;
    s.rotation = b.rigid.orientation.toRotationMatrix();
  }
  stats_.awake_bodies = static_cast<std::int64_t>(moving.size());

  // Active constraints: those touching an awake dynamic body.
  std::vector<Contact*> active;
  stats_.contact_points = 0;
  for (Contact& c : contacts_) {
    const Body& a = bodies_[c.body_a];
    const Body& b = bodies_[c.body_b];
    const bool live = (a.type == BodyType::dynamic && a.awake) || (b.type == BodyType::dynamic && b.awake);
    if (!live) continue;
    c.constraint.body_a = c.body_a;
    c.constraint.body_b = c.body_b;
    active.push_back(&c);
    stats_.contact_points += c.constraint.count;
  }
  stats_.contacts = static_cast<std::int64_t>(active.size());

  spun_.resize(n);
  build_solve_groups(active, moving);
  const auto groups = static_cast<std::int64_t>(solve_group_count_);
  stats_.solve_groups = groups;
  // Each group's constraints touch only its own moving bodies (the others they touch are static or
  // asleep, read and never written), so the groups step side by side. A body sees the same
  // constraints in the same order as in one solve over all of them: the bits do not depend on
  // the grouping, nor on the thread count.
  std::int64_t largest = 0;
  for (std::int64_t g = 0; g < groups; ++g)
    largest = std::max<std::int64_t>(largest, static_cast<std::int64_t>(solve_groups_[g].moving.size()));
  if (groups > 1 && 2 * largest <= stats_.awake_bodies)
    parallel_for(0, groups, [&](std::int64_t g) { solve_group(solve_groups_[g], h, inverse_h); }, 2);
  else
    for (std::int64_t g = 0; g < groups; ++g) solve_group(solve_groups_[g], h, inverse_h);  // loops inside in parallel

  // The contacts made within the step join the others, in key order (the pointers into contacts_
  // are not used after the solve). Through buffers kept from step to step: a step that makes
  // contacts would otherwise allocate and fault in a copy of every contact (two kilobytes each).
  std::vector<Contact>& made = made_buffer_;
  made.clear();
  for (std::int64_t g = 0; g < groups; ++g) {
    for (Contact& c : solve_groups_[g].made) made.push_back(std::move(c));
    solve_groups_[g].made.clear();
  }
  if (!made.empty()) {
    stats_.contacts += static_cast<std::int64_t>(made.size());
    for (const Contact& c : made) stats_.contact_points += c.constraint.count;
    // A piece may have a made contact beside one from the step's start (same key): the step's
    // start first, then in the order made.
    // (Insertion: few, and stable.)
    for (auto it = made.begin(); it != made.end(); ++it)
      std::rotate(std::upper_bound(made.begin(), it, *it, key_less), it, std::next(it));
    std::vector<Contact>& merged = merge_buffer_;
    merged.clear();
    merged.reserve(contacts_.size() + made.size());
    std::merge(std::make_move_iterator(contacts_.begin()), std::make_move_iterator(contacts_.end()),
               std::make_move_iterator(made.begin()), std::make_move_iterator(made.end()), std::back_inserter(merged),
               key_less);
    contacts_.swap(merged);
  }
}

void World::build_solve_groups(std::span<Contact* const> active, std::span<const Index> moving) {
  const Index n = body_count();
  solve_parent_.resize(n);
  std::iota(solve_parent_.begin(), solve_parent_.end(), 0);
  auto moves = [&](Index i) { return moves_in_solve(bodies_[i]); };
  for (const Contact* c : active)
    if (moves(c->body_a) && moves(c->body_b)) unite(solve_parent_, c->body_a, c->body_b);
  // Per moving body, the sum of the normals (into it) of its contacts with its supports: bodies
  // that take no impulses (static, asleep, kinematic). For the tests of a press into the supports,
  // here and in solve_group.
  const auto responds = [&](Index i) { return bodies_[i].type == BodyType::dynamic && moves(i); };
  for (const Index i : moving) support_normal_[i].setZero();
  for (const Contact* c : active) {
    if (responds(c->body_a) == responds(c->body_b)) continue;
    if (responds(c->body_b))
      support_normal_[c->body_b] += c->constraint.normal;
    else
      support_normal_[c->body_a] -= c->constraint.normal;
  }
  // Components where a dynamic body at least twice the shock ratio heavier presses a dynamic body
  // into its support take extra relax passes: one, and one more each time the ratio doubles, up
  // to ContactSolverSettings::mass_ratio_relax_passes. Components are grouped by that count, so
  // that each is solved the same whatever components share its group.
  const double ratio = settings_.contact.shock_mass_ratio;
  const int most = ratio > 0 ? std::max(0, settings_.contact.mass_ratio_relax_passes) : 0;
  std::vector<int> passes(n, 0);  // per component root
  if (most > 0) {
    for (const Contact* c : active) {
      if (!responds(c->body_a) || !responds(c->body_b)) continue;
      const double ia = bodies_[c->body_a].inertia.inverse_mass, ib = bodies_[c->body_b].inertia.inverse_mass;
      // The lighter body, pressed into its support by the other (as for shock propagation).
      const bool light_a = ia >= ib;
      const Index light = light_a ? c->body_a : c->body_b;
      const Vec3& up = support_normal_[light];
      const Vec3 push = light_a ? Vec3(-c->constraint.normal) : c->constraint.normal;
      const bool supported = presses_into(push, up);
      const double r = supported ? (light_a ? ia / ib : ib / ia) : 0.0;
      int k = 0;
      for (double at = 2 * ratio; k < most && r >= at; at *= 2) ++k;
      int& p = passes[find_root(solve_parent_, c->body_a)];
      p = std::max(p, k);
    }
  }
  // Components numbered in the order of their first body; consecutive components with the same
  // extra passes fill a group up to solve_group_bodies moving bodies.
  std::vector<Index> group_of_root(n, -1);
  std::size_t count = 0;
  std::vector<std::int64_t> open(static_cast<std::size_t>(most) + 1, -1);  // the group each count fills
  std::vector<std::int64_t> filled(static_cast<std::size_t>(most) + 1, 0);
  auto open_group = [&](std::size_t kind) {
    if (solve_groups_.size() <= count) solve_groups_.emplace_back();
    SolveGroup& g = solve_groups_[count];
    g.moving.clear();
    g.constraints.clear();
    g.refreshable.clear();
    g.made.clear();
    g.extra_relax_passes = static_cast<int>(kind);
    open[kind] = static_cast<std::int64_t>(count);
    ++count;
    filled[kind] = 0;
  };
  for (const Index i : moving) {
    const Index root = find_root(solve_parent_, i);
    const auto kind = static_cast<std::size_t>(passes[root]);
    if (group_of_root[root] < 0) {
      if (open[kind] < 0 || filled[kind] >= settings_.solve_group_bodies) open_group(kind);
      group_of_root[root] = static_cast<Index>(open[kind]);
    }
    solve_groups_[group_of_root[root]].moving.push_back(i);
    ++filled[kind];
  }
  solve_group_count_ = count;
  for (Contact* c : active) {
    // A live constraint has an awake dynamic body (solve), which moves.
    const Index body = moves(c->body_a) ? c->body_a : c->body_b;
    SolveGroup& group = solve_groups_[group_of_root[find_root(solve_parent_, body)]];
    group.constraints.push_back(&c->constraint);
    // A piece of a rigid dynamic body (not the tet mode's points: no piece) and a plane or a piece
    // of another rigid body.
    const auto rigid_piece = [&](Index slot, Index piece) { return piece >= 0 && !bodies_[slot].deform; };
    const auto dynamic_piece = [&](Index slot, Index piece) {
      return bodies_[slot].type == BodyType::dynamic && rigid_piece(slot, piece);
    };
    if ((dynamic_piece(c->body_a, c->piece_a) && (bodies_[c->body_b].is_plane || rigid_piece(c->body_b, c->piece_b))) ||
        (dynamic_piece(c->body_b, c->piece_b) && (bodies_[c->body_a].is_plane || rigid_piece(c->body_a, c->piece_a))))
      group.refreshable.push_back(c);
  }
}

void World::solve_group(SolveGroup& group, double h, double inverse_h) {
  const std::vector<Index>& moving = group.moving;
  for (const Index i : moving) {
    const Body& b = bodies_[i];
    SolverBody& s = solver_bodies_[i];
    s.linear_velocity = b.rigid.linear_velocity;
    s.angular_velocity = b.rigid.angular_velocity;
    const bool responds = b.type == BodyType::dynamic;
    s.inverse_mass = responds ? b.inertia.inverse_mass : 0.0;
    s.inverse_inertia = responds ? world_inverse_inertia(b.inertia, b.rigid.orientation) : Mat3::Zero();
    s.position = b.rigid.position;
    s.rotation = b.rigid.orientation.toRotationMatrix();
    spun_[i] = 0;
  }
  group.turn_base.assign(group.refreshable.size(), {0.0, 0.0, 0.0});
  // Box3D's choices: the spring at most an eighth of the substep rate; contacts with static and
  // kinematic bodies twice as stiff and half as damped, so nothing is pushed into the ground (and
  // so are those with a dynamic body much heavier than the other: wall_like).
  const double hertz = std::min(settings_.contact.contact_hertz, 0.125 / h);
  const Softness soft = make_softness(hertz, settings_.contact.damping_ratio, h);
  const Softness static_soft = make_softness(2 * hertz, 0.5 * settings_.contact.damping_ratio, h);
  for (ContactConstraint* c : group.constraints) {
    ContactConstraint& cc = *c;
    const Body& a = bodies_[cc.body_a];
    const Body& b = bodies_[cc.body_b];
    cc.friction = mixed_friction(a.surface, b.surface);
    cc.restitution = mixed_restitution(a.surface, b.surface);
    prepare_contact(cc, solver_bodies_, settings_.speculative_distance);
  }

  const Vec3 dv_gravity = h * settings_.gravity;
  const double max_speed = settings_.max_linear_speed;
  const double max_spin = settings_.max_rotation / settings_.time_step;
  // Scaled back to the limits (the direction kept); below them, untouched. Before the substep's
  // solve, and again before the drift: the solve may push a light piece past them (the points of
  // a manifold pushed one after another spin a thin shard), and the drift must not move it
  // farther than the limits allow, nor the step's contacts, found at its start, go stale.
  const auto limit_speeds = [max_speed, max_spin](SolverBody& s) {
    if (const double v2 = s.linear_velocity.squaredNorm(); v2 > max_speed * max_speed)
      s.linear_velocity *= max_speed / std::sqrt(v2);
    if (const double w2 = s.angular_velocity.squaredNorm(); w2 > max_spin * max_spin)
      s.angular_velocity *= max_spin / std::sqrt(w2);
  };
  // A light body pressed into its support by a heavier one (its support normal from
  // build_solve_groups): it meets the support with the softer spring (pressed_mass_ratio), and the
  // heavier body stops against it (shock propagation, shock_mass_ratio).
  group.shock.clear();
  group.shock_support.clear();
  for (const Index i : moving) pressed_into_support_[i] = 0;
  const double shock_ratio = settings_.contact.shock_mass_ratio;
  const double pressed_ratio = settings_.contact.pressed_mass_ratio;
  if (shock_ratio > 0 || pressed_ratio > 0) {
    // The smaller of the two ratios that are on: a pair lighter than it is neither.
    const double least = shock_ratio > 0 && pressed_ratio > 0 ? std::min(shock_ratio, pressed_ratio)
                                                              : std::max(shock_ratio, pressed_ratio);
    for (ContactConstraint* c : group.constraints) {
      if (!c->a_responds || !c->b_responds) continue;
      const double ma = solver_bodies_[c->body_a].inverse_mass, mb = solver_bodies_[c->body_b].inverse_mass;
      // The lighter body: its inverse mass at least `least` times the other's.
      const bool light_a = ma >= least * mb;
      if (!light_a && !(mb >= least * ma)) continue;
      const Index light = light_a ? c->body_a : c->body_b;
      const Vec3& up = support_normal_[light];
      // Pressed into its support: the push on it (from the other body) against its support's.
      const Vec3 push = light_a ? Vec3(-c->normal) : c->normal;
      if (!presses_into(push, up)) continue;
      const auto heavier_by = [&](double r) { return r > 0 && (light_a ? ma >= r * mb : mb >= r * ma); };
      if (heavier_by(pressed_ratio)) pressed_into_support_[light] = 1;
      if (heavier_by(shock_ratio)) group.shock.emplace_back(c, light_a);
    }
    if (!group.shock.empty())
      for (ContactConstraint* c : group.constraints) {
        if (c->a_responds == c->b_responds) continue;
        const Index body = c->a_responds ? c->body_a : c->body_b;
        for (const auto& [sc, light_a] : group.shock)
          if ((light_a ? sc->body_a : sc->body_b) == body) {
            group.shock_support.emplace_back(c, !c->a_responds);
            break;
          }
      }
  }
  for (ContactConstraint* c : group.constraints)
    c->softness = contact_softness(c->body_a, c->body_b, soft, static_soft);
  // After a pass, from the bottom up (Guendelman et al.'s order): the light bodies stop against
  // their support, then the heavy ones against the light ones. The other way round, the heavy body
  // was stopped against the light body's velocity before that body's own push moved it, which the
  // heavy body then met in the next pass: a 10 cm box ten times as dense as the box under it
  // rocked at up to 140 mm/s (docs/method.md, "Heavy on light").
  const auto push_off = [&](bool use_bias) {
    for (const auto& [c, support_a] : group.shock_support)
      push_off_supported(*c, solver_bodies_, support_a, inverse_h, use_bias, settings_.contact.max_push_velocity);
    for (const auto& [c, light_a] : group.shock)
      push_off_supported(*c, solver_bodies_, light_a, inverse_h, use_bias, settings_.contact.max_push_velocity);
  };
  // Four constraints at a time, in an order that depends only on the constraints' (contact_batches.h).
  ContactBatches& batches = group.batches;
  batches.build(group.constraints, solver_bodies_);
  const auto num_moving = static_cast<std::int64_t>(moving.size());

  for (int sub = 0; sub < settings_.substeps; ++sub) {
    if (sub > 0 && !group.refreshable.empty()) refresh_contacts(group, sub * h, soft, static_soft);
    parallel_for(
        0, num_moving,
        [&](std::int64_t k) {
          const Index i = moving[k];
          if (bodies_[i].type != BodyType::dynamic) return;
          SolverBody& s = solver_bodies_[i];
          s.linear_velocity += dv_gravity;
          if (const Body& b = bodies_[i]; b.pressed) {
            s.linear_velocity += (h * s.inverse_mass) * b.press_force;
            s.angular_velocity += s.inverse_inertia * (h * b.press_torque);
          }
          limit_speeds(s);
        },
        settings_.parallel_min_bodies);
    batches.measure_approach(solver_bodies_);
    batches.warm_start(solver_bodies_);
    batches.solve(solver_bodies_, inverse_h, true, settings_.contact.max_push_velocity);
    push_off(true);
    // Drift in groups of four bodies (integrate_positions: side by side in vector lanes).
    parallel_for(
        0, (num_moving + 3) / 4,
        [&](std::int64_t g) {
          std::array<const RigidInertia*, 4> inertia{};
          std::array<RigidState*, 4> states{};
          std::array<Mat3*, 4> rotations{};
          const std::int64_t first = 4 * g, count = std::min<std::int64_t>(4, num_moving - first);
          for (std::int64_t k = 0; k < count; ++k) {
            Body& b = bodies_[moving[first + k]];
            SolverBody& s = solver_bodies_[moving[first + k]];
            if (b.type == BodyType::dynamic) limit_speeds(s);
            b.rigid.linear_velocity = s.linear_velocity;
            b.rigid.angular_velocity = s.angular_velocity;
            inertia[k] = &b.inertia;
            states[k] = &b.rigid;
            rotations[k] = &s.rotation;
          }
          const auto size = static_cast<std::size_t>(count);
          integrate_positions(std::span(inertia.data(), size), std::span(states.data(), size), h,
                              std::span(rotations.data(), size));
          for (std::int64_t k = 0; k < count; ++k) {
            const Body& b = bodies_[moving[first + k]];
            SolverBody& s = solver_bodies_[moving[first + k]];
            s.angular_velocity = b.rigid.angular_velocity;
            s.position = b.rigid.position;
            spun_[moving[first + k]] += h * s.angular_velocity.norm();
          }
        },
        (settings_.parallel_min_bodies + 3) / 4);  // groups: the same threshold in bodies
    // Relax, again where masses differ widely: one Gauss-Seidel pass converges slowly across
    // them (a 10 cm box 20 times as dense as the box under it: 24 → 8.9 mm/s with two more).
    for (int pass = 0; pass <= group.extra_relax_passes; ++pass) {
      batches.solve(solver_bodies_, inverse_h, false, settings_.contact.max_push_velocity);
      push_off(false);
    }
  }
  batches.store();
  for (ContactConstraint* c : group.constraints)
    apply_restitution(*c, solver_bodies_, settings_.contact.restitution_threshold);
  for (Contact& c : group.made)
    apply_restitution(c.constraint, solver_bodies_, settings_.contact.restitution_threshold);
  for (const Index i : moving) {
    bodies_[i].rigid.linear_velocity = solver_bodies_[i].linear_velocity;
    bodies_[i].rigid.angular_velocity = solver_bodies_[i].angular_velocity;
  }
}

bool World::wall_like(const Body& a, const Body& b) const {
  if (a.type != BodyType::dynamic || b.type != BodyType::dynamic) return true;
  const double ratio = settings_.contact.wall_mass_ratio;
  if (!(ratio > 0)) return false;
  const double ia = a.inertia.inverse_mass, ib = b.inertia.inverse_mass;
  return ia > ratio * ib || ib > ratio * ia;
}

Softness World::contact_softness(Index a, Index b, const Softness& soft, const Softness& static_soft) const {
  const Body& ba = bodies_[a];
  const Body& bb = bodies_[b];
  if (!wall_like(ba, bb)) return soft;
  // Met as a wall; but a dynamic body pressed into a static or kinematic one by a heavier body
  // meets it with the softer spring (the flag is set for moving bodies only).
  const bool a_pressed = ba.type == BodyType::dynamic && moves_in_solve(ba) && pressed_into_support_[a] != 0;
  const bool b_pressed = bb.type == BodyType::dynamic && moves_in_solve(bb) && pressed_into_support_[b] != 0;
  return (a_pressed && bb.type != BodyType::dynamic) || (b_pressed && ba.type != BodyType::dynamic) ? soft
                                                                                                    : static_soft;
}

void World::refresh_contacts(SolveGroup& group, double elapsed, const Softness& soft, const Softness& static_soft) {
  // A pair's contacts were found at the step's start, from the poses then, and the solver holds
  // their points with rows fixed at those poses. A body turned far within the step (a blow, a
  // landing that trips it) has other vertices come down, where no point is: a piece spun to the
  // rotation limit went wholly under the ground in one step, and 34 mm into a resting block.
  // Found again when the turn has moved a vertex farther than its rows foresee: r (1 - cos θ) ~
  // r θ² / 2 past a quarter of the speculative distance (the depth at which collide_hull_plane
  // adds a vertex the motion brings), θ the angle a moving body of the pair turned since they were
  // found (the sum of |ω| h), either's when both move: the rows' normal and lever arms are fixed
  // in the world, and a piece sliding along a turning face (a paddle sweeping it along) comes into
  // the face along a normal that turned away (and a piece riding it turns with it).
  const double spec = settings_.speculative_distance;
  const double left = settings_.time_step - elapsed;
  const std::vector<Contact*>& list = group.refreshable;
  std::vector<Contact*> found;  // the pair's contacts: from the step's start, then those made since
  // Two normals within about 0.8° are the same (cos 0.8° = 1 - 1e-4): a contact along one takes
  // the other's points; farther apart, a contact against a moving body is aimed again.
  constexpr double same_normal = 1 - 1e-4;
  const auto turned_far = [&](Index slot, double since) {
    const Body& body = bodies_[slot];
    const double turn = spun_[slot] - since;
    if (!moves_in_solve(body)) return false;
    // A kinematic body's faces carry the pieces riding them, sliding along them, whatever the
    // body's size: once a face has turned past the angle at which its contacts are aimed again
    // (θ² / 2 > 1 - cos), every substep at 7 rad/s and more. Found only when vertices came down,
    // the normal lagged the face by up to two substeps' turn and the sliding piece went that much
    // deeper: 21 of 60 sweeps of World.APieceSweptByATurningPaddleStaysOutOfIt past 4 mm, 7 now.
    if (body.type == BodyType::kinematic && 0.5 * turn * turn > 1 - same_normal) return true;
    return 0.5 * turn * turn * body.radius > 0.25 * spec;
  };
  // A piece sliding along a turning dynamic body's face (a heavy rotor sweeping it along) goes
  // into the face by the slide times the angle its normal lags the face: found again once that
  // passes a sixteenth of the speculative distance. The slide is the tangential speed at the
  // pair's first point times the time since found: resting and rolling pieces, turning but not
  // sliding, stay put.
  const double slide_depth = spec / 16;
  const auto slid_far = [&](Index slot_a, Index slot_b, const std::array<double, 3>& since, const Contact& c) {
    const Body& ba = bodies_[slot_a];
    const Body& bb = bodies_[slot_b];
    const double turn = std::max(moves_in_solve(ba) ? spun_[slot_a] - since[0] : 0.0,
                                 moves_in_solve(bb) ? spun_[slot_b] - since[1] : 0.0);
    const SolverBody& sa = solver_bodies_[slot_a];
    const SolverBody& sb = solver_bodies_[slot_b];
    // First a bound from the bodies alone (resting pieces end here, without reading the contact).
    const double dt = elapsed - since[2];
    const auto speed = [](const Body& b, const SolverBody& s) {
      return moves_in_solve(b) ? s.linear_velocity.norm() + s.angular_velocity.norm() * b.radius : 0.0;
    };
    const double fastest = speed(ba, sa) + speed(bb, sb);
    if (!(fastest * dt * turn > slide_depth)) return false;
    const ContactConstraint& cc = c.constraint;
    if (cc.count == 0 || !(cc.points[0].normal_impulse > 0)) return false;  // not pressed: not riding
    const Vec3 ra = sa.rotation * cc.points[0].local_anchor_a;
    const Vec3 rb = sb.rotation * cc.points[0].local_anchor_b;
    const Vec3 v =
        sb.linear_velocity + sb.angular_velocity.cross(rb) - sa.linear_velocity - sa.angular_velocity.cross(ra);
    return (v - cc.normal.dot(v) * cc.normal).norm() * dt * turn > slide_depth;
  };
  for (std::size_t first = 0, last = 0; first < list.size(); first = last) {
    const Index slot_a = list[first]->body_a, slot_b = list[first]->body_b;
    for (last = first + 1; last < list.size() && list[last]->body_a == slot_a && list[last]->body_b == slot_b;) ++last;
    // The pieces of the moving dynamic body (A, when both are) are collided with the other's plane
    // or pieces; each point's position lies on the other's surface.
    const bool other_first = bodies_[slot_a].type != BodyType::dynamic || !moves_in_solve(bodies_[slot_a]);
    const Index slot = other_first ? slot_b : slot_a;
    const Index other_slot = other_first ? slot_a : slot_b;
    const Body& b = bodies_[slot];
    const Body& other = bodies_[other_slot];
    std::array<double, 3>& since = group.turn_base[first];
    if (!turned_far(slot_a, since[0]) && !turned_far(slot_b, since[1]) &&
        !slid_far(slot_a, slot_b, since, *list[first]))
      continue;
    since = {spun_[slot_a], spun_[slot_b], elapsed};  // a body that does not move: never read
    found.assign(list.begin() + static_cast<std::ptrdiff_t>(first), list.begin() + static_cast<std::ptrdiff_t>(last));
    for (Contact& c : group.made)
      if (c.body_a == slot_a && c.body_b == slot_b) found.push_back(&c);
    const SolverBody& s = solver_bodies_[slot];
    const SolverBody& so = solver_bodies_[other_slot];
    const Transform pose{s.rotation, s.position};
    // Gaps the rest of the step can close, as the narrow phase's margin (the other body's motion
    // is zero when it does not move).
    const double margin = spec + left * (s.linear_velocity.norm() + s.angular_velocity.norm() * b.radius) +
                          left * (so.linear_velocity.norm() + so.angular_velocity.norm() * other.radius);
    const Softness pair_soft = contact_softness(slot, other_slot, soft, static_soft);
    const bool moving_other = moves_in_solve(other);
    bool changed = false;
    // The manifold `m` (its normal from A to B) of the pieces `piece_a`, `piece_b` at the pose now,
    // merged into the pair's contacts.
    const auto place = [&](const ContactManifold& m, Index piece_a, Index piece_b, const SatCache& sat) {
      if (m.count == 0) return;  // the contacts it has keep their points (their gaps are followed)
      const auto same_pieces = [&](const Contact* c) { return c->piece_a == piece_a && c->piece_b == piece_b; };
      // Against a moving body, a contact whose normal has turned (the face it came from turned
      // with its body: a kinematic paddle sweeping a piece along) is aimed along the normal now,
      // its points those of the manifold that no other contact of the pieces holds: its normal
      // fixed at the step's start pushed the piece along a direction the face had left, and the
      // face ran into it. A point the contact held keeps its impulses, totals and approach speed
      // (by feature).
      const auto held_by = [&](const Contact* c, std::uint32_t feature) {
        return point_with(c->constraint, feature) >= 0;
      };
      if (moving_other)
        for (Contact* c : found) {
          ContactConstraint& cc = c->constraint;
          if (!same_pieces(c) || cc.normal.dot(m.normal) > same_normal ||
              std::none_of(m.points.begin(), m.points.begin() + m.count,
                           [&](const ManifoldPoint& q) { return held_by(c, q.feature); }))
            continue;
          std::array<ManifoldPoint, 4> kept{};
          int count = 0;
          for (int k = 0; k < m.count; ++k)
            if (std::none_of(found.begin(), found.end(), [&](const Contact* o) {
                  return o != c && same_pieces(o) && held_by(o, m.points[k].feature);
                }))
              kept[count++] = m.points[k];
          if (count == 0) continue;
          group.batches.pull(&cc);
          cc = aimed(cc, m.normal, std::span(kept.data(), count), solver_bodies_, spec);
          group.batches.reload(&cc, solver_bodies_);
          changed = true;
        }
      // The new manifold's points, deepest first; those the pieces' contacts hold already go.
      std::array<ManifoldPoint, 4> fresh{};
      int fresh_count = 0;
      for (int k = 0; k < m.count; ++k) {
        const ManifoldPoint& q = m.points[k];
        const bool held = std::any_of(found.begin(), found.end(),
                                      [&](const Contact* c) { return same_pieces(c) && held_by(c, q.feature); });
        if (held) continue;
        int at = fresh_count++;
        for (; at > 0 && q.separation < fresh[at - 1].separation; --at) fresh[at] = fresh[at - 1];
        fresh[at] = q;
      }
      int next = 0;  // the first of `fresh` not placed yet
      // Into a contact of the pieces with the same normal: a free slot, or the slot of the widest
      // point that has carried no load in the step (a speculative point; its impulses and totals
      // are all zero) when it lies less deep. A point that carried load stays, with its rows and
      // impulses: the warm start holds the body up, and its totals and approach speed are the
      // impact analysis's (rows made again at the pose now held a tripped shard less well: 5 mm
      // deep against 0.3 mm).
      for (Contact* c : found) {
        // The same normal within about 0.8 degrees (a normal from the moving body's face turns with it).
        if (!same_pieces(c) || next == fresh_count || !(c->constraint.normal.dot(m.normal) > same_normal)) continue;
        ContactConstraint& cc = c->constraint;
        group.batches.pull(&cc);
        const SolverBody& sa = solver_bodies_[cc.body_a];
        const SolverBody& sb = solver_bodies_[cc.body_b];
        // Each point now: the dynamic body's surface point, the other's its projection (the body
        // slides on it).
        ContactConstraint now = cc;
        for (int k = 0; k < now.count; ++k) {
          ContactPoint& p = now.points[k];
          const Vec3 on_a = sa.position + sa.rotation * p.local_anchor_a;
          const Vec3 on_b = sb.position + sb.rotation * p.local_anchor_b;
          p.separation = p.adjusted_separation + cc.normal.dot(on_b - on_a);
          p.position =
              other_first ? Vec3(on_b - 0.5 * p.separation * cc.normal) : Vec3(on_a + 0.5 * p.separation * cc.normal);
        }
        std::array<bool, 4> joined{};
        for (; next < fresh_count; ++next) {
          const ManifoldPoint& q = fresh[next];
          int at = now.count;
          if (now.count == 4) {
            at = -1;
            for (int k = 0; k < 4; ++k) {
              const ContactPoint& p = cc.points[k];
              if (!joined[k] && p.total_normal_impulse == 0 && p.max_normal_impulse == 0 &&
                  (at < 0 || now.points[k].separation > now.points[at].separation))
                at = k;
            }
            if (at < 0 || !(q.separation < now.points[at].separation)) break;
          } else {
            ++now.count;
          }
          now.points[at] = {.position = q.point, .separation = q.separation, .feature = q.feature};
          joined[at] = true;
        }
        if (std::none_of(joined.begin(), joined.end(), [](bool j) { return j; })) continue;
        // The joining points' rows from the constraint prepared at the poses now; the other points,
        // the friction centre and the friction rows stay (the twist's lever arms from the centre on
        // the other body, which does not turn, or turns less than the body that tripped the refresh).
        prepare_contact(now, solver_bodies_, spec);
        cc.count = now.count;
        for (int k = 0; k < cc.count; ++k) {
          if (!joined[k]) continue;
          cc.points[k] = now.points[k];
          cc.points[k].lever_arm =
              other_first ? (cc.points[k].anchor_a - cc.centre_a).norm() : (cc.points[k].anchor_b - cc.centre_b).norm();
        }
        group.batches.reload(&cc, solver_bodies_);
        changed = true;
      }
      if (next == fresh_count) return;
      // What found no place: a contact of its own, solved one at a time after the others.
      Contact& c = group.made.emplace_back();
      c.body_a = slot_a;
      c.body_b = slot_b;
      c.piece_a = piece_a;
      c.piece_b = piece_b;
      c.sat = sat;
      ContactConstraint& cc = c.constraint;
      cc.body_a = slot_a;
      cc.body_b = slot_b;
      cc.normal = m.normal;
      cc.friction = mixed_friction(bodies_[slot_a].surface, bodies_[slot_b].surface);
      cc.restitution = mixed_restitution(bodies_[slot_a].surface, bodies_[slot_b].surface);
      cc.softness = pair_soft;
      for (; next < fresh_count; ++next)
        cc.points[cc.count++] = {
            .position = fresh[next].point, .separation = fresh[next].separation, .feature = fresh[next].feature};
      prepare_contact(cc, solver_bodies_, spec);
      group.batches.add(&cc);
      found.push_back(&c);
      changed = true;
    };
    const auto& pieces = b.shape->pieces;
    if (other.is_plane) {
      const HullMotion motion{.linear_velocity = s.linear_velocity,
                              .angular_velocity = s.angular_velocity,
                              .dt = left,
                              .depth = 0.25 * spec,
                              .inverse_mass = b.inertia.inverse_mass,
                              .inverse_inertia = b.inertia.inverse_inertia_body};
      for (Index i = 0; i < static_cast<Index>(pieces.size()); ++i) {
        ContactManifold m = collide_hull_plane(pieces[i], pose, other.shape->plane, margin, &motion);
        if (other_first) m.normal = -m.normal;  // from the plane (A) to the hull (B)
        place(m, other_first ? -1 : i, other_first ? i : -1, {});
      }
    } else {
      // Each piece against the other body's pieces whose boxes its box (grown by the margin) meets,
      // at its pose now (a static body's: as it rests).
      const Transform held =
          other.type == BodyType::static_body ? transform_of(other.rigid) : Transform{so.rotation, so.position};
      const auto& other_pieces = other.shape->pieces;
      std::vector<Aabb> other_boxes;  // the other's pieces' world boxes, once per pair
      other_boxes.reserve(other_pieces.size());
      for (const ConvexHull& piece : other_pieces) other_boxes.push_back(transform_box(piece.bounds, held));
      for (Index i = 0; i < static_cast<Index>(pieces.size()); ++i) {
        const Aabb box = grow(transform_box(pieces[i].bounds, pose), margin);
        for (Index j = 0; j < static_cast<Index>(other_pieces.size()); ++j) {
          if (!boxes_overlap(box, other_boxes[j])) continue;
          const Index piece_a = other_first ? j : i, piece_b = other_first ? i : j;
          SatCache sat;  // the step's start's, where the pieces had a contact
          const auto with_cache = std::find_if(found.begin(), found.end(), [&](const Contact* c) {
            return c->piece_a == piece_a && c->piece_b == piece_b;
          });
          if (with_cache != found.end()) sat = (*with_cache)->sat;
          const ContactManifold m = other_first ? collide_hulls(other_pieces[j], held, pieces[i], pose, margin, &sat)
                                                : collide_hulls(pieces[i], pose, other_pieces[j], held, margin, &sat);
          place(m, piece_a, piece_b, sat);
        }
      }
    }
    // The pair's contacts are no longer those of their origin (a pair reuses its contacts on its
    // first one's): found afresh next step.
    if (changed)
      for (Contact* c : found) c->origin.margin = -1;
  }
}

void World::update_sleep() {
  const Index n = body_count();
  const double dt = settings_.time_step;
  if (!settings_.enable_sleep) return;
  // Bodies pushed by a moving kinematic body stay awake.
  for (const Contact& c : contacts_) {
    for (const auto& [k, d] : {std::pair{c.body_a, c.body_b}, std::pair{c.body_b, c.body_a}}) {
      const Body& kb = bodies_[k];
      if (kb.type == BodyType::kinematic &&
          (kb.rigid.linear_velocity.squaredNorm() > 0 || kb.rigid.angular_velocity.squaredNorm() > 0))
        bodies_[d].sleep_time = -dt;  // becomes 0 below
    }
  }
  std::vector<double> island_min(n, std::numeric_limits<double>::infinity());
  for (Index i = 0; i < n; ++i) {
    Body& b = bodies_[i];
    if (b.type != BodyType::dynamic || !b.awake) continue;
    const double speed = b.deform ? b.deform->max_speed
                                  : b.rigid.linear_velocity.norm() + b.rigid.angular_velocity.norm() * b.shape->radius;
    if (!b.can_sleep || speed > settings_.sleep_velocity || b.sleep_time < 0)
      b.sleep_time = 0;
    else
      b.sleep_time += dt;
    const Index root = island_of_[i];
    island_min[root] = std::min(island_min[root], b.sleep_time);
  }
  for (Index i = 0; i < n; ++i) {
    Body& b = bodies_[i];
    if (b.type != BodyType::dynamic || !b.awake) continue;
    if (island_min[island_of_[i]] >= settings_.time_to_sleep) {
      b.awake = false;
      b.rigid.linear_velocity.setZero();
      b.rigid.angular_velocity.setZero();
      if (b.deform) {
        for (Vec3& v : b.deform->nodes.v) v.setZero();
        b.deform->max_speed = 0;
      }
    }
  }
}

void World::process_impacts() {
  if (!settings_.enable_impacts) {
    open_impacts_.clear();
    return;
  }
  auto settings_of = [&](const Body& b) -> const ImpactSettings& { return b.impact ? *b.impact : settings_.impact; };
  auto analysable = [](const Body& b) { return b.type == BodyType::dynamic && b.model && b.breakable && !b.removed; };
  auto velocity_at = [](const Body& b, const Vec3& p) {
    return Vec3(b.rigid.linear_velocity + b.rigid.angular_velocity.cross(p - b.rigid.position));
  };
  // Walk the pairs touching this step (some point pushed or overlaps) with the open events.
  std::vector<OpenImpact> next;
  std::vector<std::size_t> ready;  // events of `next` to analyse now
  auto old = open_impacts_.begin();
  for (std::size_t i = 0; i < contacts_.size();) {
    const Index a = contacts_[i].body_a;
    const Index b = contacts_[i].body_b;
    const std::size_t first = i;
    double approach = 0;  // fastest approach of a pushing point before the solve
    bool touches = false;
    for (; i < contacts_.size() && contacts_[i].body_a == a && contacts_[i].body_b == b; ++i) {
      const ContactConstraint& cc = contacts_[i].constraint;
      for (int k = 0; k < cc.count; ++k) {
        const ContactPoint& p = cc.points[k];
        touches |= p.separation <= 0 || p.total_normal_impulse > 0;
        if (p.total_normal_impulse > 0) approach = std::max(approach, p.approach_speed);
      }
    }
    while (old != open_impacts_.end() && old->pair < std::array<Index, 2>{a, b}) ++old;
    const bool was_open = old != open_impacts_.end() && old->pair == std::array<Index, 2>{a, b};
    if (!touches) continue;  // apart: its event (if any) closes
    const Body& ba = bodies_[a];
    const Body& bb = bodies_[b];
    if (was_open) {
      next.push_back(*old);
      ++next.back().steps;
      if (next.back().analysed) continue;  // nothing more to collect
    } else {
      const double threshold = std::min(settings_of(ba).min_approach_speed, settings_of(bb).min_approach_speed);
      if (approach < threshold || (!analysable(ba) && !analysable(bb))) continue;
      next.push_back({.pair = {a, b}});
    }
    // Collect the pushing points (only for events still collecting), and how fast the pair still
    // closes after the solve.
    OpenImpact& e = next.back();
    e.approach = std::max(e.approach, approach);
    double still_closing = 0;
    const Mat3 ra = ba.rigid.orientation.toRotationMatrix();
    const Mat3 rb = bb.rigid.orientation.toRotationMatrix();
    for (std::size_t j = first; j < i; ++j) {
      const ContactConstraint& cc = contacts_[j].constraint;
      for (int k = 0; k < cc.count; ++k) {
        const ContactPoint& p = cc.points[k];
        if (!(p.total_normal_impulse > 0)) continue;
        // Each body's own surface point (the manifold point lies midway across the gap).
        const Vec3 pa = ba.rigid.position + ra * p.local_anchor_a;
        const Vec3 pb = bb.rigid.position + rb * p.local_anchor_b;
        still_closing = std::max(still_closing, -cc.normal.dot(velocity_at(bb, pb) - velocity_at(ba, pa)));
        e.points.push_back({.local_a = p.local_anchor_a,
                            .local_b = p.local_anchor_b,
                            .normal_a = ra.transpose() * -cc.normal,
                            .normal_b = rb.transpose() * cc.normal,
                            .impulse = p.total_normal_impulse,
                            .approach = p.approach_speed});
      }
    }
    // Ready once the pair no longer closes (the solver resolved the collision), or after a few
    // steps whatever happens.
    if (still_closing <= 0.1 * e.approach || e.steps >= kMaxImpactSteps) {
      e.analysed = true;
      ready.push_back(next.size() - 1);
    }
  }
  open_impacts_ = std::move(next);

  // One analysis per body over the points of all its events that became ready, by body id.
  std::vector<std::array<Index, 3>> work;  // (body, other, event)
  for (const std::size_t k : ready) {
    const OpenImpact& e = open_impacts_[k];
    for (int side = 0; side < 2; ++side)
      if (analysable(bodies_[e.pair[side]])) work.push_back({e.pair[side], e.pair[1 - side], static_cast<Index>(k)});
  }
  std::sort(work.begin(), work.end());
  std::vector<std::pair<Index, Index>> analyse;
  std::vector<std::vector<ImpactContact>> contacts_of;
  std::vector<double> restitution_of;
  for (std::size_t i = 0; i < work.size();) {
    const Index id = work[i][0];
    const Body& body = bodies_[id];
    const Mat3 rotation = body.rigid.orientation.toRotationMatrix();
    std::vector<ImpactContact> found;
    double restitution = 0;
    const Index first_other = work[i][1];
    for (; i < work.size() && work[i][0] == id; ++i) {
      const OpenImpact& e = open_impacts_[work[i][2]];
      const bool is_b = e.pair[1] == id;
      restitution = std::max({restitution, body.surface.restitution, bodies_[work[i][1]].surface.restitution});
      for (const OpenImpact::Point& p : e.points)
        found.push_back({.point = body.rigid.position + rotation * (is_b ? p.local_b : p.local_a),
                         .normal = rotation * (is_b ? p.normal_b : p.normal_a),
                         .normal_impulse = p.impulse,
                         .approach_speed = p.approach});
    }
    analyse.emplace_back(id, first_other);
    contacts_of.push_back(std::move(found));
    restitution_of.push_back(restitution);
  }
  // The analyses only read the world, and each body has its own static solver: they run side by
  // side (each serially inside when there are several), and their results change the world
  // afterwards, in body order. Two blocks that break each other cost one analysis' time on two
  // threads, and the bits do not depend on the thread count.
  std::vector<std::optional<Result<ImpactResult>>> results(analyse.size());
  parallel_for(
      0, static_cast<std::int64_t>(analyse.size()),
      [&](std::int64_t i) {
        const auto k = static_cast<std::size_t>(i);
        const auto [id, other_id] = analyse[k];
        const Body& body = bodies_[id];
        const Body& other = bodies_[other_id];
        ImpactSettings settings = impact_settings(body, other.model ? &other.model->fem.material : nullptr);
        settings.restitution = restitution_of[k];
        BodyState state = impact_state(body);
        results[k] = analyze_impact(*body.model, state, contacts_of[k], settings);
      },
      /*min_parallel=*/2);
  // The children's collision shapes (their convex hulls) side by side too: each reads only its
  // parent's shape and its own model.
  std::vector<std::array<std::size_t, 2>> children;  // (analysis, child), in that order
  for (std::size_t k = 0; k < analyse.size(); ++k)
    if (*results[k] && (*results[k])->analysed)
      for (std::size_t c = 0; c < (*results[k])->children.size(); ++c) children.push_back({k, c});
  std::vector<std::optional<Result<std::shared_ptr<const Shape>>>> built(children.size());
  parallel_for(
      0, static_cast<std::int64_t>(children.size()),
      [&](std::int64_t i) {
        const auto [k, c] = children[static_cast<std::size_t>(i)];
        const ImpactResult& r = **results[k];
        built[static_cast<std::size_t>(i)] = child_shape(analyse[k].first, r, r.children[c]);
      },
      /*min_parallel=*/2);
  std::vector<std::vector<Result<std::shared_ptr<const Shape>>>> shapes(analyse.size());
  for (std::size_t i = 0; i < children.size(); ++i) shapes[children[i][0]].push_back(std::move(*built[i]));
  for (std::size_t k = 0; k < analyse.size(); ++k) {
    const auto [id, other_id] = analyse[k];
    Result<ImpactResult>& result = *results[k];
    if (!result)
      log_warning("world: the impact analysis of body " + std::to_string(id) + " failed: " + result.error().message);
    if (!result || !result->analysed) continue;
    ++stats_.impacts;
    apply_impact(id, other_id, *result, std::move(shapes[k]));
  }
  for (OpenImpact& e : open_impacts_)
    if (e.analysed) e.points.clear();
  forget_removed();
}

ImpactSettings World::impact_settings(const Body& body, const Material* other) const {
  ImpactSettings settings = body.impact ? *body.impact : settings_.impact;
  settings.other_material = other ? *other : settings_.obstacle_material;
  if (body_count() >= settings_.max_bodies) settings.fracture.crack.max_cracks = 0;
  settings.min_fragment_mass = std::max(settings.min_fragment_mass, settings.min_fragment_fraction * body.root_mass);
  return settings;
}

BodyState World::impact_state(const Body& body) {
  BodyState state;
  state.rigid = body.rigid;
  state.plastic_strain = body.plastic_strain;
  state.tensile_strength = body.tensile_strength;
  state.solver = body.solver;
  return state;
}

void World::forget_removed() {
  std::erase_if(contacts_, [&](const Contact& c) { return bodies_[c.body_a].removed || bodies_[c.body_b].removed; });
  std::erase_if(open_impacts_,
                [&](const OpenImpact& e) { return bodies_[e.pair[0]].removed || bodies_[e.pair[1]].removed; });
}

Result<std::shared_ptr<const World::Shape>> World::child_shape(Index slot, const ImpactResult& r,
                                                               const ImpactChild& child) const {
  const Body& body = bodies_[slot];
  // A dent keeps the tets (the pieces keep theirs); a crack's pieces come from the old clusters.
  if (r.children.size() == 1 && r.cracks.empty()) return shape_from_clusters(body.shape->piece_tets, *child.model);
  return inherit_shape(*body.shape, child);
}

void World::apply_impact(Index id, Index other, ImpactResult& r,
                         std::vector<Result<std::shared_ptr<const Shape>>> shapes) {
  if (shapes.empty())
    for (const ImpactChild& child : r.children) shapes.push_back(child_shape(id, r, child));
  ImpactRecord rec;
  rec.body = body_id(id);
  rec.other = other < 0 ? BodyId{} : body_id(other);
  rec.time = time();
  rec.point = r.load_point;
  rec.approach_speed = r.approach_speed;
  rec.impulse = r.impulse;
  rec.contact_time = r.contact_time;
  rec.force = r.force;
  rec.yield_scale = r.yield_scale;
  rec.collision_radius = r.collision_radius;
  rec.max_principal_stress = r.max_principal_stress;
  rec.max_von_mises = r.max_von_mises;
  rec.converged = r.solve.converged;
  rec.load_fraction = r.solve.load_fraction;
  rec.newton_iterations = r.solve.newton_iterations;
  rec.dented = r.dented;
  rec.cracks = static_cast<Index>(r.cracks.size());
  rec.debris_count = r.debris_count;
  rec.debris_mass = r.debris_mass;
  rec.solve_ms = r.solve_ms;
  rec.fracture_ms = r.fracture_ms;
  {
    const Body& body = bodies_[id];
    const Mat3 rotation = body.rigid.orientation.toRotationMatrix();
    for (const CrackEvent& c : r.cracks)
      events_.cracks.push_back({.body = body_id(id),
                                .origin = body.rigid.position + rotation * c.plan.origin,
                                .normal = rotation * c.plan.normal,
                                .radius = c.plan.radius,
                                .stress = c.plan.stress});
  }
  // The stress view of a piece: its tets show the stress of the parent tets they came from.
  auto child_stress = [&](const ImpactChild& child, const std::vector<double>& parent_values) {
    std::vector<double> out;
    if (parent_values.empty()) return out;
    out.reserve(child.parent_tet.size());
    for (const Index e : child.parent_tet) out.push_back(parent_values[static_cast<std::size_t>(e)]);
    return out;
  };
  if (r.children.empty() && r.cracks.empty()) {
    bodies_[id].plastic_strain = std::move(r.plastic_strain);
    bodies_[id].display_stress = std::move(r.display_stress);
    bodies_[id].principal_stress = std::move(r.principal_stress);
    events_.impacts.push_back(rec);
    return;
  }
  if (r.children.size() == 1) {
    // Dented, or cracked but whole: the body goes on under its id with the new model.
    Body& body = bodies_[id];
    ImpactChild& child = r.children.front();
    auto& shape = shapes.front();
    if (shape) {
      set_shape(body, std::move(*shape));
      // Its contacts were found with the old shape: find them again.
      for (Contact& c : contacts_)
        if (c.body_a == id || c.body_b == id) c.origin.margin = -1;
      body.model = child.model;
      body.inertia = rigid_inertia(child.model->mass);
      body.rigid = child.rigid;
      body.plastic_strain = std::move(child.plastic_strain);
      body.tensile_strength = std::move(child.tensile_strength);
      body.display_stress = child_stress(child, r.display_stress);
      body.principal_stress = child_stress(child, r.principal_stress);
    } else {  // keep the body as it was: nothing was removed
      log_warning("world: body " + std::to_string(id) + " keeps its shape: " + shape.error().message);
      rec.dented = false;
      rec.cracks = 0;
      rec.debris_count = 0;
      rec.debris_mass = 0;
    }
    events_.impacts.push_back(rec);
    return;
  }
  // Broken: the children replace the body. (None: every piece was below the debris size, and
  // the whole body went as debris.)
  const Body parent = bodies_[id];
  std::vector<Index> born;
  for (std::size_t c = 0; c < r.children.size(); ++c) {
    ImpactChild& child = r.children[c];
    auto& shape = shapes[c];
    if (!shape) {  // a piece without a collision shape cannot take part: it goes as debris
      log_warning("world: a fragment of body " + std::to_string(id) + " became debris: " + shape.error().message);
      rec.debris_count += 1;
      rec.debris_mass += child.model->mass.mass;
      continue;
    }
    BodyDef def{.type = BodyType::dynamic,
                .rigid = child.rigid,
                .surface = parent.surface,
                .filter = parent.filter,
                .can_sleep = parent.can_sleep,
                .awake = true,
                .breakable = parent.breakable,
                .impact = parent.impact};
    const double mass = child.model->mass.mass;
    const Index cid = add(def, std::move(*shape), std::move(child.model));
    Body& b = bodies_[cid];
    b.parent = id;
    b.root_mass = parent.root_mass;
    b.plastic_strain = std::move(child.plastic_strain);
    b.tensile_strength = std::move(child.tensile_strength);
    b.display_stress = child_stress(child, r.display_stress);
    b.principal_stress = child_stress(child, r.principal_stress);
    born.push_back(cid);
    events_.fragments.push_back({.parent = body_id(id), .body = body_id(cid), .mass = mass});
  }
  Body& removed_body = bodies_[id];
  removed_body.removed = true;
  removed_body.awake = false;
  removed_body.solver.reset();
  events_.removed.push_back(body_id(id));
  // Siblings start in contact along their crack faces: they touch only once they have parted.
  for (std::size_t i = 0; i < born.size(); ++i)
    for (std::size_t j = i + 1; j < born.size(); ++j) insert_pair(until_apart_, born[i], born[j]);
  rec.fragments = static_cast<Index>(born.size());
  events_.impacts.push_back(rec);
}

Result<void> World::strike(BodyId id, const Vec3& point, const Vec3& impulse, double speed, double radius) {
  SHATTER_TRY(slot, live_slot(id, "strike"));
  if (!point.allFinite() || !impulse.allFinite() || !std::isfinite(speed) || !(speed > 0) || !std::isfinite(radius) ||
      radius < 0)
    return make_error("strike: the point and impulse must be finite, the speed > 0 and the radius >= 0");
  SHATTER_TRY(pushed, apply_impulse(id, impulse, point));
  const Body& b = bodies_[*slot];
  tools_.push_back({.body = *slot,
                    .strike = true,
                    .local_point = b.rigid.orientation.conjugate() * (point - b.rigid.position),
                    .vector = impulse,
                    .speed = speed,
                    .radius = radius});
  return {};
}

Result<void> World::press(BodyId id, const Vec3& point, const Vec3& force, double radius, double duration) {
  SHATTER_TRY(slot, live_slot(id, "press"));
  if (!point.allFinite() || !force.allFinite() || !std::isfinite(radius) || !std::isfinite(duration) || radius < 0 ||
      duration < 0)
    return make_error("press: the point and force must be finite, the radius and duration >= 0");
  const Body& b = bodies_[*slot];
  tools_.push_back({.body = *slot,
                    .strike = false,
                    .local_point = b.rigid.orientation.conjugate() * (point - b.rigid.position),
                    .vector = force,
                    .radius = radius,
                    .remaining = std::max(duration, settings_.time_step)});
  return {};
}

Result<Index> World::slice(BodyId id, const Vec3& point, const Vec3& normal) {
  SHATTER_TRY(slot, live_slot(id, "slice"));
  const Body& b = bodies_[*slot];
  if (!b.model || b.type != BodyType::dynamic) return make_error("slice: only dynamic tet bodies can be cut");
  if (b.deform) return make_error("slice: deformable bodies cannot be cut (they do not fracture)");
  SHATTER_TRY(r, slice_body(*b.model, impact_state(b), point, normal, impact_settings(b, nullptr)));
  if (r->cracks.empty()) return Index{0};
  const auto pieces = static_cast<Index>(r->children.size());
  apply_impact(*slot, -1, *r);
  forget_removed();
  return pieces;
}

void World::push_tools() {
  // Presses push their bodies for the coming step (strikes pushed when given). A rigid body takes
  // the force in every substep (solve_group), as it takes gravity: all of a step's push given at
  // once would drive a light body deep into what it is pressed against before its contacts caught
  // it.
  for (Body& b : bodies_)
    if (b.pressed) {
      b.press_force.setZero();
      b.press_torque.setZero();
      b.pressed = false;
    }
  for (const Tool& t : tools_) {
    Body& b = bodies_[t.body];
    if (t.strike || b.removed || b.type != BodyType::dynamic) continue;
    const Vec3 point = b.rigid.position + b.rigid.orientation * t.local_point;
    const Vec3 impulse = settings_.time_step * t.vector;
    if (b.deform) {
      turn_nodes(t.body, spread_impulse(t.body, impulse, point));
      fit_deformable(t.body);
      wake_slot(t.body);
      continue;
    }
    b.press_force += t.vector;
    b.press_torque += (point - b.rigid.position).cross(t.vector);
    b.pressed = true;
    wake_slot(t.body);
  }
}

void World::process_tools() {
  if (tools_.empty()) return;
  std::vector<Tool> tools = std::move(tools_);
  tools_.clear();
  for (Tool& t : tools) {
    Body& b = bodies_[t.body];
    if (b.removed) continue;
    const bool analysable = b.type == BodyType::dynamic && b.model && b.breakable;
    if (analysable) {
      const Vec3 point = b.rigid.position + b.rigid.orientation * t.local_point;
      ImpactSettings settings = impact_settings(b, nullptr);
      BodyState state = impact_state(b);
      Result<ImpactResult> result = ImpactResult{};
      if (t.strike) {
        settings.min_approach_speed = 0;
        // The hammer's face: a floor on the patch radius (a fraction of the body's radius there).
        if (t.radius > 0 && b.shape && b.shape->radius > 0)
          settings.min_patch_radius = std::max(settings.min_patch_radius, t.radius / b.shape->radius);
        const ImpactContact contact{.point = point,
                                    .normal = t.vector.normalized(),
                                    .normal_impulse = t.vector.norm(),
                                    .approach_speed = t.speed};
        result = analyze_impact(*b.model, state, std::span(&contact, 1), settings);
      } else {
        const SurfaceLoad load{.point = point, .force = t.vector, .radius = t.radius};
        result = analyze_load(*b.model, state, std::span(&load, 1), settings);
      }
      if (!result) {
        log_warning("world: the analysis of a tool on body " + std::to_string(t.body) +
                    " failed: " + result.error().message);
      } else if (result->analysed) {
        ++stats_.impacts;
        apply_impact(t.body, -1, *result);
      }
    }
    t.remaining -= settings_.time_step;
    if (!t.strike && t.remaining > 0.5 * settings_.time_step && !bodies_[t.body].removed) tools_.push_back(t);
  }
  forget_removed();
}

std::span<const Vec3> World::node_positions(BodyId id) const {
  const Body& b = body(id);
  return b.deform ? std::span<const Vec3>(b.deform->nodes.x) : std::span<const Vec3>();
}

std::span<const Vec3> World::node_velocities(BodyId id) const {
  const Body& b = body(id);
  return b.deform ? std::span<const Vec3>(b.deform->nodes.v) : std::span<const Vec3>();
}

void World::fit_deformable(Index slot) {
  Body& b = bodies_[slot];
  Body::Deformation& d = *b.deform;
  const std::vector<double>& m = b.model->fem.node_mass;
  const std::vector<Vec3>& rest = *d.rest;
  const std::vector<Vec3>& x = d.nodes.x;
  const std::vector<Vec3>& v = d.nodes.v;
  // Centre of mass and inertia of the lumped masses (for linear tets their centre is the exact
  // one, the rest frame's origin), and their momentum.
  const MassProperties lumped = point_mass_properties(m, x);
  const Vec3& c = lumped.center;
  Vec3 p = Vec3::Zero();
  for (std::size_t i = 0; i < x.size(); ++i) p += m[i] * v[i];
  const Vec3 velocity = p / lumped.mass;
  // Best-fit rotation: the polar factor of sum m_i (x_i - c) r_i^T (shape matching).
  // Angular velocity: the nodes' angular momentum through their inertia (both about c).
  Mat3 A = Mat3::Zero();
  Vec3 L = Vec3::Zero();
  d.box = Aabb{};
  d.max_speed = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    const Vec3 r = x[i] - c;
    A += m[i] * r * rest[i].transpose();
    L += m[i] * r.cross(v[i] - velocity);
    d.box.extend(x[i]);
    d.max_speed = std::max(d.max_speed, v[i].norm());
  }
  Quat q(polar_decomposition(A).R);
  q.normalize();
  if (q.dot(b.rigid.orientation) < 0) q.coeffs() = -q.coeffs();  // the sign the pose had
  b.rigid.position = c;
  b.rigid.orientation = q;
  b.rigid.linear_velocity = velocity;
  b.rigid.angular_velocity = lumped.inertia.ldlt().solve(L);
  // The model shows the deformed shape in the body frame (copied first if a snapshot shares it).
  if (d.model.use_count() > 2) {
    d.model = std::make_shared<BodyModel>(*d.model);
    b.model = d.model;
  }
  BodyModel& model = *d.model;
  const Mat3 Rt = q.toRotationMatrix().transpose();
  for (std::size_t i = 0; i < x.size(); ++i) model.mesh.positions[i] = Rt * (x[i] - c);
  for (std::size_t k = 0; k < model.surface.positions.size(); ++k)
    model.surface.positions[k] = model.mesh.positions[static_cast<std::size_t>(model.surface.vertex_node[k])];
}

Vec3 World::spread_impulse(Index slot, const Vec3& impulse, const Vec3& point) {
  Body& b = bodies_[slot];
  Body::Deformation& d = *b.deform;
  const std::vector<double>& m = b.model->fem.node_mass;
  const TriSurface& surf = b.model->surface;
  std::vector<Vec3>& x = d.nodes.x;
  std::vector<Vec3>& v = d.nodes.v;
  // The surface nodes within the patch radius, weighted (1 - d/r)^2 (the nearest one when none is).
  thread_local std::vector<std::pair<Index, double>> near;
  near.clear();
  double total = 0;
  Index nearest = -1;
  double nearest_d2 = std::numeric_limits<double>::infinity();
  for (const Index node : surf.vertex_node) {
    const double d2 = (x[node] - point).squaredNorm();
    if (d2 < nearest_d2) {
      nearest_d2 = d2;
      nearest = node;
    }
    if (d2 < d.patch_radius * d.patch_radius) {
      const double w = 1 - std::sqrt(d2) / d.patch_radius;
      near.emplace_back(node, w * w);
      total += w * w;
    }
  }
  if (!(total > 0)) {
    near.assign(1, {nearest, 1.0});
    total = 1;
  }
  // Node i takes w_i J: the momentum changes by J, and the moment about c by (sum w_i x_i - c) x J.
  Vec3 centre = Vec3::Zero();
  for (const auto& [node, w] : near) {
    v[node] += (w / total / m[node]) * impulse;
    centre += (w / total) * x[node];
  }
  return (point - centre).cross(impulse);
}

void World::turn_nodes(Index slot, const Vec3& moment) {
  if (moment.squaredNorm() == 0) return;
  Body& b = bodies_[slot];
  const std::vector<double>& m = b.model->fem.node_mass;
  std::vector<Vec3>& x = b.deform->nodes.x;
  std::vector<Vec3>& v = b.deform->nodes.v;
  // dw = I^-1 H with I the nodes' inertia about their centre of mass c; v_i += dw x r_i changes
  // the angular momentum by I dw = H and the momentum by dw x sum m_i r_i = 0.
  const MassProperties lumped = point_mass_properties(m, x);
  const Vec3 dw = lumped.inertia.ldlt().solve(moment);
  for (std::size_t i = 0; i < x.size(); ++i) v[i] += dw.cross(x[i] - lumped.center);
}

DynamicObstacles World::deformable_obstacles(Index slot) const {
  const Body& b = bodies_[slot];
  DynamicObstacles out;
  // Anything within reach of the nodes over the step.
  const Aabb reach = grow(b.deform->box, settings_.speculative_distance + settings_.time_step * b.deform->max_speed);
  for (Index o = 0; o < body_count(); ++o) {
    const Body& other = bodies_[o];
    if (o == slot || other.removed || other.type == BodyType::dynamic) continue;
    if (!(b.filter.group & other.filter.mask) || !(other.filter.group & b.filter.mask) || pair_excluded(slot, o))
      continue;
    const double mu = mixed_friction(b.surface, other.surface);
    if (other.shape->is_plane) {
      out.planes.push_back({.normal = other.shape->plane.normal, .offset = other.shape->plane.offset, .friction = mu});
      continue;
    }
    const Transform t = transform_of(other.rigid);
    if (!boxes_overlap(reach, slot_bounds(o))) continue;
    for (const ConvexHull& piece : other.shape->pieces) {
      if (!boxes_overlap(reach, transform_box(piece.bounds, t))) continue;
      ContactConvex convex{.faces = {}, .friction = mu};
      for (const HullFace& f : piece.faces) {
        const Vec3 n = t.rotation * f.normal;
        convex.faces.push_back({.normal = n, .offset = f.offset + n.dot(t.translation)});
      }
      out.convexes.push_back(std::move(convex));
    }
  }
  return out;
}

void World::step_deformables() {
  for (Index slot = 0; slot < body_count(); ++slot) {
    Body& b = bodies_[slot];
    if (!b.deform || !b.awake || b.removed) continue;
    Body::Deformation& d = *b.deform;
    // What the contact solver gave it through its contacts with other dynamic bodies, as impulses
    // on the nodes: each point's normal impulse there, the friction at the friction centre and the
    // twist about the normal, all summed over the step (what the other body took, reversed). The
    // moments the patches miss and the twists turn the whole body once, at the end.
    // (Its contacts with planes, static and kinematic bodies held it up in that solve, as a rigid
    // body; the FEM step below meets those obstacles itself.)
    Vec3 moment = Vec3::Zero();
    for (const Contact& ct : contacts_) {
      if (ct.body_a != slot && ct.body_b != slot) continue;
      if (bodies_[ct.body_a == slot ? ct.body_b : ct.body_a].type != BodyType::dynamic) continue;
      const ContactConstraint& cc = ct.constraint;
      if (cc.count == 0) continue;
      const double sign = ct.body_b == slot ? 1.0 : -1.0;  // the impulses act on B along +normal
      for (int i = 0; i < cc.count; ++i) {
        const ContactPoint& p = cc.points[i];
        if (p.total_normal_impulse != 0)
          moment += spread_impulse(slot, sign * p.total_normal_impulse * cc.normal, p.position);
      }
      // The friction centre: A's centre of mass at the step's start plus centre_a.
      const Vec3 centre = cc.points[0].position - cc.points[0].anchor_a + cc.centre_a;
      if (cc.total_friction_impulse.squaredNorm() > 0)
        moment += spread_impulse(slot, sign * cc.total_friction_impulse, centre);
      moment += sign * cc.total_twist_impulse * cc.normal;
    }
    turn_nodes(slot, moment);
    const DynamicObstacles obstacles = deformable_obstacles(slot);
    bool converged = true;
    for (int sub = 0; sub < d.substeps; ++sub) {
      Result<DynamicStepReport> report = d.solver->step(b.model->fem, obstacles, d.nodes);
      if (!report) {
        log_warning("world: the FEM step of deformable body " + std::to_string(slot) +
                    " failed: " + report.error().message);
        break;
      }
      stats_.deformable_newton_iterations += report->newton_iterations;
      converged = converged && report->converged;
    }
    if (!converged) ++stats_.deformable_unconverged;
    fit_deformable(slot);
  }
}

void World::step() {
  stats_ = {};
  // The last step's events go; those of calls made since (slice) stay, as this step's.
  const auto drop_front = [](auto& list, std::size_t count) {
    list.erase(list.begin(), list.begin() + static_cast<std::ptrdiff_t>(std::min(count, list.size())));
  };
  drop_front(events_.impacts, step_events_end_[0]);
  drop_front(events_.cracks, step_events_end_[1]);
  drop_front(events_.fragments, step_events_end_[2]);
  drop_front(events_.removed, step_events_end_[3]);
  advance();
  step_events_end_ = {events_.impacts.size(), events_.cracks.size(), events_.fragments.size(), events_.removed.size()};
}

void World::advance() {
  push_tools();
  // Nothing to do while every dynamic body sleeps and no kinematic body moves.
  const bool anything_moves = std::any_of(bodies_.begin(), bodies_.end(), [](const Body& b) {
    if (b.type == BodyType::dynamic) return b.awake;
    return b.type == BodyType::kinematic &&
           (b.rigid.linear_velocity.squaredNorm() > 0 || b.rigid.angular_velocity.squaredNorm() > 0);
  });
  if (anything_moves) {
    auto t0 = Clock::now();
    find_pairs(pairs_);
    stats_.body_pairs = static_cast<std::int64_t>(pairs_.size());
    stats_.broad_phase_ms = ms_since(t0);
    t0 = Clock::now();
    narrow_phase(pairs_);
    stats_.narrow_phase_ms = ms_since(t0);
    t0 = Clock::now();
    update_islands_and_wake();
    solve();
    stats_.solver_ms = ms_since(t0);
    t0 = Clock::now();
    step_deformables();
    stats_.deformable_ms = ms_since(t0);
    update_sleep();
    t0 = Clock::now();
    ++step_count_;
    process_impacts();
    process_tools();
    stats_.impact_ms = ms_since(t0);
    return;
  }
  ++step_count_;
  process_tools();
}

Index World::live_body_count() const {
  return static_cast<Index>(std::count_if(bodies_.begin(), bodies_.end(), [](const Body& b) { return !b.removed; }));
}

double World::kinetic_energy() const {
  double e = 0;
  for (const Body& b : bodies_) {
    if (b.type != BodyType::dynamic || b.removed) continue;
    if (!b.deform) {
      e += shatter::kinetic_energy(b.inertia, b.rigid);
      continue;
    }
    const std::vector<double>& m = b.model->fem.node_mass;
    for (std::size_t i = 0; i < m.size(); ++i) e += 0.5 * m[i] * b.deform->nodes.v[i].squaredNorm();
  }
  return e;
}

WorldSnapshot World::save() const {
  auto state = std::make_shared<State>();
  state->world_id = world_id_;
  state->bodies = bodies_;
  state->contacts = contacts_;
  state->excluded = excluded_;
  state->until_apart = until_apart_;
  state->open_impacts = open_impacts_;
  state->tools = tools_;
  state->step_count = step_count_;
  WorldSnapshot s;
  s.state_ = std::move(state);
  return s;
}

Result<void> World::restore(const WorldSnapshot& snapshot) {
  if (!snapshot.state_) return make_error("restore: the snapshot is empty");
  const State& s = *snapshot.state_;
  if (s.world_id != world_id_) return make_error("restore: the snapshot was taken of another world");
  bodies_ = s.bodies;
  contacts_ = s.contacts;
  excluded_ = s.excluded;
  until_apart_ = s.until_apart;
  open_impacts_ = s.open_impacts;
  tools_ = s.tools;
  step_count_ = s.step_count;
  events_ = {};
  step_events_end_ = {};
  return {};
}

std::uint64_t World::state_hash() const {
  Hasher h;
  h.add(step_count_);
  for (const Body& b : bodies_) {
    const RigidState& r = b.rigid;
    h.add(std::array<double, 13>{r.position.x(), r.position.y(), r.position.z(), r.orientation.w(), r.orientation.x(),
                                 r.orientation.y(), r.orientation.z(), r.linear_velocity.x(), r.linear_velocity.y(),
                                 r.linear_velocity.z(), r.angular_velocity.x(), r.angular_velocity.y(),
                                 r.angular_velocity.z()});
    h.add(static_cast<std::uint8_t>(b.awake));
    h.add(static_cast<std::uint8_t>(b.removed));
    h.add(b.sleep_time);
    h.add(b.parent);
    h.add(static_cast<Index>(b.plastic_strain.size()));
    for (const double e : b.plastic_strain) h.add(e);
    if (!b.tensile_strength.empty()) {  // (bodies without drawn strengths hash as before)
      h.add(static_cast<Index>(b.tensile_strength.size()));
      for (const double s : b.tensile_strength) h.add(s);
    }
    if (b.deform) {
      h.add(std::span<const Vec3>(b.deform->nodes.x));
      h.add(std::span<const Vec3>(b.deform->nodes.v));
      h.add(b.deform->max_speed);
    }
  }
  for (const Contact& c : contacts_) {
    h.add(std::array<Index, 4>{c.body_a, c.body_b, c.piece_a, c.piece_b});
    h.add(std::array<Index, 2>{c.sat.index_a, c.sat.index_b});
    h.add(c.sat.kind);
    const ContactConstraint& cc = c.constraint;
    h.add(std::array<double, 3>{cc.normal.x(), cc.normal.y(), cc.normal.z()});
    for (int i = 0; i < cc.count; ++i) {
      const ContactPoint& p = cc.points[i];
      h.add(p.feature);
      h.add(std::array<double, 6>{p.position.x(), p.position.y(), p.position.z(), p.separation, p.normal_impulse,
                                  p.total_normal_impulse});
    }
    h.add(std::array<double, 3>{cc.friction_impulse.x(), cc.friction_impulse.y(), cc.twist_impulse});
    const ContactOrigin& o = c.origin;
    h.add(o.margin);
    if (o.margin < 0) continue;
    h.add(std::array<double, 10>{o.offset.x(), o.offset.y(), o.offset.z(), o.rotation.w(), o.rotation.x(),
                                 o.rotation.y(), o.rotation.z(), o.normal_a.x(), o.normal_a.y(), o.normal_a.z()});
    for (int i = 0; i < cc.count; ++i)
      h.add(std::array<double, 6>{o.point_a[i].x(), o.point_a[i].y(), o.point_a[i].z(), o.point_b[i].x(),
                                  o.point_b[i].y(), o.point_b[i].z()});
  }
  for (const auto& p : excluded_) h.add(p);
  h.add(std::int64_t{-1});
  for (const auto& p : until_apart_) h.add(p);
  h.add(std::int64_t{-1});
  for (const Tool& t : tools_) {
    h.add(t.body);
    h.add(static_cast<std::uint8_t>(t.strike));
    h.add(std::array<double, 9>{t.local_point.x(), t.local_point.y(), t.local_point.z(), t.vector.x(), t.vector.y(),
                                t.vector.z(), t.speed, t.radius, t.remaining});
  }
  h.add(std::int64_t{-1});
  for (const OpenImpact& e : open_impacts_) {
    h.add(e.pair);
    h.add(std::array<std::int64_t, 2>{e.steps, e.analysed ? 1 : 0});
    h.add(e.approach);
    for (const OpenImpact::Point& p : e.points)
      h.add(std::array<double, 14>{p.local_a.x(), p.local_a.y(), p.local_a.z(), p.local_b.x(), p.local_b.y(),
                                   p.local_b.z(), p.normal_a.x(), p.normal_a.y(), p.normal_a.z(), p.normal_b.x(),
                                   p.normal_b.y(), p.normal_b.z(), p.impulse, p.approach});
  }
  return h.digest();
}

}  // namespace shatter
