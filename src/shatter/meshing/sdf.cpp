// Signed distance functions: evaluation, bounds and volumes of the SDF tree (formulas: Quilez).
#include "shatter/meshing/sdf.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include "shatter/meshing/surface_sdf.h"

namespace shatter {

struct Sdf::Node {
  Kind kind = Kind::sphere;
  Vec3 v = Vec3::Zero();      ///< box half extents, ellipsoid radii
  double a = 0, b = 0;        ///< radius / half height / major / minor / k / half depth
  std::vector<Vec2> polygon;  ///< revolution profile (r, y) or extrusion polygon (x, y)
  std::shared_ptr<const SurfaceDistance> surface;
  std::vector<Sdf> children;
  Vec3 translation = Vec3::Zero();
  Mat3 rotation = Mat3::Identity();
  double scale = 1.0;
};

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

std::shared_ptr<Sdf::Node> new_node(Sdf::Kind kind) {
  auto n = std::make_shared<Sdf::Node>();
  n->kind = kind;
  return n;
}

// Distance to an axis-aligned 2D "box" combination: exact for intersections of two slabs.
double op_extrude(double d2, double w) {
  const double ox = std::max(d2, 0.0), oy = std::max(w, 0.0);
  return std::min(std::max(d2, w), 0.0) + std::sqrt(ox * ox + oy * oy);
}

double smin(double a, double b, double k) {
  const double h = std::max(k - std::abs(a - b), 0.0) / k;
  return std::min(a, b) - h * h * k * 0.25;
}

Aabb transform_box(const Aabb& box, const Vec3& t, const Mat3& r, double s) {
  Aabb out;
  if (box.empty()) return out;
  for (int c = 0; c < 8; ++c) {
    const Vec3 corner((c & 1) ? box.max.x() : box.min.x(), (c & 2) ? box.max.y() : box.min.y(),
                      (c & 4) ? box.max.z() : box.min.z());
    out.extend(t + r * (s * corner));
  }
  return out;
}

}  // namespace

double polygon_signed_distance(const std::vector<Vec2>& v, const Vec2& p) {
  const std::size_t n = v.size();
  double d = (p - v[0]).squaredNorm();
  double s = 1.0;
  for (std::size_t i = 0, j = n - 1; i < n; j = i, ++i) {
    const Vec2 e = v[j] - v[i];
    const Vec2 w = p - v[i];
    const double ee = e.squaredNorm();
    const double t = ee > 0 ? std::clamp(w.dot(e) / ee, 0.0, 1.0) : 0.0;
    const Vec2 b = w - e * t;
    d = std::min(d, b.squaredNorm());
    // Crossing test (even-odd).
    const bool c1 = p.y() >= v[i].y(), c2 = p.y() < v[j].y();
    const bool c3 = e.x() * w.y() > e.y() * w.x();
    if ((c1 && c2 && c3) || (!c1 && !c2 && !c3)) s = -s;
  }
  return s * std::sqrt(d);
}

double polygon_area(const std::vector<Vec2>& v) {
  double a = 0;
  for (std::size_t i = 0, j = v.size() - 1; i < v.size(); j = i, ++i) a += v[j].x() * v[i].y() - v[i].x() * v[j].y();
  return 0.5 * a;
}

Result<void> check_polygon(const std::vector<Vec2>& polygon, bool revolution, const std::string& field) {
  if (polygon.size() < 3)
    return field_error(field, "expected a closed polygon of at least 3 points, got " + std::to_string(polygon.size()));
  for (std::size_t i = 0; i < polygon.size(); ++i) {
    if (!polygon[i].allFinite())
      return field_error(field + "[" + std::to_string(i) + "]", "expected finite coordinates");
    if (revolution && polygon[i].x() < 0)
      return field_error(field + "[" + std::to_string(i) + "]", "expected radius r >= 0 (profile points are (r, y))");
  }
  if (!(std::abs(polygon_area(polygon)) > 0)) return field_error(field, "expected a polygon with non-zero area");
  return {};
}

Mat3 rotation_from_euler_deg(const Vec3& deg) {
  const Vec3 r = deg * (std::numbers::pi / 180.0);
  return (Eigen::AngleAxisd(r.z(), Vec3::UnitZ()) * Eigen::AngleAxisd(r.y(), Vec3::UnitY()) *
          Eigen::AngleAxisd(r.x(), Vec3::UnitX()))
      .toRotationMatrix();
}

