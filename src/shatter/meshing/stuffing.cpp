// Isosurface stuffing (Labelle & Shewchuk 2007) on a uniform BCC lattice.
//
// Lattice points are kept in doubled integer coordinates P: black points (cube corners) have all
// coordinates even, red points (cube centres) all odd; position = origin + P * h / 2. Long edges
// join same-colour neighbours (P +- 2 e_a, length h), short edges join a red point to the 8 corners
// of its cube (P + (+-1, +-1, +-1), length h sqrt(3) / 2). Each BCC tet is a black edge
// (B, B + 2 e_a) with two consecutive cube centres around it (B + e_a +- e_b +- e_c).
#include "shatter/meshing/stuffing.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "shatter/core/parallel.h"
#include "shatter/mesh/topology.h"
#include "shatter/mesh/validate.h"
#include "shatter/meshing/coarsen.h"
#include "shatter/meshing/sharpen.h"
#include "shatter/meshing/stuffing_stencil.h"

namespace shatter {
namespace {

using Key = std::int64_t;  // lattice id, or kCutBase + owner * kSlots + slot for a cut point
using IVec3 = Eigen::Vector3i;
constexpr int kSlots = 11;  // per lattice point: 3 long edges (+x, +y, +z), 8 short edges (red only)

struct Lattice {
  Vec3 origin = Vec3::Zero();
  double h = 0;
  IVec3 n = IVec3::Zero();  // cubes per axis
  std::int64_t nb = 0, nr = 0;

  [[nodiscard]] bool valid(const IVec3& p) const {
    const bool odd = (p.x() & 1) != 0;
    for (int a = 0; a < 3; ++a) {
      if (((p[a] & 1) != 0) != odd) return false;
      if (odd ? (p[a] < 1 || p[a] > 2 * n[a] - 1) : (p[a] < 0 || p[a] > 2 * n[a])) return false;
    }
    return true;
  }
  [[nodiscard]] std::int64_t id(const IVec3& p) const {
    if ((p.x() & 1) == 0)
      return p.x() / 2 + std::int64_t(n.x() + 1) * (p.y() / 2 + std::int64_t(n.y() + 1) * (p.z() / 2));
    return nb + (p.x() - 1) / 2 + std::int64_t(n.x()) * ((p.y() - 1) / 2 + std::int64_t(n.y()) * ((p.z() - 1) / 2));
  }
  [[nodiscard]] IVec3 coord(std::int64_t i) const {
    if (i < nb) {
      const std::int64_t sx = n.x() + 1, sy = n.y() + 1;
      return IVec3(int(2 * (i % sx)), int(2 * ((i / sx) % sy)), int(2 * (i / (sx * sy))));
    }
    i -= nb;
    const std::int64_t sx = n.x(), sy = n.y();
    return IVec3(int(2 * (i % sx) + 1), int(2 * ((i / sx) % sy) + 1), int(2 * (i / (sx * sy)) + 1));
  }
  [[nodiscard]] Vec3 position(const IVec3& p) const { return origin + p.cast<double>() * (0.5 * h); }
};

// The 14 lattice directions: 0..5 long (+x, +y, +z, -x, -y, -z), 6..13 short (sign bits x, y, z).
IVec3 direction(int d) {
  if (d < 6) {
    IVec3 v = IVec3::Zero();
    v[d % 3] = d < 3 ? 2 : -2;
    return v;
  }
  const int bits = d - 6;
  return IVec3((bits & 1) ? 1 : -1, (bits & 2) ? 1 : -1, (bits & 4) ? 1 : -1);
}
int short_bits(const IVec3& d) { return (d.x() > 0 ? 1 : 0) | (d.y() > 0 ? 2 : 0) | (d.z() > 0 ? 4 : 0); }

// Owner point and slot of the edge (p, p + d).
struct Slot {
  IVec3 owner;
  int slot;
};
Slot edge_slot(const IVec3& p, const IVec3& d) {
  if (d.cwiseAbs().sum() == 2) {  // long
    int a = 0;
    d.cwiseAbs().maxCoeff(&a);
    return d[a] > 0 ? Slot{p, a} : Slot{p + d, a};
  }
  if ((p.x() & 1) != 0) return {p, 3 + short_bits(d)};
  return {p + d, 3 + short_bits(-d)};
}

struct Stuffer {
  const Sdf& sdf;
  const StuffingDef& def;
  Lattice lat;
  std::int64_t nl = 0;               // lattice points
  std::vector<double> value;         // sdf at lattice points (#nl)
  std::vector<double> cut_t;         // cut parameter from owner, or -1 (#nl x kSlots)
  std::vector<std::uint8_t> warped;  // (#nl)
  std::vector<Vec3> pos;             // lattice positions after warping (#nl)

