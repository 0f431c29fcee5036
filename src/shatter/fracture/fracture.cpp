// Stresses, plasticity, cracks and fragments of one body in one call (see fracture.h).
#include "shatter/fracture/fracture.h"

#include <numeric>
#include <utility>

#include "shatter/core/assert.h"

namespace shatter {

FractureResult fracture(const TetMesh& rest, const FemModel& model, const std::vector<Vec3>& deformed,
                        const FractureOptions& options) {
  return fracture_with_stress(rest, model, deformed, compute_stresses(model, deformed), options);
}

FractureResult fracture_with_stress(const TetMesh& rest, const FemModel& model, const std::vector<Vec3>& deformed,
                                    std::vector<TetStress> stress, const FractureOptions& options) {
  SHATTER_CHECK(deformed.size() == rest.positions.size() && stress.size() == rest.tets.size());
  SHATTER_CHECK(model.num_tets() == rest.num_tets() && model.num_nodes == rest.num_nodes());
  const Material& material = model.material;
  FractureResult r;
  r.stress = std::move(stress);
  r.plastic = apply_plasticity(model, rest.positions, deformed, r.stress, options.plastic_strain, options.plasticity);
  r.mesh = rest;
  r.mesh.positions = r.plastic.rest_positions;
  r.deformed = deformed;
  r.plastic_strain = r.plastic.plastic_strain;
  r.node_parent.resize(rest.positions.size());
  std::iota(r.node_parent.begin(), r.node_parent.end(), Index(0));
  r.tet_parent.resize(rest.tets.size());
  std::iota(r.tet_parent.begin(), r.tet_parent.end(), Index(0));

  // Face neighbours of the mesh being cut, from the plans' regions and carried from cut to cut
  // (below): each crack's region grows in them, searching only what they do not know.
  FaceNeighborTable known;
  const std::vector<CrackPlan> plans = plan_cracks(r.mesh, r.stress, material, options.crack, r.plastic.failed,
                                                   options.tensile_strength, options.faces, &known, PlanRegions::first);
  for (std::size_t k = 0; k < plans.size(); ++k) {
    CrackEvent ev;
    ev.plan = plans[k];
    const std::vector<Index> region =
        k == 0 ? plans[k].tets : crack_region(r.mesh, known, plans[k].origin_tet, plans[k].origin, plans[k].radius);
    CutResult cut = cut_mesh(r.mesh, {.point = plans[k].origin, .normal = plans[k].normal}, region, options.cut);
    // Carrying the neighbours costs a pass over the mesh (about 16 ns a tet here); searching them,
    // about 100 ns per tet of the next region. Carried when the next crack's region is likely over
    // an eighth of the mesh: its planned region when planned (without branching), else this
    // crack's region (branches of one blow have alike radii). The same neighbours either way.
    if (k + 1 < plans.size()) {
      const std::size_t next = options.crack.branch ? region.size() : plans[k + 1].tets.size();
      known = next * 8 >= r.mesh.tets.size() ? carry_face_neighbors(r.mesh, known, cut)
                                             : unknown_face_neighbors(cut.mesh.num_tets());
    }
    ev.tets_marked = static_cast<Index>(region.size());
    ev.tets_split = cut.tets_split;
    ev.edge_nodes = cut.edge_nodes;
    ev.nodes_duplicated = cut.nodes_duplicated;
    ev.faces_cut = cut.faces_cut;
    // Carry per-node and per-tet data through the cut.
    std::vector<Vec3> x(cut.node_origin.size());
    std::vector<Index> np(cut.node_origin.size());
    for (std::size_t i = 0; i < x.size(); ++i) {
      const NodeOrigin& o = cut.node_origin[i];
      x[i] = o.a == o.b ? r.deformed[o.a] : Vec3((1.0 - o.t) * r.deformed[o.a] + o.t * r.deformed[o.b]);
      np[i] = r.node_parent[o.t <= 0.5 ? o.a : o.b];
    }
    std::vector<Index> tp(cut.tet_parent.size());
    std::vector<double> ps(cut.tet_parent.size());
    for (std::size_t e = 0; e < tp.size(); ++e) {
      tp[e] = r.tet_parent[cut.tet_parent[e]];
      ps[e] = r.plastic_strain[cut.tet_parent[e]];
    }
    r.mesh = std::move(cut.mesh);
    r.deformed = std::move(x);
    r.node_parent = std::move(np);
    r.tet_parent = std::move(tp);
    r.plastic_strain = std::move(ps);
    r.events.push_back(std::move(ev));
  }
  r.fragments = extract_fragments(r.mesh, material.density);
  return r;
}

}  // namespace shatter
