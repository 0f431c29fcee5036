// Fracture outputs of a static analysis (see static_fracture.h).
#include "shatter/scene/static_fracture.h"

#include <algorithm>
#include <cstdio>
#include <ostream>
#include <string>

#include "shatter/core/file_io.h"
#include "shatter/mesh/io/mesh_io.h"

namespace shatter {
namespace {

// A copy of `mesh` whose ids are stored explicitly (default ids i + 1 made concrete).
TetMesh with_explicit_ids(const TetMesh& mesh) {
  TetMesh m = mesh;
  m.node_ids.resize(static_cast<std::size_t>(mesh.num_nodes()));
  for (Index i = 0; i < mesh.num_nodes(); ++i) m.node_ids[static_cast<std::size_t>(i)] = mesh.node_id(i);
  m.tet_ids.resize(static_cast<std::size_t>(mesh.num_tets()));
  for (Index e = 0; e < mesh.num_tets(); ++e) m.tet_ids[static_cast<std::size_t>(e)] = mesh.tet_id(e);
  return m;
}

void append_g(std::string& s, double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  s += buf;
}

}  // namespace

std::vector<Index> fragment_of_tets(const FractureResult& r) {
  std::vector<Index> out(static_cast<std::size_t>(r.mesh.num_tets()), -1);
  for (std::size_t k = 0; k < r.fragments.size(); ++k)
    for (Index e : r.fragments[k].tet_map) out[static_cast<std::size_t>(e)] = static_cast<Index>(k);
  return out;
}

TetMesh fragment_mesh_with_ids(const FractureResult& r, std::size_t k) {
  const Fragment& f = r.fragments[k];
  TetMesh m = f.mesh;
  m.node_ids.resize(f.node_map.size());
  for (std::size_t i = 0; i < f.node_map.size(); ++i) m.node_ids[i] = r.mesh.node_id(f.node_map[i]);
  m.tet_ids.resize(f.tet_map.size());
  for (std::size_t e = 0; e < f.tet_map.size(); ++e) m.tet_ids[e] = r.mesh.tet_id(f.tet_map[e]);
  return m;
}

double max_plastic_strain(const FractureResult& r) {
  double m = 0;
  for (double v : r.plastic_strain) m = std::max(m, v);
  return m;
}

Result<void> write_fragments_mesh(const std::string& path, const TetMesh& input, const FractureResult& r) {
  const TetMesh mesh = with_explicit_ids(r.mesh);
  const std::size_t nn = static_cast<std::size_t>(mesh.num_nodes());
  const std::size_t ne = static_cast<std::size_t>(mesh.num_tets());
  MeshWriteOptions options;
  MeshField disp{"displacement", 3, std::vector<double>(3 * nn)};
  for (std::size_t i = 0; i < nn; ++i)
    for (int c = 0; c < 3; ++c) disp.values[3 * i + c] = r.deformed[i][c] - mesh.positions[i][c];
  options.fields.node_fields.push_back(std::move(disp));

  const std::vector<Index> fragment = fragment_of_tets(r);
  MeshField fid{"fragment_id", 1, std::vector<double>(ne)};
  MeshField display{"display_stress", 1, std::vector<double>(ne)};
  MeshField sigma1{"max_principal", 1, std::vector<double>(ne)};
  MeshField vm{"von_mises", 1, std::vector<double>(ne)};
  MeshField eps{"plastic_strain", 1, std::vector<double>(ne)};
  MeshField parent{"parent_tet_id", 1, std::vector<double>(ne)};
  for (std::size_t e = 0; e < ne; ++e) {
    const Index p = r.tet_parent[e];
    const TetStress& s = r.stress[static_cast<std::size_t>(p)];
    fid.values[e] = static_cast<double>(fragment[e]);
    display.values[e] = s.display;
    sigma1.values[e] = s.principal[0];
    vm.values[e] = s.von_mises;
    eps.values[e] = r.plastic_strain.empty() ? 0.0 : r.plastic_strain[e];
    parent.values[e] = static_cast<double>(input.tet_id(p));
  }
  for (MeshField* f : {&fid, &display, &sigma1, &vm, &eps, &parent}) options.fields.tet_fields.push_back(std::move(*f));
  return write_mesh(path, mesh, options);
}

Result<void> write_cracks_csv(const std::string& path, const TetMesh& input, const FractureResult& r) {
  std::string s =
      "crack,origin_element_id,x,y,z,nx,ny,nz,radius,stress,ductile,tets_marked,tets_split,edge_nodes,"
      "nodes_duplicated,faces_cut\n";
  for (std::size_t k = 0; k < r.events.size(); ++k) {
    const CrackEvent& ev = r.events[k];
    const CrackPlan& p = ev.plan;
    s += std::to_string(k) + "," + std::to_string(input.tet_id(p.origin_tet));
    for (double v :
         {p.origin.x(), p.origin.y(), p.origin.z(), p.normal.x(), p.normal.y(), p.normal.z(), p.radius, p.stress}) {
      s += ",";
      append_g(s, v);
    }
    s += p.ductile ? ",1" : ",0";
    for (Index v : {ev.tets_marked, ev.tets_split, ev.edge_nodes, ev.nodes_duplicated, ev.faces_cut})
      s += "," + std::to_string(v);
    s += "\n";
  }
  return write_file_atomic(path, s);
}

Result<void> write_rest_shape(const std::string& path, const FractureResult& r) {
  const TetMesh mesh = with_explicit_ids(r.mesh);
  MeshWriteOptions options;
  MeshField eps{"plastic_strain", 1, r.plastic_strain};
  eps.values.resize(static_cast<std::size_t>(mesh.num_tets()), 0.0);
  options.fields.tet_fields.push_back(std::move(eps));
  return write_mesh(path, mesh, options);
}

}  // namespace shatter