  [[nodiscard]] Key cut_key(const IVec3& p, const IVec3& q) const {
    const Slot s = edge_slot(p, q - p);
    return nl + lat.id(s.owner) * kSlots + s.slot;
  }
  [[nodiscard]] Vec3 key_position(Key k) const {
    if (k < nl) return pos[static_cast<std::size_t>(k)];
    const std::int64_t owner = (k - nl) / kSlots;
    const int slot = static_cast<int>((k - nl) % kSlots);
    const IVec3 p = lat.coord(owner);
    const IVec3 q = p + (slot < 3 ? direction(slot) : direction(6 + slot - 3));
    const double t = cut_t[static_cast<std::size_t>(k - nl)];
    const Vec3 a = lat.position(p), b = lat.position(q);
    return a + t * (b - a);
  }
  [[nodiscard]] int sign(std::int64_t i) const {
    if (warped[static_cast<std::size_t>(i)]) return 0;
    const double v = value[static_cast<std::size_t>(i)];
    return v < 0 ? -1 : (v > 0 ? 1 : 0);
  }

  // Root of the sdf on the segment a + t (b - a), t in (0, 1), fa and fb of opposite signs
  // (false position with the Illinois modification).
  [[nodiscard]] double root(const Vec3& a, const Vec3& b, double fa, double fb) const {
    double ta = 0, tb = 1;
    int side = 0;
    double t = 0.5;
    for (int it = 0; it < def.root_iterations; ++it) {
      t = (ta * fb - tb * fa) / (fb - fa);
      if (!(t > ta && t < tb)) t = 0.5 * (ta + tb);
      const double ft = sdf(a + t * (b - a));
      if (ft == 0) break;
      if ((ft < 0) == (fa < 0)) {
        ta = t;
        fa = ft;
        if (side == -1) fb *= 0.5;
        side = -1;
      } else {
        tb = t;
        fb = ft;
        if (side == 1) fa *= 0.5;
        side = 1;
      }
      if (tb - ta < 1e-12) break;
    }
    return std::clamp(t, 1e-9, 1.0 - 1e-9);
  }

  void evaluate() {
    value.assign(static_cast<std::size_t>(nl), 0.0);
    parallel_for(
        0, nl, [&](std::int64_t i) { value[static_cast<std::size_t>(i)] = sdf(lat.position(lat.coord(i))); }, 256);
  }

  void cut_points() {
    cut_t.assign(static_cast<std::size_t>(nl * kSlots), -1.0);
    parallel_for(
        0, nl,
        [&](std::int64_t i) {
          const IVec3 p = lat.coord(i);
          const double fp = value[static_cast<std::size_t>(i)];
          const bool red = (p.x() & 1) != 0;
          for (int s = 0; s < (red ? kSlots : 3); ++s) {
            const IVec3 q = p + (s < 3 ? direction(s) : direction(6 + s - 3));
            if (!lat.valid(q)) continue;
            const double fq = value[static_cast<std::size_t>(lat.id(q))];
            if (!((fp < 0 && fq > 0) || (fp > 0 && fq < 0))) continue;
            cut_t[static_cast<std::size_t>(i * kSlots + s)] = root(lat.position(p), lat.position(q), fp, fq);
          }
        },
        256);
  }

