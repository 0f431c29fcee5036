// Parsing CASE.json into a StaticCase and resolving it against a mesh (see static_case.h).
#include "shatter/scene/static_case.h"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>

#include "shatter/core/file_io.h"
#include "shatter/core/json_reader.h"
#include "shatter/mesh/topology.h"
#include "shatter/scene/material_json.h"

namespace shatter {
namespace {

using json_input::Json;
using json_input::ObjectReader;
using json_input::Where;

constexpr double kStandardGravity = 9.81;  // m/s^2

// "xyz", "x", "yz", ... -> bits.
Result<std::uint8_t> read_components(const Json& value, const Where& where) {
  SHATTER_TRY(s, json_input::read_string(value, where));
  std::uint8_t mask = 0;
  for (char ch : *s) {
    const int c = ch == 'x' ? 0 : ch == 'y' ? 1 : ch == 'z' ? 2 : -1;
    if (c < 0 || (mask & (1u << c)))
      return where.error(
          "expected a non-empty combination of the letters x, y, z, each at most once "
          "(\"xyz\", \"x\", \"yz\", ...), got \"" +
          *s + "\"");
    mask = static_cast<std::uint8_t>(mask | (1u << c));
  }
  if (mask == 0) return where.error("expected at least one of x, y, z, got an empty string");
  return mask;
}

// {min, max}
Result<Aabb> read_box(const Json& value, const Where& where) {
  ObjectReader r(value, where);
  if (!r.status().ok()) return r.status().error();
  const Json* jmin = r.get("min");
  const Json* jmax = r.get("max");
  SHATTER_TRY(done, r.finish());
  if (!jmin) return where.key("min").error("missing; expected [x, y, z], the box's lowest corner (m)");
  if (!jmax) return where.key("max").error("missing; expected [x, y, z], the box's highest corner (m)");
  SHATTER_TRY(lo, json_input::read_vec3(*jmin, where.key("min")));
  SHATTER_TRY(hi, json_input::read_vec3(*jmax, where.key("max")));
  for (int k = 0; k < 3; ++k)
    if ((*lo)[k] > (*hi)[k])
      return where.error("min must not exceed max in any axis (axis " + std::string(1, "xyz"[k]) + ")");
  Aabb box;
  box.min = *lo;
  box.max = *hi;
  return box;
}

// One of nodes / box / plane / set in the object read by `r`.
Result<NodeSelector> read_selector(ObjectReader& r) {
  const Where& where = r.where();
  const Json* jnodes = r.get("nodes");
  const Json* jbox = r.get("box");
  const Json* jplane = r.get("plane");
  const Json* jset = r.get("set");
  const int count = (jnodes != nullptr) + (jbox != nullptr) + (jplane != nullptr) + (jset != nullptr);
  if (count == 0)
    return where.error(
        "expected one of \"nodes\" (a list of node ids), \"box\" ({min, max}), "
        "\"plane\" ({point, normal, tolerance}) or \"set\" (a node set name)");
  if (count > 1) return where.error("give only one of \"nodes\", \"box\", \"plane\", \"set\"");
  NodeSelector s;
  if (jnodes) {
    s.kind = NodeSelector::Kind::ids;
    const Where w = where.key("nodes");
    SHATTER_TRY(arr, json_input::read_array(*jnodes, w));
    if ((*arr)->empty()) return w.error("expected a non-empty list of node ids");
    for (std::size_t i = 0; i < (*arr)->size(); ++i) {
      SHATTER_TRY(id, json_input::read_integer((**arr)[i], w.index(i)));
      s.ids.push_back(*id);
    }
  } else if (jbox) {
    s.kind = NodeSelector::Kind::box;
    SHATTER_TRY(box, read_box(*jbox, where.key("box")));
    s.box = *box;
    if (const Json* jt = r.get("tolerance")) {
      SHATTER_TRY(t, json_input::read_non_negative(*jt, where.key("tolerance")));
      s.tolerance = *t;
    }
  } else if (jplane) {
    s.kind = NodeSelector::Kind::plane;
    const Where w = where.key("plane");
    ObjectReader p(*jplane, w);
    if (!p.status().ok()) return p.status().error();
    const Json* jpoint = p.get("point");
    const Json* jnormal = p.get("normal");
    const Json* jtol = p.get("tolerance");
    SHATTER_TRY(done, p.finish());
    if (!jpoint) return w.key("point").error("missing; expected [x, y, z], a point on the plane (m)");
    if (!jnormal) return w.key("normal").error("missing; expected [nx, ny, nz], the plane's normal");
    SHATTER_TRY(point, json_input::read_vec3(*jpoint, w.key("point")));
    SHATTER_TRY(normal, json_input::read_vec3(*jnormal, w.key("normal")));
    if (!(normal->norm() > 0)) return w.key("normal").error("expected a non-zero vector");
    s.point = *point;
    s.normal = normal->normalized();
    if (jtol) {
      SHATTER_TRY(t, json_input::read_non_negative(*jtol, w.key("tolerance")));
      s.tolerance = *t;
    }
  } else {
    s.kind = NodeSelector::Kind::set;
    SHATTER_TRY(name, json_input::read_string(*jset, where.key("set")));
    s.set = *name;
  }
  return s;
}

Result<AnchorSpec> read_anchor(const Json& value, const Where& where) {
  ObjectReader r(value, where);
  if (!r.status().ok()) return r.status().error();
  r.allow({"tolerance"});  // only meaningful with "box"; read_selector reads it there
  SHATTER_TRY(selector, read_selector(r));
  AnchorSpec a;
  a.where = std::move(*selector);
  a.field = where.path;
  if (const Json* jc = r.get("components")) {
    SHATTER_TRY(mask, read_components(*jc, where.key("components")));
    a.components = *mask;
  }
  if (const Json* jd = r.get("displacement")) {
    SHATTER_TRY(d, json_input::read_vec3(*jd, where.key("displacement")));
    a.displacement = *d;
  }
  if (r.has("tolerance") && a.where.kind != NodeSelector::Kind::box)
    return where.key("tolerance").error("only allowed with \"box\" (a plane takes its own plane.tolerance)");
  SHATTER_TRY(done, r.finish());
  return a;
}

Result<LoadSpec> read_load(const Json& value, const Where& where) {
  ObjectReader r(value, where);
  if (!r.status().ok()) return r.status().error();
  r.allow({"tolerance"});
  SHATTER_TRY(selector, read_selector(r));
  LoadSpec l;
  l.where = std::move(*selector);
  l.field = where.path;
  const Json* jforce = r.get("force");
  const Json* jtotal = r.get("total_force");
  const Json* jdist = r.get("distribution");
  if ((jforce != nullptr) == (jtotal != nullptr))
    return where.error(
        "expected exactly one of \"force\" ([fx, fy, fz] N on each selected node) or "
        "\"total_force\" ([fx, fy, fz] N spread over the selected nodes)");
  if (jforce) {
    SHATTER_TRY(f, json_input::read_vec3(*jforce, where.key("force")));
    l.force = *f;
    l.per_node = true;
    if (jdist) return where.key("distribution").error("only allowed with \"total_force\"");
  } else {
    SHATTER_TRY(f, json_input::read_vec3(*jtotal, where.key("total_force")));
    l.force = *f;
    l.per_node = false;
  }
  if (jdist) {
    SHATTER_TRY(d, json_input::read_string(*jdist, where.key("distribution")));
    if (*d == "equal")
      l.distribution = LoadSpec::Distribution::equal;
    else if (*d == "area")
      l.distribution = LoadSpec::Distribution::area;
    else
      return where.key("distribution").error("expected \"equal\" or \"area\", got \"" + *d + "\"");
  }
  if (r.has("tolerance") && l.where.kind != NodeSelector::Kind::box)
    return where.key("tolerance").error("only allowed with \"box\" (a plane takes its own plane.tolerance)");
  SHATTER_TRY(done, r.finish());
  return l;
}

// "glass" | {"preset": "glass", "youngs_modulus": ...} | {"youngs_modulus": ..., ...}
Result<CaseSolverSettings> read_solver(const Json& value, const Where& where) {
  ObjectReader r(value, where);
  if (!r.status().ok()) return r.status().error();
  CaseSolverSettings s;
  if (const Json* j = r.get("linear_solver")) {
    SHATTER_TRY(v, json_input::read_string(*j, where.key("linear_solver")));
    auto kind = parse_linear_solver_kind(*v);
    if (!kind.ok()) return where.key("linear_solver").error(kind.error().message);
    s.linear_solver = *kind;
  }
  if (const Json* j = r.get("tolerance")) {
    SHATTER_TRY(v, json_input::read_positive(*j, where.key("tolerance")));
    s.tolerance = *v;
  }
  if (const Json* j = r.get("linear_tolerance")) {
    SHATTER_TRY(v, json_input::read_positive(*j, where.key("linear_tolerance")));
    s.linear_tolerance = *v;
  }
  if (const Json* j = r.get("linear_max_iterations")) {
    SHATTER_TRY(v, json_input::read_integer(*j, where.key("linear_max_iterations")));
    if (*v < 1 || *v > 10000000) return where.key("linear_max_iterations").error("expected an integer in 1..10000000");
    s.linear_max_iterations = *v;
  }
  if (const Json* j = r.get("max_iterations")) {
    SHATTER_TRY(v, json_input::read_integer(*j, where.key("max_iterations")));
    if (*v < 1 || *v > 100000) return where.key("max_iterations").error("expected an integer in 1..100000");
    s.max_iterations = *v;
  }
  if (const Json* j = r.get("load_steps")) {
    SHATTER_TRY(v, json_input::read_integer(*j, where.key("load_steps")));
    if (*v < 1 || *v > 100000) return where.key("load_steps").error("expected an integer in 1..100000");
    s.load_steps = *v;
  }
  if (const Json* j = r.get("line_search")) {
    SHATTER_TRY(v, json_input::read_bool(*j, where.key("line_search")));
    s.line_search = *v;
  }
  if (const Json* j = r.get("tangent")) {
    SHATTER_TRY(v, json_input::read_string(*j, where.key("tangent")));
    auto kind = parse_tangent_kind(*v);
    if (!kind.ok()) return where.key("tangent").error(kind.error().message);
    s.tangent = *kind;
  }
  SHATTER_TRY(done, r.finish());
  return s;
}

// "fracture": {...} -> FractureOptions (crack planning, cutting, plasticity). Every key optional.
Result<FractureOptions> read_fracture(const Json& value, const Where& where) {
  ObjectReader r(value, where);
  if (!r.status().ok()) return r.status().error();
  FractureOptions o;
  // A number with a range check; `what` describes the accepted range in messages.
  const auto number = [&](const char* key, double lo, double hi, bool lo_open, bool hi_open, const char* what,
                          double& target) -> Result<void> {
    const Json* j = r.get(key);
    if (!j) return {};
    // "inf" where the range reaches infinity (e.g. a plastic strain that never tears).
    if (j->is_string() && j->get<std::string>() == "inf" && hi == kInfinity && !hi_open) {
      target = kInfinity;
      return {};
    }
    SHATTER_TRY(v, json_input::read_number(*j, where.key(key)));
    const bool ok = (lo_open ? *v > lo : *v >= lo) && (hi_open ? *v < hi : *v <= hi);
    if (!ok) {
      char got[32];
      std::snprintf(got, sizeof got, "%.6g", *v);
      return where.key(key).error(std::string("expected ") + what + ", got " + got);
    }
    target = *v;
    return {};
  };
  const double inf = kInfinity;
  if (const Json* j = r.get("max_cracks")) {
    SHATTER_TRY(v, json_input::read_integer(*j, where.key("max_cracks")));
    if (*v < 0 || *v > 10000) return where.key("max_cracks").error("expected an integer in 0..10000");
    o.crack.max_cracks = static_cast<int>(*v);
  }
  SHATTER_TRY(a, number("brittleness", 0, inf, false, true,
                        "a finite number >= 0 (0: derived from the material's toughness)", o.crack.brittleness));
  SHATTER_TRY(b, number("radius_fraction", 0, inf, true, true, "a finite number > 0", o.crack.radius_fraction));
  SHATTER_TRY(c, number("min_radius_edges", 0, inf, false, true, "a finite number >= 0", o.crack.min_radius_edges));
  SHATTER_TRY(d, number("separation", 0, inf, false, true, "a finite number >= 0", o.crack.separation));
  if (const Json* j = r.get("split_tets")) {
    SHATTER_TRY(v, json_input::read_bool(*j, where.key("split_tets")));
    o.cut.split_tets = *v;
  }
  SHATTER_TRY(e, number("snap_fraction", 0, 0.5, false, true, "a number in [0, 0.5)", o.cut.snap_fraction));
  SHATTER_TRY(f, number("min_piece_fraction", 0, 0.5, false, true, "a number in [0, 0.5)", o.cut.min_volume_fraction));
  if (const Json* j = r.get("plasticity")) {
    SHATTER_TRY(v, json_input::read_bool(*j, where.key("plasticity")));
    o.plasticity.enabled = *v;
  }
  SHATTER_TRY(g, number("creep", 0, 1, false, false, "a number in [0, 1]", o.plasticity.creep));
  SHATTER_TRY(h, number("max_plastic_strain", 0, inf, true, false, "a number > 0 (or \"inf\": never tears)",
                        o.plasticity.max_plastic_strain));
  SHATTER_TRY(
      k, number("min_rest_volume_fraction", 0, 1, true, true, "a number in (0, 1)", o.plasticity.min_volume_fraction));
  SHATTER_TRY(done, r.finish());
  return o;
}

}  // namespace

Result<Material> read_material_json(const Json& value, const Where& where) {
  if (value.is_string()) {
    SHATTER_TRY(name, json_input::read_string(value, where));
    auto m = material_preset(*name);
    if (!m.ok()) return where.error(m.error().message);
    return std::move(*m);
  }
  ObjectReader r(value, where);
  if (!r.status().ok())
    return where.error("expected a preset name (a string) or an object with material values, got " +
                       json_input::type_name(value));
  // Without a preset only what the file gives counts: the strengths and toughness start unknown.
  Material m;
  m.tensile_strength = kInfinity;
  m.yield_stress = kInfinity;
  m.fracture_toughness = kInfinity;
  bool from_preset = false;
  if (const Json* jp = r.get("preset")) {
    SHATTER_TRY(name, json_input::read_string(*jp, where.key("preset")));
    auto preset = material_preset(*name);
    if (!preset.ok()) return where.key("preset").error(preset.error().message);
    m = std::move(*preset);
    from_preset = true;
  }
  if (const Json* jn = r.get("name")) {
    SHATTER_TRY(name, json_input::read_string(*jn, where.key("name")));
    m.name = *name;
  } else if (!from_preset) {
    m.name = "custom";
  }
  struct Num {
    const char* key;
    double* target;
    bool required;  // without a preset
  };
  const Num nums[] = {
      {"youngs_modulus", &m.youngs_modulus, true},
      {"poisson_ratio", &m.poisson_ratio, true},
      {"density", &m.density, true},
      {"tensile_strength", &m.tensile_strength, false},
      {"yield_stress", &m.yield_stress, false},
      {"fracture_toughness", &m.fracture_toughness, false},
      {"weibull_modulus", &m.weibull_modulus, false},
  };
  bool overridden = false;
  for (const Num& n : nums) {
    const Json* j = r.get(n.key);
    if (!j) {
      if (n.required && !from_preset)
        return where.key(n.key).error(
            "missing; a material without \"preset\" needs youngs_modulus (Pa), "
            "poisson_ratio and density (kg/m^3)");
      continue;
    }
    // Strengths may be "inf" (never cracks / never yields).
    if (j->is_string() && j->get<std::string>() == "inf" && !n.required) {
      *n.target = kInfinity;
    } else {
      SHATTER_TRY(v, json_input::read_number(*j, where.key(n.key)));
      *n.target = *v;
    }
    overridden = true;
  }
  if (from_preset && overridden && !r.has("name")) m.name += " (modified)";
  SHATTER_TRY(done, r.finish());
  auto valid = validate_material(m);
  if (!valid.ok()) {
    const std::string& f = valid.error().field;
    return (f.empty() ? where : where.key(f)).error(valid.error().message);
  }
  return m;
}

Result<StaticCase> parse_static_case(std::string_view json_text, const std::string& file) {
  SHATTER_TRY(doc, json_input::parse_json(json_text, file));
  const Where root{&file, ""};
  ObjectReader r(*doc, root);
  if (!r.status().ok()) return r.status().error();
  StaticCase c;
  c.file = file;
  c.name = std::filesystem::path(file).stem().string();
  r.allow({"description"});
  // Unknown keys first: a misspelt "anchors" reads better as a typo than as a missing key.
  for (const char* key : {"name", "material", "model", "anchors", "loads", "gravity", "solver", "fracture"})
    (void)r.get(key);
  SHATTER_TRY(known, r.finish());
  if (const Json* j = r.get("name")) {
    SHATTER_TRY(v, json_input::read_string(*j, root.key("name")));
    c.name = *v;
  }
  const Json* jmat = r.get("material");
  if (!jmat) {
    const std::vector<std::string> names = material_preset_names();
    std::string list;
    for (const std::string& n : names) list += (list.empty() ? "" : ", ") + n;
    return root.key("material")
        .error("missing; expected a preset name (" + list +
               ") or an object with youngs_modulus, poisson_ratio, density");
  }
  SHATTER_TRY(material, read_material_json(*jmat, root.key("material")));
  c.material = std::move(*material);
  if (const Json* j = r.get("model")) {
    SHATTER_TRY(v, json_input::read_string(*j, root.key("model")));
    auto kind = parse_model_kind(*v);
    if (!kind.ok()) return root.key("model").error(kind.error().message);
    c.model = *kind;
  }
  const Json* janchors = r.get("anchors");
  if (!janchors)
    return root.key("anchors").error(
        "missing; a static case needs anchors, or the body could move "
        "freely (rigid motion)");
  {
    const Where w = root.key("anchors");
    SHATTER_TRY(arr, json_input::read_array(*janchors, w));
    if ((*arr)->empty()) return w.error("expected at least one anchor, or the body could move freely (rigid motion)");
    for (std::size_t i = 0; i < (*arr)->size(); ++i) {
      SHATTER_TRY(a, read_anchor((**arr)[i], w.index(i)));
      c.anchors.push_back(std::move(*a));
    }
  }
  if (const Json* jl = r.get("loads")) {
    const Where w = root.key("loads");
    SHATTER_TRY(arr, json_input::read_array(*jl, w));
    for (std::size_t i = 0; i < (*arr)->size(); ++i) {
      SHATTER_TRY(l, read_load((**arr)[i], w.index(i)));
      c.loads.push_back(std::move(*l));
    }
  }
  if (const Json* jg = r.get("gravity")) {
    const Where w = root.key("gravity");
    if (jg->is_boolean()) {
      c.gravity = jg->get<bool>() ? Vec3(0, -kStandardGravity, 0) : Vec3::Zero();
    } else if (jg->is_array()) {
      SHATTER_TRY(g, json_input::read_vec3(*jg, w));
      c.gravity = *g;
    } else {
      return w.error("expected true, false or [gx, gy, gz] (m/s^2), got " + json_input::type_name(*jg));
    }
  }
  if (const Json* js = r.get("solver")) {
    SHATTER_TRY(s, read_solver(*js, root.key("solver")));
    c.solver = *s;
  }
  if (const Json* jf = r.get("fracture")) {
    SHATTER_TRY(f, read_fracture(*jf, root.key("fracture")));
    c.fracture = std::move(*f);
    c.fracture_given = true;
  }
  SHATTER_TRY(done, r.finish());
  return c;
}

Result<StaticCase> read_static_case(const std::string& path) {
  SHATTER_TRY(text, read_file(path, 64ULL << 20));
  return parse_static_case(*text, path);
}

namespace {

Error case_error(const StaticCase& c, const std::string& field, std::string message) {
  Error e = field_error(field, std::move(message));
  e.file = c.file;
  return e;
}

}  // namespace

Result<ResolvedStaticCase> resolve_static_case(const StaticCase& c, const TetMesh& mesh) {
  const auto n = static_cast<std::size_t>(mesh.num_nodes());
  ResolvedStaticCase out;
  out.held.assign(n, 0);
  out.prescribed = mesh.positions;
  out.forces.assign(n, Vec3::Zero());

  for (const AnchorSpec& a : c.anchors) {
    auto nodes = select_nodes(mesh, a.where);
    if (!nodes.ok()) return case_error(c, a.field, nodes.error().message);
    for (Index i : *nodes) {
      out.held[i] = static_cast<std::uint8_t>(out.held[i] | a.components);
      for (int k = 0; k < 3; ++k)
        if (a.components & (1u << k)) out.prescribed[i][k] = mesh.positions[i][k] + a.displacement[k];
    }
  }
  for (std::size_t i = 0; i < n; ++i)
    if (out.held[i]) ++out.num_held_nodes;

  // A load component on a held component is taken by the anchor, and one on a node no tet uses by
  // nothing: neither is applied, and each load that loses some of its force that way is named.
  std::vector<char> used(n, 0);
  for (const TetIndices& t : mesh.tets)
    for (Index v : t) used[static_cast<std::size_t>(v)] = 1;
  for (const LoadSpec& l : c.loads) {
    auto nodes = select_nodes(mesh, l.where);
    if (!nodes.ok()) return case_error(c, l.field, nodes.error().message);
    const std::vector<Vec3> before = out.forces;
    if (l.per_node) {
      for (Index i : *nodes) out.forces[i] += l.force;
    } else if (l.distribution == LoadSpec::Distribution::equal) {
      const Vec3 share = l.force / static_cast<double>(nodes->size());
      for (Index i : *nodes) out.forces[i] += share;
    } else {
      const std::vector<double> area = lumped_boundary_area(mesh, *nodes);
      double total = 0;
      for (double a : area) total += a;
      if (!(total > 0))
        return case_error(c, l.field,
                          "\"distribution\": \"area\" needs selected nodes that span at least "
                          "one boundary triangle; the " +
                              std::to_string(nodes->size()) + " selected node(s) span none");
      for (std::size_t k = 0; k < nodes->size(); ++k) out.forces[(*nodes)[k]] += l.force * (area[k] / total);
    }
    double given = 0, lost = 0;  // sums of |component|, N
    for (Index i : *nodes) {
      const Vec3 f = out.forces[i] - before[i];
      for (int k = 0; k < 3; ++k) {
        given += std::abs(f[k]);
        if (!used[i] || (out.held[i] & (1u << k))) lost += std::abs(f[k]);
      }
    }
    if (lost > 1e-12 * given) {
      char pct[32];
      std::snprintf(pct, sizeof pct, "%.3g", lost / given * 100.0);
      out.warnings.push_back(c.file + ": " + l.field + ": " +
                             (lost >= given ? std::string("all") : std::string(pct) + " %") +
                             " of the load falls on held components (the anchors take it) or on nodes no tet uses, "
                             "and is not applied");
    }
  }
  // The summary's total is what is applied: free components of nodes some tet uses.
  for (std::size_t i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k)
      if (used[i] && !(out.held[i] & (1u << k))) out.total_load[k] += out.forces[i][k];

  // Every connected piece of the mesh must be held against rigid motion.
  const Components comps = connected_components(mesh);
  std::vector<std::vector<Index>> piece_nodes(static_cast<std::size_t>(comps.count));
  std::vector<Index> piece_of_node(n, -1);
  for (Index e = 0; e < mesh.num_tets(); ++e)
    for (Index v : mesh.tets[e]) piece_of_node[v] = comps.tet_component[e];
  for (std::size_t i = 0; i < n; ++i)
    if (piece_of_node[i] >= 0) piece_nodes[piece_of_node[i]].push_back(static_cast<Index>(i));
  for (Index p = 0; p < comps.count; ++p) {
    if (holds_rigid_motion(mesh, piece_nodes[p], out.held)) continue;
    const Index first = piece_nodes[p].empty() ? 0 : piece_nodes[p].front();
    std::string where =
        comps.count > 1 ? "the mesh piece containing node " + std::to_string(mesh.node_id(first)) : "the mesh";
    return case_error(c, "anchors",
                      "the anchors leave " + where +
                          " free to move rigidly (translate or rotate); hold "
                          "more components or more nodes (e.g. a whole face with \"components\": \"xyz\")");
  }
  return out;
}

StaticProblem make_static_problem(const StaticCase& c, const ResolvedStaticCase& resolved) {
  StaticProblem p;
  p.anchors.assign(resolved.held.begin(), resolved.held.end());
  p.anchor_positions = resolved.prescribed;
  p.external_forces = resolved.forces;
  p.gravity = c.gravity.squaredNorm() > 0;
  p.gravity_vector = c.gravity;
  return p;
}

StaticSolverOptions make_solver_options(const CaseSolverSettings& s) {
  StaticSolverOptions o;
  if (s.linear_solver) o.linear.kind = *s.linear_solver;
  if (s.tolerance) o.relative_residual_tolerance = *s.tolerance;
  if (s.linear_tolerance) o.linear.relative_tolerance = *s.linear_tolerance;
  if (s.linear_max_iterations) o.linear.max_iterations = static_cast<int>(*s.linear_max_iterations);
  if (s.max_iterations) o.max_newton_iterations = static_cast<int>(*s.max_iterations);
  if (s.load_steps) o.load_increments = static_cast<int>(*s.load_steps);
  if (s.line_search) o.line_search = *s.line_search;
  if (s.tangent) o.tangent = *s.tangent;
  return o;
}

}  // namespace shatter
