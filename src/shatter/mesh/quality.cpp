#include "shatter/mesh/quality.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "shatter/mesh/topology.h"

namespace shatter {

std::array<double, 6> dihedral_cosines(const Mat34& x) {
  // Outward face normals n_k (face opposite corner k); the dihedral angle at the edge shared by
  // faces k and l is pi - angle(n_k, n_l), so its cosine is -n_k . n_l. Edge (i,j) is shared by
  // the faces opposite the other two.
  std::array<Vec3, 4> n;
  for (int k = 0; k < 4; ++k) {
    const int a = (k + 1) % 4, b = (k + 2) % 4, c = (k + 3) % 4;
    Vec3 nk = (x.col(b) - x.col(a)).cross(x.col(c) - x.col(a));
    if (nk.dot(x.col(k) - x.col(a)) > 0) nk = -nk;  // point away from the opposite corner
    const double len = nk.norm();
    n[k] = len > 0 ? Vec3(nk / len) : Vec3::Zero();
  }
  std::array<double, 6> out{};
  for (int e = 0; e < 6; ++e) {
    int other[2], m = 0;
    for (int k = 0; k < 4; ++k)
      if (k != kTetEdges[e][0] && k != kTetEdges[e][1]) other[m++] = k;
    out[e] = -n[other[0]].dot(n[other[1]]);
  }
  return out;
}

std::array<double, 6> dihedral_angles(const Mat34& x) {
  std::array<double, 6> out = dihedral_cosines(x);
  for (double& c : out) c = M_PI - std::acos(std::clamp(-c, -1.0, 1.0));
  return out;
}

double signed_shape_measure(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  const double l2 = (b - a).squaredNorm() + (c - a).squaredNorm() + (d - a).squaredNorm() + (c - b).squaredNorm() +
                    (d - b).squaredNorm() + (d - c).squaredNorm();
  return signed_volume(a, b, c, d) / (l2 * std::sqrt(l2));
}

double aspect_ratio(const Mat34& x) {
  const Vec3 a = x.col(1) - x.col(0), b = x.col(2) - x.col(0), c = x.col(3) - x.col(0);
  const double six_v = std::abs(a.dot(b.cross(c)));
  double area = 0;
  for (int k = 0; k < 4; ++k) {
    const Vec3 p = x.col((k + 1) % 4), q = x.col((k + 2) % 4), r = x.col((k + 3) % 4);
    area += 0.5 * (q - p).cross(r - p).norm();
  }
  if (!(six_v > 0) || !(area > 0)) return std::numeric_limits<double>::infinity();
  const double inradius = 0.5 * six_v / area;  // r = 3V / A
  // Circumradius: |a|^2 (b x c) + |b|^2 (c x a) + |c|^2 (a x b) over 2 * (6V)
  const Vec3 num = a.squaredNorm() * b.cross(c) + b.squaredNorm() * c.cross(a) + c.squaredNorm() * a.cross(b);
  const double circumradius = num.norm() / (2.0 * six_v);
  return circumradius / (3.0 * inradius);
}

QualitySummary mesh_quality(const TetMesh& mesh) {
  QualitySummary q;
  if (mesh.tets.empty()) return q;
  q.min_tet_volume = std::numeric_limits<double>::infinity();
  q.max_tet_volume = -std::numeric_limits<double>::infinity();
  q.min_dihedral_deg = 180;
  q.max_dihedral_deg = 0;
  q.min_aspect = std::numeric_limits<double>::infinity();
  q.max_aspect = 0;
  double sum_aspect = 0;
  for (Index e = 0; e < mesh.num_tets(); ++e) {
    const Mat34 x = mesh.corners(e);
    const double v = signed_volume(x.col(0), x.col(1), x.col(2), x.col(3));
    q.volume += v;
    q.min_tet_volume = std::min(q.min_tet_volume, v);
    q.max_tet_volume = std::max(q.max_tet_volume, v);
    for (double angle : dihedral_angles(x)) {
      const double deg = angle * 180.0 / M_PI;
      if (deg < q.min_dihedral_deg) {
        q.min_dihedral_deg = deg;
        q.min_dihedral_tet = e;
      }
      q.max_dihedral_deg = std::max(q.max_dihedral_deg, deg);
    }
    const double ar = aspect_ratio(x);
    q.min_aspect = std::min(q.min_aspect, ar);
    if (ar > q.max_aspect || q.worst_aspect_tet < 0) {
      q.max_aspect = ar;
      q.worst_aspect_tet = e;
    }
    sum_aspect += ar;
  }
  q.mean_aspect = sum_aspect / mesh.num_tets();
  return q;
}

}  // namespace shatter
