// Displacements, stresses and their files (see static_results.h).
#include "shatter/scene/static_results.h"

#include <cstdio>
#include <ostream>

#include "shatter/core/file_io.h"
#include "shatter/fracture/stress.h"
#include "shatter/mesh/io/mesh_io.h"

namespace shatter {

StaticResults compute_static_results(const FemModel& model, const TetMesh& rest_mesh, const std::vector<Vec3>& x) {
  return compute_static_results(model, rest_mesh, x, compute_stresses(model, x));
}

StaticResults compute_static_results(const FemModel& model, const TetMesh& rest_mesh, const std::vector<Vec3>& x,
                                     const std::vector<TetStress>& stress) {
  SHATTER_CHECK(x.size() == rest_mesh.positions.size());
  SHATTER_CHECK(model.num_tets() == rest_mesh.num_tets());
  StaticResults r;
  const std::size_t n = x.size();
  r.displacement.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    r.displacement[i] = x[i] - rest_mesh.positions[i];
    const double d = r.displacement[i].norm();
    if (r.max_displacement_node < 0 || d > r.max_displacement) {
      r.max_displacement = d;
      r.max_displacement_node = static_cast<Index>(i);
    }
  }
  SHATTER_CHECK(static_cast<Index>(stress.size()) == model.num_tets());
  const auto m = stress.size();
  r.stress.resize(m);
  r.max_principal.resize(m);
  r.max_direction.resize(m);
  r.von_mises.resize(m);
  for (std::size_t e = 0; e < m; ++e) {
    const TetStress& s = stress[e];
    r.stress[e] = s.sigma;
    r.max_principal[e] = s.principal[0];
    r.max_direction[e] = s.directions.col(0);
    r.von_mises[e] = s.von_mises;
    const auto ei = static_cast<Index>(e);
    if (r.max_principal_tet < 0 || s.principal[0] > r.max_principal_stress) {
      r.max_principal_stress = s.principal[0];
      r.max_principal_tet = ei;
    }
    if (r.max_von_mises_tet < 0 || r.von_mises[e] > r.max_von_mises) {
      r.max_von_mises = r.von_mises[e];
      r.max_von_mises_tet = ei;
    }
  }
  return r;
}

namespace {

void put(std::ostream& out, double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, ",%.17g", v);
  out << buf;
}

}  // namespace

Result<void> write_displacements_csv(const std::string& path, const TetMesh& mesh, const StaticResults& r) {
  return write_file_atomic(path, [&](std::ostream& out) -> Result<void> {
    out << "node_id,ux,uy,uz\n";
    for (Index i = 0; i < mesh.num_nodes(); ++i) {
      out << mesh.node_id(i);
      for (int k = 0; k < 3; ++k) put(out, r.displacement[i][k]);
      out << '\n';
    }
    return {};
  });
}

Result<void> write_elements_csv(const std::string& path, const TetMesh& mesh, const StaticResults& r) {
  return write_file_atomic(path, [&](std::ostream& out) -> Result<void> {
    out << "element_id,sxx,syy,szz,sxy,syz,szx,max_principal,dir_x,dir_y,dir_z,von_mises\n";
    for (Index e = 0; e < mesh.num_tets(); ++e) {
      const Mat3& s = r.stress[e];
      out << mesh.tet_id(e);
      for (double v : {s(0, 0), s(1, 1), s(2, 2), s(0, 1), s(1, 2), s(2, 0)}) put(out, v);
      put(out, r.max_principal[e]);
      for (int k = 0; k < 3; ++k) put(out, r.max_direction[e][k]);
      put(out, r.von_mises[e]);
      out << '\n';
    }
    return {};
  });
}

Result<void> write_result_mesh(const std::string& path, const TetMesh& mesh, const StaticResults& r) {
  MeshWriteOptions options;
  MeshField disp{.name = "displacement", .components = 3, .values = {}};
  MeshField node_id{.name = "node_id", .components = 1, .values = {}};
  for (Index i = 0; i < mesh.num_nodes(); ++i) {
    for (int k = 0; k < 3; ++k) disp.values.push_back(r.displacement[i][k]);
    node_id.values.push_back(static_cast<double>(mesh.node_id(i)));
  }
  MeshField stress{.name = "stress", .components = 6, .values = {}};
  MeshField principal{.name = "max_principal", .components = 1, .values = {}};
  MeshField direction{.name = "max_principal_direction", .components = 3, .values = {}};
  MeshField vm{.name = "von_mises", .components = 1, .values = {}};
  MeshField tet_id{.name = "tet_id", .components = 1, .values = {}};
  for (Index e = 0; e < mesh.num_tets(); ++e) {
    const Mat3& s = r.stress[e];
    for (double v : {s(0, 0), s(1, 1), s(2, 2), s(0, 1), s(1, 2), s(2, 0)}) stress.values.push_back(v);
    principal.values.push_back(r.max_principal[e]);
    for (int k = 0; k < 3; ++k) direction.values.push_back(r.max_direction[e][k]);
    vm.values.push_back(r.von_mises[e]);
    tet_id.values.push_back(static_cast<double>(mesh.tet_id(e)));
  }
  options.fields.node_fields = {std::move(disp), std::move(node_id)};
  options.fields.tet_fields = {std::move(stress), std::move(principal), std::move(direction), std::move(vm),
                               std::move(tet_id)};
  return write_mesh(path, mesh, options);
}

}  // namespace shatter
