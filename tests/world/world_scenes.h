// Scenes shared by the world tests and benchmarks: boxes, balls, towers, pyramids and piles of
// tet-meshed bodies on a ground plane.
#pragma once

#include <cmath>
#include <memory>
#include <vector>

#include "shatter/core/random.h"
#include "shatter/mesh/generate.h"
#include "shatter/rigid/body.h"
#include "shatter/world/world.h"

namespace shatter::scenes {

/// A box body model of half extents `half` (m), `cells` per axis, centred at the origin.
inline std::shared_ptr<const BodyModel> box_model(const Vec3& half, const Material& material = {},
                                                  std::array<Index, 3> cells = {1, 1, 1}) {
  const TetMesh mesh = make_box_mesh({.min = -half, .max = half, .cells = cells});
  auto model = make_body_model(mesh, material);
  return std::make_shared<const BodyModel>(std::move(*model));
}

/// A ball: a twice-subdivided icosahedron (162 surface nodes) fanned to its centre, radius r (m).
/// A vertex sits at the bottom (-y), below the centre.
inline std::shared_ptr<const BodyModel> ball_model(double r, const Material& material = {}) {
  const double t = (1 + std::sqrt(5.0)) / 2;
  std::vector<Vec3> v = {{-1, t, 0},  {1, t, 0},  {-1, -t, 0}, {1, -t, 0}, {0, -1, t},  {0, 1, t},
                         {0, -1, -t}, {0, 1, -t}, {t, 0, -1},  {t, 0, 1},  {-t, 0, -1}, {-t, 0, 1}};
  std::vector<std::array<Index, 3>> f = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                         {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                         {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                         {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (int level = 0; level < 2; ++level) {
    std::vector<std::array<Index, 3>> next;
    std::vector<std::array<Index, 3>> mids;  // (a, b, midpoint), a < b
    auto mid = [&](Index a, Index b) {
      if (a > b) std::swap(a, b);
      for (const auto& m : mids)
        if (m[0] == a && m[1] == b) return m[2];
      v.push_back(0.5 * (v[a] + v[b]));
      mids.push_back({a, b, static_cast<Index>(v.size() - 1)});
      return static_cast<Index>(v.size() - 1);
    };
    for (const auto& tri : f) {
      const Index ab = mid(tri[0], tri[1]), bc = mid(tri[1], tri[2]), ca = mid(tri[2], tri[0]);
      next.push_back({tri[0], ab, ca});
      next.push_back({tri[1], bc, ab});
      next.push_back({tri[2], ca, bc});
      next.push_back({ab, bc, ca});
    }
    f = std::move(next);
  }
  // Turn so that vertex 2 (-1, -t, 0) points straight down.
  const Quat turn = Quat::FromTwoVectors(v[2].normalized(), Vec3(0, -1, 0));
  TetMesh mesh;
  for (const Vec3& p : v) mesh.positions.push_back(r * (turn * p.normalized()));
  mesh.positions.push_back(Vec3::Zero());
  const auto centre = static_cast<Index>(mesh.positions.size() - 1);
  // Each surface triangle with the centre, ordered for a positive volume.
  for (const auto& tri : f) {
    TetIndices tet{tri[0], tri[1], tri[2], centre};
    const Vec3& a = mesh.positions[tet[0]];
    if ((mesh.positions[tet[1]] - a).cross(mesh.positions[tet[2]] - a).dot(mesh.positions[centre] - a) < 0)
      std::swap(tet[1], tet[2]);
    mesh.tets.push_back(tet);
  }
  auto model = make_body_model(mesh, material);
  return std::make_shared<const BodyModel>(std::move(*model));
}

/// Settings of the stacking scenes: sleeping as asked.
inline WorldSettings settings(bool sleep) {
  WorldSettings s;
  s.enable_sleep = sleep;
  return s;
}

/// A ground plane y = 0.
inline BodyId add_ground(World& world, const SurfaceMaterial& surface = {}) {
  return world.add_plane({Vec3::UnitY(), 0.0}, surface);
}

/// A dynamic body of `model` at `position`.
inline BodyId add_dynamic(World& world, std::shared_ptr<const BodyModel> model, const Vec3& position,
                          const SurfaceMaterial& surface = {}) {
  BodyDef def;
  def.rigid.position = position;
  def.surface = surface;
  return *world.add_body(std::move(model), def);
}

/// A tower of n cubes of edge `size` (m) standing on the ground, exactly touching.
inline std::vector<BodyId> add_tower(World& world, int n, double size) {
  auto model = box_model(Vec3::Constant(0.5 * size));
  std::vector<BodyId> ids;
  for (int i = 0; i < n; ++i) ids.push_back(add_dynamic(world, model, Vec3(0, (i + 0.5) * size, 0)));
  return ids;
}

/// A pyramid of `levels` rows of cubes of edge `size` (m) in the x-y plane (Box2D's large pyramid),
/// neighbours exactly touching.
inline std::vector<BodyId> add_pyramid(World& world, int levels, double size) {
  auto model = box_model(Vec3::Constant(0.5 * size));
  std::vector<BodyId> ids;
  for (int row = 0; row < levels; ++row)
    for (int k = 0; k < levels - row; ++k) {
      const double x = (k - 0.5 * (levels - row - 1)) * size;
      ids.push_back(add_dynamic(world, model, Vec3(x, (row + 0.5) * size, 0)));
    }
  return ids;
}

/// Box pieces of random sizes (edges in [lo, hi] m, about `tets` tets each), each rotated at random.
inline std::vector<std::shared_ptr<const BodyModel>> random_pieces(int count, double lo, double hi, int tets,
                                                                   std::uint64_t seed) {
  Random rng(seed);
  std::vector<std::shared_ptr<const BodyModel>> out;
  for (int i = 0; i < count; ++i) {
    const Vec3 extent = rng.uniform_vec3(lo, hi);
    out.push_back(box_model(0.5 * extent, {}, cells_for_tet_count(extent, tets)));
  }
  return out;
}

}  // namespace shatter::scenes
