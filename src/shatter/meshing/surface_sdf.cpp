// Winding-number inside test and BVH distance queries for closed triangle surfaces.
#include "shatter/meshing/surface_sdf.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>
#include <tuple>

namespace shatter {

double point_triangle_distance(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  // Ericson 5.1.5: closest point by Voronoi regions.
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return ap.norm();
  const Vec3 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return bp.norm();
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const double v = d1 / (d1 - d3);
    return (p - (a + v * ab)).norm();
  }
  const Vec3 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return cp.norm();
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const double w = d2 / (d2 - d6);
    return (p - (a + w * ac)).norm();
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return (p - (b + w * (c - b))).norm();
  }
  const double denom = 1.0 / (va + vb + vc);
  const double v = vb * denom, w = vc * denom;
  return (p - (a + ab * v + ac * w)).norm();
}

double triangle_winding(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  // tan(Omega / 2) = a.(b x c) / (|a||b||c| + (a.b)|c| + (a.c)|b| + (b.c)|a|).
  const Vec3 x = a - p, y = b - p, z = c - p;
  const double lx = x.norm(), ly = y.norm(), lz = z.norm();
  const double num = x.dot(y.cross(z));
  const double den = lx * ly * lz + x.dot(y) * lz + x.dot(z) * ly + y.dot(z) * lx;
  return std::atan2(num, den) / (2.0 * std::numbers::pi);
}

std::int32_t SurfaceDistance::build(std::int32_t first, std::int32_t count) {
  const auto index = static_cast<std::int32_t>(nodes_.size());
  nodes_.emplace_back();
  Aabb box, centroids;
  for (std::int32_t i = first; i < first + count; ++i) {
    const Tri& t = tris_[i];
    box.extend(t.a);
    box.extend(t.b);
    box.extend(t.c);
    centroids.extend((t.a + t.b + t.c) / 3.0);
  }
  nodes_[index].box = box;
  Vec3 area_vector = Vec3::Zero(), weighted = Vec3::Zero();
  double area_sum = 0;
  for (std::int32_t i = first; i < first + count; ++i) {
    const Tri& t = tris_[i];
    const Vec3 av = 0.5 * (t.b - t.a).cross(t.c - t.a);
    area_vector += av;
    area_sum += av.norm();
    weighted += av.norm() * (t.a + t.b + t.c) / 3.0;
  }
  const Vec3 center = area_sum > 0 ? Vec3(weighted / area_sum) : Vec3(0.5 * (box.min + box.max));
  double radius = 0;
  for (int c = 0; c < 8; ++c) {
    const Vec3 corner((c & 1) ? box.max.x() : box.min.x(), (c & 2) ? box.max.y() : box.min.y(),
                      (c & 4) ? box.max.z() : box.min.z());
    radius = std::max(radius, (corner - center).norm());
  }
  nodes_[index].area_vector = area_vector;
  nodes_[index].center = center;
  nodes_[index].radius = radius;
  if (count <= 4) {
    nodes_[index].first = first;
    nodes_[index].count = count;
    return index;
  }
  // Median split along the longest axis of the centroids (stable: ties by original order).
  int axis = 0;
  centroids.extent().maxCoeff(&axis);
  const std::int32_t mid = first + count / 2;
  std::nth_element(tris_.begin() + first, tris_.begin() + mid, tris_.begin() + first + count,
                   [axis](const Tri& u, const Tri& v) {
                     const double cu = u.a[axis] + u.b[axis] + u.c[axis];
                     const double cv = v.a[axis] + v.b[axis] + v.c[axis];
                     if (cu != cv) return cu < cv;
                     return std::tie(u.a.x(), u.a.y(), u.a.z()) < std::tie(v.a.x(), v.a.y(), v.a.z());
                   });
  const std::int32_t left = build(first, mid - first);
  const std::int32_t right = build(mid, first + count - mid);
  nodes_[index].left = left;
  nodes_[index].right = right;
  return index;
}

