#include "shatter/mesh/generate.h"

#include <algorithm>
#include <cmath>

#include "shatter/core/assert.h"
#include "shatter/core/random.h"

namespace shatter {

TetMesh make_box_mesh(const BoxMeshDef& def) {
  SHATTER_CHECK(def.cells[0] >= 1 && def.cells[1] >= 1 && def.cells[2] >= 1);
  const Index nx = def.cells[0], ny = def.cells[1], nz = def.cells[2];
  const Vec3 h = (def.max - def.min).cwiseQuotient(Vec3(nx, ny, nz));
  auto node = [&](Index i, Index j, Index k) { return i + (nx + 1) * (j + (ny + 1) * k); };
  TetMesh m;
  m.positions.reserve(static_cast<std::size_t>(nx + 1) * (ny + 1) * (nz + 1));
  Random rng(def.seed);
  for (Index k = 0; k <= nz; ++k)
    for (Index j = 0; j <= ny; ++j)
      for (Index i = 0; i <= nx; ++i) {
        Vec3 p = def.min + Vec3(i * h.x(), j * h.y(), k * h.z());
        if (def.jitter > 0) {
          const Vec3 d = rng.uniform_vec3(-def.jitter, def.jitter).cwiseProduct(h);
          // Boundary nodes stay on their faces.
          if (i > 0 && i < nx) p.x() += d.x();
          if (j > 0 && j < ny) p.y() += d.y();
          if (k > 0 && k < nz) p.z() += d.z();
        }
        m.positions.push_back(p);
      }
  // Cell corners c[b] with bit 0 = +x, bit 1 = +y, bit 2 = +z.
  static constexpr int kSix[6][4] = {{0, 1, 3, 7}, {0, 3, 2, 7}, {0, 2, 6, 7},
                                     {0, 6, 4, 7}, {0, 4, 5, 7}, {0, 5, 1, 7}};
  static constexpr int kFiveEven[5][4] = {{0, 1, 2, 4}, {1, 3, 2, 7}, {1, 4, 5, 7}, {2, 7, 6, 4}, {1, 2, 4, 7}};
  static constexpr int kFiveOdd[5][4] = {{1, 0, 3, 5}, {0, 2, 3, 6}, {0, 5, 4, 6}, {3, 6, 7, 5}, {0, 3, 5, 6}};
  for (Index k = 0; k < nz; ++k)
    for (Index j = 0; j < ny; ++j)
      for (Index i = 0; i < nx; ++i) {
        Index c[8];
        for (int b = 0; b < 8; ++b) c[b] = node(i + (b & 1), j + ((b >> 1) & 1), k + ((b >> 2) & 1));
        auto add = [&](const int* q) {
          TetIndices t{c[q[0]], c[q[1]], c[q[2]], c[q[3]]};
          if (signed_volume(m.positions[t[0]], m.positions[t[1]], m.positions[t[2]], m.positions[t[3]]) < 0)
            std::swap(t[2], t[3]);
          m.tets.push_back(t);
        };
        if (def.pattern == BoxMeshDef::Pattern::six) {
          for (const auto& q : kSix) add(q);
        } else {
          const bool odd = ((i + j + k) & 1) != 0;
          for (int t = 0; t < 5; ++t) add(odd ? kFiveOdd[t] : kFiveEven[t]);
        }
      }
  return m;
}

std::array<Index, 3> cells_for_tet_count(const Vec3& extent, std::int64_t target_tets, BoxMeshDef::Pattern pattern) {
  const double per_cell = pattern == BoxMeshDef::Pattern::six ? 6.0 : 5.0;
  const double cells = std::max(1.0, static_cast<double>(target_tets) / per_cell);
  const double h = std::cbrt(extent.prod() / cells);
  std::array<Index, 3> n{};
  for (int a = 0; a < 3; ++a) n[a] = std::max<Index>(1, static_cast<Index>(std::lround(extent[a] / h)));
  return n;
}

}  // namespace shatter
