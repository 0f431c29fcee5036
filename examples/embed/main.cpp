// Embedding shatter: mesh a glass bar, hold one end, pull the other past the glass's tensile
// strength, solve the static equilibrium, crack the bar and write its fragments.
//   embed [OUT_DIR]      (default: embed_out)
// Uses only the public headers (include/shatter/).
#include <cstdio>
#include <string>

#include "shatter/shatter.h"

int main(int argc, char** argv) {
  using namespace shatter;
  const std::string out_dir = argc > 1 ? argv[1] : "embed_out";

  // A 20 x 2 x 2 cm bar along x, about 3,000 tets (a box: the structured mesher is chosen).
  const Vec3 half(0.1, 0.01, 0.01);
  auto meshed = mesh_shape(Sdf::box(half), MeshShapeDef{.stuffing = {.target_tets = 3000}}, "bar");
  if (!meshed) {
    std::fprintf(stderr, "embed: %s\n", meshed.error().to_string().c_str());
    return 1;
  }
  const TetMesh& mesh = meshed->mesh;

  // The load case: glass, the end x = -0.1 held, 60 MPa of tension on the end x = +0.1.
  StaticCase load;
  load.name = "pulled_bar";
  load.material = material_preset("glass").value();
  load.anchors.push_back(
      AnchorSpec{.where = {.kind = NodeSelector::Kind::plane, .point = Vec3(-half.x(), 0, 0), .normal = Vec3::UnitX()},
                 .field = "anchors[0]"});
  const double area = 4 * half.y() * half.z();
  load.loads.push_back(
      LoadSpec{.where = {.kind = NodeSelector::Kind::plane, .point = Vec3(half.x(), 0, 0), .normal = Vec3::UnitX()},
               .force = Vec3(60e6 * area, 0, 0),
               .per_node = false,
               .distribution = LoadSpec::Distribution::area,
               .field = "loads[0]"});

  // Solve, crack, write.
  auto analysis = run_static_analysis(load, mesh, {.fracture = true});
  if (!analysis) {
    std::fprintf(stderr, "embed: %s\n", analysis.error().to_string().c_str());
    return 1;
  }
  if (!analysis->report.converged) {
    std::fprintf(stderr, "embed: the solver did not converge: %s (%s)\n", analysis->report.message.c_str(),
                 to_string(analysis->report.status));
    return 1;
  }
  auto written = write_static_outputs(out_dir, mesh, *analysis);
  if (!written) {
    std::fprintf(stderr, "embed: %s\n", written.error().to_string().c_str());
    return 1;
  }
  const FractureResult& broken = *analysis->fracture;
  std::printf("embed: %d tets, max principal stress %.3g Pa, %zu crack(s), %zu fragment(s) in %s\n", mesh.num_tets(),
              analysis->results.max_principal_stress, broken.events.size(), broken.fragments.size(), out_dir.c_str());
  return broken.fragments.size() >= 2 ? 0 : 1;
}
