// An orbit camera (Y up) as in common 3D tools: it looks at `target` from `distance` metres, turned
// by `yaw` about the vertical and raised by `pitch`. Matrices follow OpenGL (right-handed view,
// clip z in [-1, 1]).
#pragma once

#include "shatter/core/types.h"

namespace shatter::render {

struct Camera {
  Vec3 target = Vec3(0, 0.5, 0);  ///< point looked at, m
  double distance = 3;            ///< m
  double yaw = 0.6;               ///< rad about +Y; 0 looks along -Z
  double pitch = 0.35;            ///< rad above the horizon
  double fov_y = 0.7;             ///< vertical field of view, rad

  /// Eye position, m.
  [[nodiscard]] Vec3 eye() const;
  /// World to eye.
  [[nodiscard]] Mat4 view() const;
  /// Eye to clip for an aspect (width / height); near and far follow the distance.
  [[nodiscard]] Mat4 projection(double aspect) const;
  /// Pixel coordinates (x right, y down from the top-left corner) of a world point in a
  /// width x height image, and its depth in front of the eye (m; <= 0: behind).
  [[nodiscard]] Vec3 project(const Vec3& p, int width, int height) const;
  /// The world ray through pixel (x, y): origin (the eye) and unit direction.
  void ray(double x, double y, int width, int height, Vec3& origin, Vec3& direction) const;

  /// Turn, raise (clamped short of straight up and down), pan in the view plane, zoom.
  void orbit(double dyaw, double dpitch);
  void pan(double dx, double dy);  ///< in units of the distance
  void zoom(double factor);        ///< distance *= factor
};

/// World to eye for an eye looking at `target`, `up_hint` up (any other axis when they line up).
Mat4 look_at(const Vec3& eye, const Vec3& target, const Vec3& up_hint);

/// A camera that sees the box whole from the given direction.
Camera frame_box(const Aabb& box, double yaw = 0.6, double pitch = 0.35, double aspect = 16.0 / 9.0);

}  // namespace shatter::render
