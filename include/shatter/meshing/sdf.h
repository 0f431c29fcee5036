// Signed distance functions (negative inside, metres) for the mesher: primitives, surfaces of
// revolution and extrusions, CSG (union, difference, intersection, smooth union) and rigid/uniform
// transforms, as an immutable tree that is cheap to copy and safe to evaluate from many threads.
//
// Formulas follow Quilez's catalogue of distance functions (iquilezles.org/articles/distfunctions).
// Exact distances: sphere, box, cylinder, capsule, torus, revolution, extrusion, translate/rotate/
// scale. Bounds (not exact) where noted: ellipsoid (Quilez's k0(k0-1)/k1 approximation: correct
// sign and zero set, within a factor of the axis ratio of the true distance), CSG results (min/max of
// distances is a bound away from the surface, exact sign and zero set), smooth union (the zero set
// is rounded where the operands meet, by at most k/4).
#pragma once

#include <memory>
#include <optional>
#include <vector>

#include "shatter/core/error.h"
#include "shatter/core/types.h"

namespace shatter {

class SurfaceDistance;  // meshing/surface_sdf.h

/// A signed distance function as an immutable tree of shared nodes (copies are cheap).
class Sdf {
 public:
  /// Node type: a primitive, a CSG operation or a transform.
  enum class Kind {
    sphere,
    box,
    cylinder,
    capsule,
    cone,
    torus,
    ellipsoid,
    revolution,
    extrusion,
    surface,
    unite,
    subtract,
    intersect,
    smooth_unite,
    transform,
  };

  /// Empty tree (evaluates to +inf); use the builders below.
  Sdf() = default;

  // --- Primitives, centred at the origin, Y up. All lengths in m, must be > 0. ---
  /// Sphere of `radius`.
  static Sdf sphere(double radius);
  /// Box with half extents (x, y, z).
  static Sdf box(const Vec3& half_extents);
  /// Cylinder around Y, y in [-half_height, half_height].
  static Sdf cylinder(double radius, double half_height);
  /// Segment y in [-half_height, half_height] swept by a sphere of `radius`.
  static Sdf capsule(double radius, double half_height);
  /// Solid cone around Y: base disk of `radius` at y = 0, apex at y = height.
  static Sdf cone(double radius, double height);
  /// Torus around Y in the XZ plane: ring radius `major`, tube radius `minor` (< major).
  static Sdf torus(double major, double minor);
  /// Ellipsoid with semi-axes (x, y, z) (approximate distance, see top of file).
  static Sdf ellipsoid(const Vec3& radii);
  /// Closed polygon (r, y) with r >= 0, revolved around Y. Either orientation; no
  /// self-intersections (#points >= 3).
  static Sdf revolution(std::vector<Vec2> profile);
  /// Closed polygon (x, y) extruded along Z over z in [-half_depth, half_depth].
  static Sdf extrusion(std::vector<Vec2> polygon, double half_depth);
  /// A closed triangle surface (signed by its generalized winding number).
  static Sdf surface(std::shared_ptr<const SurfaceDistance> surface);

  // --- CSG and transforms. ---
  /// Union of the children (min of their distances).
  static Sdf unite(std::vector<Sdf> children);
  /// a minus every later child.
  static Sdf subtract(std::vector<Sdf> children);
  /// Intersection of the children (max of their distances).
  static Sdf intersect(std::vector<Sdf> children);
  /// Polynomial smooth minimum (Quilez): h = max(k - |a-b|, 0) / k, min(a,b) - h^2 k / 4,
  /// folded left over the children. k (m) is the blend width.
  static Sdf smooth_unite(std::vector<Sdf> children, double k);
  /// x -> translation + rotation * scale * x applied to the shape (scale > 0).
  [[nodiscard]] Sdf transformed(const Vec3& translation, const Mat3& rotation = Mat3::Identity(),
                                double scale = 1.0) const;
  /// The shape moved by t (m).
  [[nodiscard]] Sdf translated(const Vec3& t) const { return transformed(t); }
  /// The shape rotated by r about the origin.
  [[nodiscard]] Sdf rotated(const Mat3& r) const { return transformed(Vec3::Zero(), r); }
  /// The shape scaled by s (> 0) about the origin.
  [[nodiscard]] Sdf scaled(double s) const { return transformed(Vec3::Zero(), Mat3::Identity(), s); }

  /// Signed distance at p (m): < 0 inside.
  [[nodiscard]] double operator()(const Vec3& p) const;
  /// A box that contains the whole inside (m).
  [[nodiscard]] Aabb bounds() const;
  /// Exact volume (m^3) for primitives and their transforms; nullopt for CSG and surfaces.
  [[nodiscard]] std::optional<double> analytic_volume() const;
  /// Whether this is the empty tree.
  [[nodiscard]] bool empty() const { return node_ == nullptr; }
  /// Type of the root node (unite for the empty tree).
  [[nodiscard]] Kind kind() const;

  // --- Read access to the tree (for the structured meshers). ---
  /// Children of CSG nodes; the one child of a transform; empty otherwise.
  [[nodiscard]] const std::vector<Sdf>& children() const;
  /// Box half extents (box); zero otherwise.
  [[nodiscard]] Vec3 half_extents() const;
  /// Revolution (or cone) profile (r, y) or extrusion polygon (x, y); empty otherwise.
  [[nodiscard]] const std::vector<Vec2>& polygon() const;
  /// The map x -> translation + rotation * scale * x.
  struct Transform {
    Vec3 translation = Vec3::Zero();   ///< m
    Mat3 rotation = Mat3::Identity();  ///< rotation matrix
    double scale = 1.0;                ///< uniform scale (> 0)
  };
  /// A transform node's map (identity for other nodes).
  [[nodiscard]] Transform transform() const;

  /// A node of the tree (defined in sdf.cpp).
  struct Node;

 private:
  explicit Sdf(std::shared_ptr<const Node> node) : node_(std::move(node)) {}
  std::shared_ptr<const Node> node_;
};

/// Euler angles in degrees (about X, then Y, then Z) to a rotation matrix R = Rz Ry Rx.
Mat3 rotation_from_euler_deg(const Vec3& degrees);

/// Signed distance from p to a closed polygon (Quilez's sdPolygon): < 0 inside (even-odd rule).
double polygon_signed_distance(const std::vector<Vec2>& v, const Vec2& p);
/// Signed area of a closed polygon (> 0 counter-clockwise), m^2.
double polygon_area(const std::vector<Vec2>& v);

/// Checks for polygons used by revolution/extrusion: >= 3 points, finite, non-zero area, for
/// revolution r >= 0. `field` names the parameter in the error.
Result<void> check_polygon(const std::vector<Vec2>& polygon, bool revolution, const std::string& field);

}  // namespace shatter
