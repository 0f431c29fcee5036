// Structured meshes of box-CSG shapes: rectilinear grid on the box faces, Kuhn tets per cell.
#include "shatter/meshing/box_csg_mesher.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace shatter {
namespace {

// A rotation that maps axes onto axes (entries 0 or +-1 up to rounding).
bool axis_permutation(const Mat3& r) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      const double a = std::abs(r(i, j));
      if (!(a < 1e-9 || std::abs(a - 1.0) < 1e-9)) return false;
    }
  return true;
}

bool collect(const Sdf& s, const Sdf::Transform& xf, std::vector<Aabb>& out) {
  switch (s.kind()) {
    case Sdf::Kind::box: {
      const Vec3 h = s.half_extents();
      Aabb b;
      for (int c = 0; c < 8; ++c) {
        const Vec3 corner((c & 1) ? h.x() : -h.x(), (c & 2) ? h.y() : -h.y(), (c & 4) ? h.z() : -h.z());
        b.extend(xf.translation + xf.rotation * (xf.scale * corner));
      }
      out.push_back(b);
      return true;
    }
    case Sdf::Kind::unite:
    case Sdf::Kind::subtract:
    case Sdf::Kind::intersect:
      if (s.children().empty()) return false;
      for (const Sdf& c : s.children())
        if (!collect(c, xf, out)) return false;
      return true;
    case Sdf::Kind::transform: {
      const Sdf::Transform t = s.transform();
      if (!axis_permutation(t.rotation)) return false;
      // Compose: outer(inner(x)) = T + R s (t + r s' x).
      Sdf::Transform c;
      c.translation = xf.translation + xf.rotation * (xf.scale * t.translation);
      c.rotation = xf.rotation * t.rotation;
      c.scale = xf.scale * t.scale;
      return collect(s.children()[0], c, out);
    }
    default: return false;
  }
}

struct Grid {
  std::array<std::vector<double>, 3> coords;  // face coordinates per axis, sorted, merged
  std::vector<char> inside;                   // per coarse cell, x fastest
  [[nodiscard]] Index n(int a) const { return static_cast<Index>(coords[a].size()) - 1; }
  [[nodiscard]] Index cell(Index i, Index j, Index k) const { return i + n(0) * (j + n(1) * k); }
};

Grid make_grid(const Sdf& sdf, const std::vector<Aabb>& boxes) {
  const Aabb bounds = sdf.bounds();
  Grid g;
  for (int a = 0; a < 3; ++a) {
    const double lo = bounds.min[a], hi = bounds.max[a];
    const double tol = 1e-9 * std::max(hi - lo, 1e-300);
    std::vector<double> c{lo, hi};
    for (const Aabb& b : boxes)
      for (double v : {b.min[a], b.max[a]})
        if (v > lo + tol && v < hi - tol) c.push_back(v);
    std::sort(c.begin(), c.end());
    std::vector<double> merged;
    for (double v : c)
      if (merged.empty() || v - merged.back() > tol) merged.push_back(v);
    g.coords[a] = std::move(merged);
  }
  g.inside.assign(
      static_cast<std::size_t>(g.n(0)) * static_cast<std::size_t>(g.n(1)) * static_cast<std::size_t>(g.n(2)), 0);
  for (Index k = 0; k < g.n(2); ++k)
    for (Index j = 0; j < g.n(1); ++j)
      for (Index i = 0; i < g.n(0); ++i) {
        const Vec3 c(0.5 * (g.coords[0][i] + g.coords[0][i + 1]), 0.5 * (g.coords[1][j] + g.coords[1][j + 1]),
                     0.5 * (g.coords[2][k] + g.coords[2][k + 1]));
        g.inside[g.cell(i, j, k)] = sdf(c) < 0 ? 1 : 0;
      }
  return g;
}

Index pieces(double length, double h) { return std::max<Index>(1, static_cast<Index>(std::llround(length / h))); }

// Tets for cell size h: 6 per fine cell inside.
std::int64_t count_tets(const Grid& g, double h) {
  std::array<std::vector<Index>, 3> n;
  for (int a = 0; a < 3; ++a)
    for (Index i = 0; i < g.n(a); ++i) n[a].push_back(pieces(g.coords[a][i + 1] - g.coords[a][i], h));
  std::int64_t t = 0;
  for (Index k = 0; k < g.n(2); ++k)
    for (Index j = 0; j < g.n(1); ++j)
      for (Index i = 0; i < g.n(0); ++i)
        if (g.inside[g.cell(i, j, k)]) t += 6 * n[0][i] * n[1][j] * n[2][k];
  return t;
}

}  // namespace

std::optional<std::vector<Aabb>> box_csg_boxes(const Sdf& sdf) {
  std::vector<Aabb> boxes;
  if (sdf.empty() || !collect(sdf, {}, boxes)) return std::nullopt;
  return boxes;
}