Sdf Sdf::sphere(double radius) {
  auto n = new_node(Kind::sphere);
  n->a = radius;
  return Sdf(n);
}
Sdf Sdf::box(const Vec3& half_extents) {
  auto n = new_node(Kind::box);
  n->v = half_extents;
  return Sdf(n);
}
Sdf Sdf::cylinder(double radius, double half_height) {
  auto n = new_node(Kind::cylinder);
  n->a = radius;
  n->b = half_height;
  return Sdf(n);
}
Sdf Sdf::capsule(double radius, double half_height) {
  auto n = new_node(Kind::capsule);
  n->a = radius;
  n->b = half_height;
  return Sdf(n);
}
Sdf Sdf::cone(double radius, double height) {
  // A revolved right triangle: exact distance through the 2D polygon distance.
  Sdf s = revolution({Vec2(0, 0), Vec2(radius, 0), Vec2(0, height)});
  auto n = std::make_shared<Node>(*s.node_);
  n->kind = Kind::cone;
  n->a = radius;
  n->b = height;
  return Sdf(n);
}
Sdf Sdf::torus(double major, double minor) {
  auto n = new_node(Kind::torus);
  n->a = major;
  n->b = minor;
  return Sdf(n);
}
Sdf Sdf::ellipsoid(const Vec3& radii) {
  auto n = new_node(Kind::ellipsoid);
  n->v = radii;
  return Sdf(n);
}
Sdf Sdf::revolution(std::vector<Vec2> profile) {
  auto n = new_node(Kind::revolution);
  n->polygon = std::move(profile);
  return Sdf(n);
}
Sdf Sdf::extrusion(std::vector<Vec2> polygon, double half_depth) {
  auto n = new_node(Kind::extrusion);
  n->polygon = std::move(polygon);
  n->a = half_depth;
  return Sdf(n);
}
Sdf Sdf::surface(std::shared_ptr<const SurfaceDistance> surface) {
  auto n = new_node(Kind::surface);
  n->surface = std::move(surface);
  return Sdf(n);
}
Sdf Sdf::unite(std::vector<Sdf> children) {
  auto n = new_node(Kind::unite);
  n->children = std::move(children);
  return Sdf(n);
}
Sdf Sdf::subtract(std::vector<Sdf> children) {
  auto n = new_node(Kind::subtract);
  n->children = std::move(children);
  return Sdf(n);
}
Sdf Sdf::intersect(std::vector<Sdf> children) {
  auto n = new_node(Kind::intersect);
  n->children = std::move(children);
  return Sdf(n);
}
Sdf Sdf::smooth_unite(std::vector<Sdf> children, double k) {
  auto n = new_node(Kind::smooth_unite);
  n->children = std::move(children);
  n->a = k;
  return Sdf(n);
}
Sdf Sdf::transformed(const Vec3& translation, const Mat3& rotation, double scale) const {
  auto n = new_node(Kind::transform);
  n->children = {*this};
  n->translation = translation;
  n->rotation = rotation;
  n->scale = scale;
  return Sdf(n);
}

Sdf::Kind Sdf::kind() const { return node_ ? node_->kind : Kind::unite; }

const std::vector<Sdf>& Sdf::children() const {
  static const std::vector<Sdf> kNone;
  return node_ ? node_->children : kNone;
}
Vec3 Sdf::half_extents() const { return node_ && node_->kind == Kind::box ? node_->v : Vec3::Zero(); }
const std::vector<Vec2>& Sdf::polygon() const {
  static const std::vector<Vec2> kNone;
  return node_ ? node_->polygon : kNone;
}
Sdf::Transform Sdf::transform() const {
  if (!node_ || node_->kind != Kind::transform) return {};
  return {node_->translation, node_->rotation, node_->scale};
}

double Sdf::operator()(const Vec3& p) const {
  if (!node_) return kInf;
  const Node& n = *node_;
  switch (n.kind) {
    case Kind::sphere: return p.norm() - n.a;
    case Kind::box: {
      const Vec3 q = p.cwiseAbs() - n.v;
      return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
    }
    case Kind::cylinder: {
      const double r = std::hypot(p.x(), p.z());
      return op_extrude(r - n.a, std::abs(p.y()) - n.b);
    }
    case Kind::capsule: {
      Vec3 q = p;
      q.y() -= std::clamp(p.y(), -n.b, n.b);
      return q.norm() - n.a;
    }
    case Kind::cone:
    case Kind::revolution: return polygon_signed_distance(n.polygon, Vec2(std::hypot(p.x(), p.z()), p.y()));
    case Kind::torus: return std::hypot(std::hypot(p.x(), p.z()) - n.a, p.y()) - n.b;
    case Kind::ellipsoid: {
      // Quilez: k0 (k0 - 1) / k1 with k0 = |p / r|, k1 = |p / r^2|.
      const double k0 = p.cwiseQuotient(n.v).norm();
      const double k1 = p.cwiseQuotient(n.v.cwiseProduct(n.v)).norm();
      if (k1 == 0) return -n.v.minCoeff();
      return k0 * (k0 - 1.0) / k1;
    }
    case Kind::extrusion:
      return op_extrude(polygon_signed_distance(n.polygon, Vec2(p.x(), p.y())), std::abs(p.z()) - n.a);
    case Kind::surface: return n.surface->signed_distance(p);
    case Kind::unite: {
      double d = kInf;
      for (const Sdf& c : n.children) d = std::min(d, c(p));
      return d;
    }
    case Kind::intersect: {
      double d = -kInf;
      for (const Sdf& c : n.children) d = std::max(d, c(p));
      return n.children.empty() ? kInf : d;
    }
    case Kind::subtract: {
      if (n.children.empty()) return kInf;
      double d = n.children[0](p);
      for (std::size_t i = 1; i < n.children.size(); ++i) d = std::max(d, -n.children[i](p));
      return d;
    }
    case Kind::smooth_unite: {
      if (n.children.empty()) return kInf;
      double d = n.children[0](p);
      for (std::size_t i = 1; i < n.children.size(); ++i) d = smin(d, n.children[i](p), n.a);
      return d;
    }
    case Kind::transform: {
      const Vec3 q = n.rotation.transpose() * (p - n.translation) / n.scale;
      return n.scale * n.children[0](q);
    }
  }
  return kInf;
}