  // A lattice point within alpha * edge length of a cut point on one of its edges is warped onto
  // the nearest such cut point (Labelle & Shewchuk 2007, section 3).
  void warp() {
    warped.assign(static_cast<std::size_t>(nl), 0);
    pos.resize(static_cast<std::size_t>(nl));
    parallel_for(
        0, nl,
        [&](std::int64_t i) {
          const IVec3 p = lat.coord(i);
          const Vec3 x = lat.position(p);
          double best = std::numeric_limits<double>::infinity();
          Vec3 target = x;
          for (int d = 0; d < 14; ++d) {
            const IVec3 q = p + direction(d);
            if (!lat.valid(q)) continue;
            const Slot s = edge_slot(p, q - p);
            const double t = cut_t[static_cast<std::size_t>(lat.id(s.owner) * kSlots + s.slot)];
            if (t < 0) continue;
            const double frac = s.owner == p ? t : 1.0 - t;
            const bool is_long = d < 6;
            const double alpha = is_long ? def.alpha_long : def.alpha_short;
            const double length = is_long ? lat.h : lat.h * std::sqrt(3.0) * 0.5;
            if (frac < alpha && frac * length < best) {
              best = frac * length;
              target = x + frac * (lat.position(q) - x);
            }
          }
          warped[static_cast<std::size_t>(i)] = std::isfinite(best) ? 1 : 0;
          pos[static_cast<std::size_t>(i)] = target;
        },
        256);
  }

  // Fill one BCC tet (vertices: black long edge p[0]-p[1], red long edge p[2]-p[3]) from the
  // stencil table.
  void clip_tet(const std::array<IVec3, 4>& p, std::vector<std::array<Key, 4>>& out) const {
    stuffing::StencilInput in;
    std::array<Key, 10> key{};
    for (int i = 0; i < 4; ++i) {
      key[static_cast<std::size_t>(i)] = lat.id(p[static_cast<std::size_t>(i)]);
      in.sign[static_cast<std::size_t>(i)] = sign(key[static_cast<std::size_t>(i)]);
    }
    bool any_in = false, any_out = false;
    for (int s : in.sign) {
      any_in |= s < 0;
      any_out |= s > 0;
    }
    // No inside vertex: nothing, including a tet whose four vertices were all warped onto the
    // surface (it lies on the surface; keeping it can pinch the boundary at an edge, and nothing
    // bounds its shape). No outside vertex: the whole tet.
    if (!any_in) return;
    if (!any_out) {
      out.push_back({key[0], key[1], key[2], key[3]});
      return;
    }
    for (int i = 0; i < 4; ++i)
      in.x[static_cast<std::size_t>(i)] = pos[static_cast<std::size_t>(key[static_cast<std::size_t>(i)])];
    for (int e = 0; e < 6; ++e) {
      const int i = stuffing::kStencilEdges[e][0], j = stuffing::kStencilEdges[e][1];
      if (in.sign[static_cast<std::size_t>(i)] * in.sign[static_cast<std::size_t>(j)] >= 0) continue;
      const Key k = cut_key(p[static_cast<std::size_t>(i)], p[static_cast<std::size_t>(j)]);
      key[static_cast<std::size_t>(4 + e)] = k;
      in.x[static_cast<std::size_t>(4 + e)] = key_position(k);
    }
    // Parity rule: a quadrilateral whose inside vertices are a long edge pivots on the endpoint
    // with the lower coordinate along the edge when that coordinate / 2 is even.
    auto lower_pivots = [](const IVec3& a, const IVec3& b) {
      int axis = 0;
      (b - a).cwiseAbs().maxCoeff(&axis);
      return ((std::min(a[axis], b[axis]) >> 1) & 1) == 0;
    };
    auto first_pivots = [&](const IVec3& a, const IVec3& b) {
      int axis = 0;
      (b - a).cwiseAbs().maxCoeff(&axis);
      return (a[axis] < b[axis]) == lower_pivots(a, b);
    };
    in.long_pivot_first = {first_pivots(p[0], p[1]), first_pivots(p[2], p[3])};
    const stuffing::StencilOutput st = stuffing::fill_stencil(in);
    for (int t = 0; t < st.count; ++t) {
      const auto& l = st.tets[static_cast<std::size_t>(t)];
      out.push_back({key[l[0]], key[l[1]], key[l[2]], key[l[3]]});
    }
  }

