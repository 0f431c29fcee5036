// Embedding shatter's world: a porcelain vase dropped 1.5 m onto stone, tilted, shatters; its
// largest piece is then struck with a hammer. Prints the events of every step.
//   drop VASE_MESH        (e.g. assets/meshes/vase.msh)
// Uses only the public headers (include/shatter/). Exit status 0 when the vase broke.
#include <cstdio>
#include <memory>
#include <string>

#include "shatter/shatter.h"

int main(int argc, char** argv) {
  using namespace shatter;
  if (argc < 2) {
    std::fprintf(stderr, "usage: drop VASE_MESH\n");
    return 2;
  }
  // A simulation frees and reallocates large arrays at every impact: keep that memory in the
  // process (see shatter/core/memory.h).
  keep_freed_memory();
  auto read = read_mesh(argv[1]);
  if (!read) {
    std::fprintf(stderr, "drop: %s\n", read.error().to_string().c_str());
    return 1;
  }
  RigidState pose;  // where the mesh lies: its centre of mass
  auto model = make_body_model(read->mesh, material_preset("porcelain").value(), ModelKind::stvk, &pose);
  if (!model) {
    std::fprintf(stderr, "drop: %s\n", model.error().to_string().c_str());
    return 1;
  }
  pose.position.y() += 1.5;
  pose.orientation = Quat(Eigen::AngleAxisd(0.6, Vec3(1, 0, 1).normalized()));

  World world;  // 1/60 s steps, gravity -y
  world.add_plane({.normal = Vec3::UnitY(), .offset = 0.0});
  auto vase = world.add_body(std::make_shared<const BodyModel>(std::move(*model)), {.rigid = pose});
  if (!vase) {
    std::fprintf(stderr, "drop: %s\n", vase.error().to_string().c_str());
    return 1;
  }
  auto report = [&](const StepEvents& ev) {
    for (const ImpactRecord& e : ev.impacts)
      std::printf("t %.3f s  body %d hit at %.2f m/s: load %.3g N, max tension %.3g Pa, %d crack(s), %d piece(s)\n",
                  e.time, static_cast<int>(e.body.index), e.approach_speed, e.force, e.max_principal_stress,
                  static_cast<int>(e.cracks), static_cast<int>(e.fragments));
    for (const FragmentRecord& f : ev.fragments)
      std::printf("          body %d born from %d, %.3f kg\n", static_cast<int>(f.body.index),
                  static_cast<int>(f.parent.index), f.mass);
  };
  for (int i = 0; i < 90; ++i) {
    world.step();
    report(world.events());
  }
  const bool broke = world.removed(*vase);

  // Strike the heaviest piece with a 0.5 kg hammer at 10 m/s from the side.
  BodyId heaviest;
  double mass = 0;
  for (Index slot = 0; slot < world.body_count(); ++slot) {
    const BodyId id = world.body_id(slot);
    if (world.removed(id) || !world.model(id) || world.model(id)->mass.mass <= mass) continue;
    heaviest = id;
    mass = world.model(id)->mass.mass;
  }
  const BodySurface surface = world.surface(heaviest);
  Vec3 side = surface.positions.front();
  for (const Vec3& p : surface.positions)
    if (p.x() < side.x()) side = p;
  if (auto struck = world.strike(heaviest, side, Vec3(5, 0, 0), 10); !struck) {
    std::fprintf(stderr, "drop: %s\n", struck.error().to_string().c_str());
    return 1;
  }
  for (int i = 0; i < 30; ++i) {
    world.step();
    report(world.events());
  }
  std::printf("drop: %d bodies live, state hash %016llx\n", static_cast<int>(world.live_body_count()) - 1,
              static_cast<unsigned long long>(world.state_hash()));
  return broke ? 0 : 1;
}