Result<std::shared_ptr<const SurfaceDistance>> SurfaceDistance::create(const TriSurface& surface,
                                                                       const std::string& name) {
  if (surface.triangles.empty() || surface.positions.empty())
    return file_error(name, "surface is empty: expected a closed triangle surface");
  const auto nv = static_cast<Index>(surface.positions.size());
  for (Index i = 0; i < nv; ++i)
    if (!surface.positions[i].allFinite())
      return file_error(name, "vertex " + std::to_string(i + 1) + " has a non-finite coordinate");
  auto s = std::make_shared<SurfaceDistance>();
  Aabb all;
  for (std::size_t f = 0; f < surface.triangles.size(); ++f) {
    const TriIndices& t = surface.triangles[f];
    for (Index k : t)
      if (k < 0 || k >= nv)
        return file_error(name, "triangle " + std::to_string(f + 1) + " refers to vertex " + std::to_string(k + 1) +
                                    " of " + std::to_string(nv));
    const Vec3 &a = surface.positions[t[0]], &b = surface.positions[t[1]], &c = surface.positions[t[2]];
    all.extend(a);
    all.extend(b);
    all.extend(c);
    s->tris_.push_back({a, b, c});
  }
  const double diag = all.extent().norm();
  // Drop triangles of (relatively) zero area.
  std::erase_if(s->tris_,
                [diag](const Tri& t) { return !((t.b - t.a).cross(t.c - t.a).norm() > 1e-14 * diag * diag); });
  if (s->tris_.empty()) return file_error(name, "every triangle is degenerate (zero area): expected a closed surface");
  s->bounds_ = all;
  const std::vector<Tri> original = s->tris_;
  s->nodes_.reserve(2 * s->tris_.size() / 4 + 4);
  s->build(0, static_cast<std::int32_t>(s->tris_.size()));
  // Closedness and orientation: probe just inside and outside triangles spread over the surface;
  // a closed surface gives a winding number near +1 (outward) or -1 (inside-out) on one side.
  const std::size_t nt = original.size();
  const std::size_t probes = std::min<std::size_t>(nt, 64);
  std::vector<double> magnitude;
  double sum = 0;
  for (std::size_t k = 0; k < probes; ++k) {
    const Tri& t = original[k * nt / probes];
    const Vec3 n = (t.b - t.a).cross(t.c - t.a);
    const double size = std::sqrt(n.norm());
    const Vec3 c = (t.a + t.b + t.c) / 3.0;
    const double w1 = s->winding_number(c - n.normalized() * (1e-3 * size));
    const double w2 = s->winding_number(c + n.normalized() * (1e-3 * size));
    const double w = std::abs(w1) > std::abs(w2) ? w1 : w2;
    sum += w;
    magnitude.push_back(std::abs(w));
  }
  std::sort(magnitude.begin(), magnitude.end());
  const double median = magnitude[magnitude.size() / 2];
  if (median < 0.9)
    return file_error(name,
                      "surface is not closed: the generalized winding number does not come near 1 "
                      "inside it (median " +
                          std::to_string(median) +
                          " just below its triangles); "
                          "expected a closed (watertight) surface");
  if (sum < 0) s->orientation_ = -1.0;
  return std::shared_ptr<const SurfaceDistance>(std::move(s));
}

double SurfaceDistance::winding_number(const Vec3& p) const {
  double w = 0;
  std::int32_t stack[128];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const BvhNode& n = nodes_[stack[--top]];
    const Vec3 d = n.center - p;
    const double dist = d.norm();
    if (n.left >= 0 && dist > kFarField * n.radius) {
      w += n.area_vector.dot(d) / (4.0 * std::numbers::pi * dist * dist * dist);
      continue;
    }
    if (n.left < 0) {
      for (std::int32_t i = n.first; i < n.first + n.count; ++i)
        w += triangle_winding(p, tris_[i].a, tris_[i].b, tris_[i].c);
      continue;
    }
    stack[top++] = n.right;
    stack[top++] = n.left;
  }
  return w * orientation_;
}

double SurfaceDistance::unsigned_distance(const Vec3& p) const {
  double best = std::numeric_limits<double>::infinity();
  auto box_distance = [&p](const Aabb& b) {
    const Vec3 d = (b.min - p).cwiseMax(p - b.max).cwiseMax(0.0);
    return d.norm();
  };
  std::int32_t stack[128];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const BvhNode& n = nodes_[stack[--top]];
    if (box_distance(n.box) >= best) continue;
    if (n.left < 0) {
      for (std::int32_t i = n.first; i < n.first + n.count; ++i)
        best = std::min(best, point_triangle_distance(p, tris_[i].a, tris_[i].b, tris_[i].c));
      continue;
    }
    // Visit the nearer child first.
    const double dl = box_distance(nodes_[n.left].box), dr = box_distance(nodes_[n.right].box);
    if (dl < dr) {
      stack[top++] = n.right;
      stack[top++] = n.left;
    } else {
      stack[top++] = n.left;
      stack[top++] = n.right;
    }
  }
  return best;
}

double SurfaceDistance::signed_distance(const Vec3& p) const {
  const double d = unsigned_distance(p);
  return winding_number(p) > 0.5 ? -d : d;
}

}  // namespace shatter