  // All output tets as keys, black points in lattice order (z slabs in parallel, joined in order).
  std::vector<std::array<Key, 4>> tets() const {
    const int slabs = lat.n.z() + 1;
    std::vector<std::vector<std::array<Key, 4>>> per_slab(static_cast<std::size_t>(slabs));
    parallel_for(
        0, slabs,
        [&](std::int64_t kz) {
          auto& out = per_slab[static_cast<std::size_t>(kz)];
          for (int jy = 0; jy <= lat.n.y(); ++jy)
            for (int ix = 0; ix <= lat.n.x(); ++ix) {
              const IVec3 b(2 * ix, 2 * jy, 2 * static_cast<int>(kz));
              for (int a = 0; a < 3; ++a) {
                IVec3 ea = IVec3::Zero();
                ea[a] = 1;
                if (!lat.valid(b + 2 * ea)) continue;
                IVec3 eb = IVec3::Zero(), ec = IVec3::Zero();
                eb[(a + 1) % 3] = 1;
                ec[(a + 2) % 3] = 1;
                static constexpr int kRing[4][2] = {{1, 1}, {-1, 1}, {-1, -1}, {1, -1}};
                for (int q = 0; q < 4; ++q) {
                  const IVec3 r1 = b + ea + kRing[q][0] * eb + kRing[q][1] * ec;
                  const IVec3 r2 = b + ea + kRing[(q + 1) % 4][0] * eb + kRing[(q + 1) % 4][1] * ec;
                  if (!lat.valid(r1) || !lat.valid(r2)) continue;
                  clip_tet({b, b + 2 * ea, r1, r2}, out);
                }
              }
            }
        },
        2);
    std::vector<std::array<Key, 4>> all;
    std::size_t total = 0;
    for (const auto& v : per_slab) total += v.size();
    all.reserve(total);
    for (const auto& v : per_slab) all.insert(all.end(), v.begin(), v.end());
    return all;
  }
};

Result<TetMesh> stuff_once(const Sdf& sdf, const StuffingDef& def, double h, StuffingReport* report) {
  const Aabb box = sdf.bounds();
  if (box.empty() || !box.min.allFinite() || !box.max.allFinite())
    return field_error("shape", "the shape has empty or infinite bounds: nothing to mesh");
  Stuffer st{sdf, def, {}, 0, {}, {}, {}, {}};
  Lattice& lat = st.lat;
  lat.h = h;
  const Vec3 ext = box.extent();
  double count = 1;
  for (int a = 0; a < 3; ++a) {
    const double cells = std::ceil(ext[a] / h) + 2;
    count *= cells + 1;
    if (!(cells < 1e6)) count = std::numeric_limits<double>::infinity();
    lat.n[a] = static_cast<int>(std::min(cells, 1e6));
  }
  if (!(2 * count <= static_cast<double>(def.max_lattice_vertices))) {
    const double gib = 2 * count * static_cast<double>(kStuffingBytesPerLatticeVertex) / (1024.0 * 1024 * 1024);
    const bool huge = !(gib < 1e12);  // also an infinite count, which a message never prints
    return field_error("edge_length",
                       "edge length " + format_number(h) + " m needs a lattice of " +
                           (huge ? std::string("more than 1e20") : format_number(2 * count)) + " points (" +
                           (huge ? std::string("far beyond any memory") : "about " + format_number(gib) + " GiB") +
                           "; limit " + std::to_string(def.max_lattice_vertices) + " points) for bounds of " +
                           format_number(ext.x()) + " x " + format_number(ext.y()) + " x " + format_number(ext.z()) +
                           " m: expected a larger edge length");
  }
  lat.origin = 0.5 * (box.min + box.max) - 0.5 * h * lat.n.cast<double>();
  lat.nb = std::int64_t(lat.n.x() + 1) * (lat.n.y() + 1) * (lat.n.z() + 1);
  lat.nr = std::int64_t(lat.n.x()) * lat.n.y() * lat.n.z();
  st.nl = lat.nb + lat.nr;

  st.evaluate();
  for (double v : st.value)
    if (std::isnan(v)) return field_error("shape", "the signed distance is NaN somewhere in the lattice");
  st.cut_points();
  st.warp();
  std::vector<std::array<Key, 4>> key_tets = st.tets();
  if (key_tets.empty())
    return field_error("edge_length", "no tets: the shape is thinner than the edge length " + std::to_string(h) +
                                          " m; expected a smaller edge length");

  // Number the used keys: lattice points in lattice order, then cut points in slot order.
  const std::int64_t nkeys = st.nl * (1 + kSlots);
  std::vector<Index> node_of(static_cast<std::size_t>(nkeys), -1);
  for (const auto& t : key_tets)
    for (Key q : t) node_of[static_cast<std::size_t>(q)] = 0;
  TetMesh mesh;
  std::int64_t cuts = 0;
  for (std::int64_t q = 0; q < nkeys; ++q) {
    if (node_of[static_cast<std::size_t>(q)] < 0) continue;
    if (mesh.positions.size() >= static_cast<std::size_t>(std::numeric_limits<Index>::max()))
      return field_error("edge_length", "mesh too large for 32-bit indices");
    node_of[static_cast<std::size_t>(q)] = static_cast<Index>(mesh.positions.size());
    mesh.positions.push_back(st.key_position(q));
    cuts += q >= st.nl;
  }
  mesh.tets.resize(key_tets.size());
  parallel_for(0, static_cast<std::int64_t>(key_tets.size()), [&](std::int64_t e) {
    TetIndices t;
    for (int c = 0; c < 4; ++c) t[c] = node_of[static_cast<std::size_t>(key_tets[static_cast<std::size_t>(e)][c])];
    const double v =
        signed_volume(mesh.positions[t[0]], mesh.positions[t[1]], mesh.positions[t[2]], mesh.positions[t[3]]);
    if (v < 0) std::swap(t[2], t[3]);
    mesh.tets[static_cast<std::size_t>(e)] = t;
  });
  // Sharpening and grading change tets only inside [min_changed, max_changed] (within the stencil
  // bounds), so they keep the bounds and most of the uniform mesh's quality.
  const double min_changed = std::max(kStuffingMinDihedralDeg, def.changed_min_dihedral_deg);
  const double max_changed = std::min(kStuffingMaxDihedralDeg, def.changed_max_dihedral_deg);
  std::int64_t sharpened = 0;
  if (def.sharpen) {
    auto r = sharpen_features(mesh, sdf,
                              {.edge_length = h, .min_dihedral_deg = min_changed, .max_dihedral_deg = max_changed});
    if (!r) return std::move(r.error());
    sharpened = r->moved;
  }
  std::int64_t uniform_tets = mesh.num_tets();
  if (def.grading > 0) {
    // Wanted size: h down to depth h, then growing by `grading` per unit depth (depth = -sdf; a
    // bound for CSG, so the size is if anything smaller than asked).
    const double g = def.grading, cap = def.max_size_ratio * h;
    CoarsenDef cd;
    cd.size = [&sdf, g, h, cap](const Vec3& x) { return std::min(cap, h + g * std::max(0.0, -sdf(x) - h)); };
    cd.min_dihedral_deg = min_changed;
    cd.max_dihedral_deg = max_changed;
    auto r = coarsen_interior(mesh, cd);
    if (!r) return std::move(r.error());
  }
  if (report) {
    report->tets_before_grading = uniform_tets;
    report->sharpened = sharpened;
    report->edge_length = h;
    report->lattice_vertices = st.nl;
    report->cut_points = cuts;
    std::int64_t w = 0;
    for (auto x : st.warped) w += x;
    report->warped = w;
  }
  const ValidationReport vr = validate_mesh(mesh);
  if (vr.has_errors())
    return field_error("shape", "stuffing produced an invalid mesh (" + vr.problems.front().message +
                                    "); the shape may have features thinner than the edge length");
  return mesh;
}

}  // namespace

Result<TetMesh> stuff_tets(const Sdf& sdf, const StuffingDef& def, StuffingReport* report) {
  if (sdf.empty()) return field_error("shape", "no shape given");
  // A cut point within alpha of both ends would warp both onto it (alpha >= 0.5).
  if (!(def.alpha_long > 0 && def.alpha_long < 0.5)) return field_error("alpha_long", "expected a number in (0, 0.5)");
  if (!(def.alpha_short > 0 && def.alpha_short < 0.5))
    return field_error("alpha_short", "expected a number in (0, 0.5)");
  if (!(def.grading >= 0) || !std::isfinite(def.grading)) return field_error("grading", "expected a number >= 0");
  if (!(def.max_size_ratio >= 1) || !std::isfinite(def.max_size_ratio))
    return field_error("max_size_ratio", "expected a number >= 1");
  if (def.edge_length > 0) {
    if (!std::isfinite(def.edge_length)) return field_error("edge_length", "expected a finite length > 0");
    return stuff_once(sdf, def, def.edge_length, report);
  }
  if (def.edge_length < 0 || std::isnan(def.edge_length))
    return field_error("edge_length", "expected a length > 0 m, got " + std::to_string(def.edge_length));
  if (def.target_tets <= 0) return field_error("target_tets", "expected an edge length > 0 or a tet count > 0");
  // Search h: a BCC lattice has 12 tets per cube of volume h^3, so tets ~ 12 V / h^3; measure V on
  // a coarse mesh, then correct h by the cube root of the count ratio.
  const Aabb box = sdf.bounds();
  if (box.empty() || !box.max.allFinite() || !box.min.allFinite())
    return field_error("shape", "the shape has empty or infinite bounds: nothing to mesh");
  double h = box.extent().maxCoeff() / 12.0;
  int attempts = 0;
  double volume = 0;
  // The volume estimate needs neither sharpening nor grading (grading keeps the volume).
  StuffingDef plain = def;
  plain.sharpen = false;
  plain.grading = 0;
  for (int i = 0; i < 4 && volume <= 0; ++i, h *= 0.5) {
    ++attempts;
    auto coarse = stuff_once(sdf, plain, h, nullptr);
    if (coarse) volume = total_volume(*coarse);
  }
  if (!(volume > 0)) return field_error("shape", "the shape is empty or far thinner than its bounds");
  h = std::cbrt(12.0 * volume / static_cast<double>(def.target_tets));
  std::optional<TetMesh> best;
  StuffingReport best_report;
  double best_err = std::numeric_limits<double>::infinity();
  for (int i = 0; i < 5; ++i) {
    ++attempts;
    StuffingReport r;
    auto m = stuff_once(sdf, def, h, &r);
    if (!m) {
      if (best) break;
      return std::move(m.error());
    }
    const double n = static_cast<double>(m->num_tets());
    const double err = std::abs(std::log(n / static_cast<double>(def.target_tets)));
    if (err < best_err) {
      best_err = err;
      best = std::move(*m);
      best_report = r;
    }
    if (err < 0.05) break;
    h *= std::cbrt(n / static_cast<double>(def.target_tets));
  }
  best_report.attempts = attempts;
  if (report) *report = best_report;
  return std::move(*best);
}

}  // namespace shatter