Aabb Sdf::bounds() const {
  Aabb b;
  if (!node_) return b;
  const Node& n = *node_;
  switch (n.kind) {
    case Kind::sphere:
      b.min = Vec3::Constant(-n.a);
      b.max = Vec3::Constant(n.a);
      return b;
    case Kind::box:
    case Kind::ellipsoid:
      b.min = -n.v;
      b.max = n.v;
      return b;
    case Kind::cylinder:
      b.min = Vec3(-n.a, -n.b, -n.a);
      b.max = Vec3(n.a, n.b, n.a);
      return b;
    case Kind::capsule:
      b.min = Vec3(-n.a, -n.b - n.a, -n.a);
      b.max = Vec3(n.a, n.b + n.a, n.a);
      return b;
    case Kind::torus:
      b.min = Vec3(-n.a - n.b, -n.b, -n.a - n.b);
      b.max = Vec3(n.a + n.b, n.b, n.a + n.b);
      return b;
    case Kind::cone:
    case Kind::revolution: {
      double rmax = 0, ymin = kInf, ymax = -kInf;
      for (const Vec2& q : n.polygon) {
        rmax = std::max(rmax, q.x());
        ymin = std::min(ymin, q.y());
        ymax = std::max(ymax, q.y());
      }
      b.min = Vec3(-rmax, ymin, -rmax);
      b.max = Vec3(rmax, ymax, rmax);
      return b;
    }
    case Kind::extrusion:
      for (const Vec2& q : n.polygon) {
        b.extend(Vec3(q.x(), q.y(), -n.a));
        b.extend(Vec3(q.x(), q.y(), n.a));
      }
      return b;
    case Kind::surface: return n.surface->bounds();
    case Kind::unite:
    case Kind::smooth_unite:
      for (const Sdf& c : n.children) {
        const Aabb cb = c.bounds();
        if (!cb.empty()) {
          b.extend(cb.min);
          b.extend(cb.max);
        }
      }
      if (n.kind == Kind::smooth_unite && !b.empty()) {
        b.min.array() -= n.a;
        b.max.array() += n.a;
      }
      return b;
    case Kind::intersect:
      if (n.children.empty()) return b;
      b = n.children[0].bounds();
      for (std::size_t i = 1; i < n.children.size(); ++i) {
        const Aabb cb = n.children[i].bounds();
        b.min = b.min.cwiseMax(cb.min);
        b.max = b.max.cwiseMin(cb.max);
      }
      return b;
    case Kind::subtract: return n.children.empty() ? b : n.children[0].bounds();
    case Kind::transform: return transform_box(n.children[0].bounds(), n.translation, n.rotation, n.scale);
  }
  return b;
}

std::optional<double> Sdf::analytic_volume() const {
  if (!node_) return std::nullopt;
  const Node& n = *node_;
  const double pi = std::numbers::pi;
  switch (n.kind) {
    case Kind::sphere: return 4.0 / 3.0 * pi * n.a * n.a * n.a;
    case Kind::box: return 8.0 * n.v.prod();
    case Kind::cylinder: return pi * n.a * n.a * 2.0 * n.b;
    case Kind::capsule: return pi * n.a * n.a * 2.0 * n.b + 4.0 / 3.0 * pi * n.a * n.a * n.a;
    case Kind::cone: return pi * n.a * n.a * n.b / 3.0;
    case Kind::torus: return 2.0 * pi * pi * n.a * n.b * n.b;
    case Kind::ellipsoid: return 4.0 / 3.0 * pi * n.v.prod();
    case Kind::revolution: {
      // Pappus: V = 2 pi * integral of r dA = (2 pi / 6) * sum (r_j + r_i) * cross_ij.
      double s = 0;
      for (std::size_t i = 0, j = n.polygon.size() - 1; i < n.polygon.size(); j = i, ++i) {
        const Vec2 &p = n.polygon[j], &q = n.polygon[i];
        s += (p.x() + q.x()) * (p.x() * q.y() - q.x() * p.y());
      }
      return std::abs(2.0 * pi * s / 6.0);
    }
    case Kind::extrusion: return std::abs(polygon_area(n.polygon)) * 2.0 * n.a;
    case Kind::transform: {
      const auto v = n.children[0].analytic_volume();
      if (!v) return std::nullopt;
      return *v * n.scale * n.scale * n.scale;
    }
    default: return std::nullopt;
  }
}

}  // namespace shatter