Result<TetMesh> mesh_box_csg(const Sdf& sdf, const BoxCsgDef& def, BoxCsgReport* report) {
  const auto boxes = box_csg_boxes(sdf);
  if (!boxes)
    return make_error(
        "box-CSG mesher: the shape is not made of axis-aligned boxes by union, difference "
        "and intersection");
  if (!(def.edge_length > 0) && def.target_tets <= 0)
    return field_error("edge_length", "expected an edge length > 0 m or a tet count > 0");
  const Grid g = make_grid(sdf, *boxes);
  if (std::none_of(g.inside.begin(), g.inside.end(), [](char c) { return c != 0; }))
    return make_error("box-CSG mesher: the shape is empty");

  double h = def.edge_length;
  if (!(h > 0)) {
    // Scan h downwards in 1 % steps from the largest extent; keep the count closest to the target.
    const Aabb b = sdf.bounds();
    const double hmax = b.extent().maxCoeff();
    std::int64_t best = -1;
    for (double t = hmax; t > hmax * 1e-4; t *= 0.99) {
      const std::int64_t c = count_tets(g, t);
      if (best < 0 || std::llabs(c - def.target_tets) < std::llabs(best - def.target_tets)) {
        best = c;
        h = t;
      }
      if (c > 4 * def.target_tets) break;
    }
  }

  // Fine coordinates per axis and the first fine index of each grid interval.
  std::array<std::vector<double>, 3> fine;
  std::array<std::vector<Index>, 3> first;
  for (int a = 0; a < 3; ++a) {
    for (Index i = 0; i < g.n(a); ++i) {
      const double x0 = g.coords[a][i], x1 = g.coords[a][i + 1];
      const Index n = pieces(x1 - x0, h);
      first[a].push_back(static_cast<Index>(fine[a].size()));
      for (Index p = 0; p < n; ++p)
        fine[a].push_back(p == 0 ? x0 : x0 + (x1 - x0) * static_cast<double>(p) / static_cast<double>(n));
    }
    first[a].push_back(static_cast<Index>(fine[a].size()));
    fine[a].push_back(g.coords[a].back());
  }
  const Index fx = static_cast<Index>(fine[0].size()) - 1, fy = static_cast<Index>(fine[1].size()) - 1,
              fz = static_cast<Index>(fine[2].size()) - 1;
  if (static_cast<double>(fx) * fy * fz > static_cast<double>(def.max_cells))
    return field_error("edge_length", "box-CSG grid of " + std::to_string(fx) + " x " + std::to_string(fy) + " x " +
                                          std::to_string(fz) + " cells is too large (limit " +
                                          std::to_string(def.max_cells) + ")");

  // Fine cells inside: those of an inside grid cell.
  auto interval = [&](int a) {
    std::vector<Index> of(static_cast<std::size_t>(a == 0 ? fx : a == 1 ? fy : fz));
    for (Index i = 0; i < g.n(a); ++i)
      for (Index p = first[a][i]; p < first[a][i + 1]; ++p) of[p] = i;
    return of;
  };
  const std::vector<Index> ix = interval(0), iy = interval(1), iz = interval(2);
  auto node = [&](Index i, Index j, Index k) { return i + (fx + 1) * (j + (fy + 1) * k); };
  std::vector<Index> id(static_cast<std::size_t>((fx + 1) * (fy + 1) * (fz + 1)), -1);
  std::vector<std::array<Index, 3>> cells;
  for (Index k = 0; k < fz; ++k)
    for (Index j = 0; j < fy; ++j)
      for (Index i = 0; i < fx; ++i)
        if (g.inside[g.cell(ix[i], iy[j], iz[k])]) {
          cells.push_back({i, j, k});
          for (int b = 0; b < 8; ++b) id[node(i + (b & 1), j + ((b >> 1) & 1), k + ((b >> 2) & 1))] = 0;
        }
  TetMesh m;
  for (Index k = 0; k <= fz; ++k)
    for (Index j = 0; j <= fy; ++j)
      for (Index i = 0; i <= fx; ++i)
        if (id[node(i, j, k)] == 0) {
          id[node(i, j, k)] = m.num_nodes();
          m.positions.emplace_back(fine[0][i], fine[1][j], fine[2][k]);
        }
  // Kuhn split around the diagonal 0-7 (corner bit 0 = +x, bit 1 = +y, bit 2 = +z), as make_box_mesh.
  static constexpr int kSix[6][4] = {{0, 1, 3, 7}, {0, 3, 2, 7}, {0, 2, 6, 7},
                                     {0, 6, 4, 7}, {0, 4, 5, 7}, {0, 5, 1, 7}};
  m.tets.reserve(cells.size() * 6);
  for (const auto& [i, j, k] : cells) {
    Index c[8];
    for (int b = 0; b < 8; ++b) c[b] = id[node(i + (b & 1), j + ((b >> 1) & 1), k + ((b >> 2) & 1))];
    for (const auto& q : kSix) {
      TetIndices t{c[q[0]], c[q[1]], c[q[2]], c[q[3]]};
      if (signed_volume(m.positions[t[0]], m.positions[t[1]], m.positions[t[2]], m.positions[t[3]]) < 0)
        std::swap(t[2], t[3]);
      m.tets.push_back(t);
    }
  }
  if (report) {
    report->edge_length = h;
    report->grid = {g.n(0), g.n(1), g.n(2)};
    report->cells = {fx, fy, fz};
    double v = 0;
    for (Index k = 0; k < g.n(2); ++k)
      for (Index j = 0; j < g.n(1); ++j)
        for (Index i = 0; i < g.n(0); ++i)
          if (g.inside[g.cell(i, j, k)])
            v += (g.coords[0][i + 1] - g.coords[0][i]) * (g.coords[1][j + 1] - g.coords[1][j]) *
                 (g.coords[2][k + 1] - g.coords[2][k]);
    report->exact_volume = v;
  }
  return m;
}

}  // namespace shatter
