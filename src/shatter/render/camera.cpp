#include "shatter/render/camera.h"

#include <algorithm>
#include <cmath>

namespace shatter::render {

Vec3 Camera::eye() const {
  const Vec3 dir(std::cos(pitch) * std::sin(yaw), std::sin(pitch), std::cos(pitch) * std::cos(yaw));
  return target + distance * dir;
}

Mat4 look_at(const Vec3& eye, const Vec3& target, const Vec3& up_hint) {
  const Vec3 f = (target - eye).normalized();
  Vec3 s = f.cross(up_hint);
  if (s.squaredNorm() < 1e-12) s = f.cross(Vec3::UnitX());
  s.normalize();
  const Vec3 u = s.cross(f);
  Mat4 m = Mat4::Identity();
  m.block<1, 3>(0, 0) = s.transpose();
  m.block<1, 3>(1, 0) = u.transpose();
  m.block<1, 3>(2, 0) = -f.transpose();
  m(0, 3) = -s.dot(eye);
  m(1, 3) = -u.dot(eye);
  m(2, 3) = f.dot(eye);
  return m;
}

Mat4 Camera::view() const { return look_at(eye(), target, Vec3::UnitY()); }

Mat4 Camera::projection(double aspect) const {
  const double n = std::max(1e-3, distance * 0.01), fa = distance * 100 + 100;
  const double t = 1.0 / std::tan(fov_y / 2);
  Mat4 p = Mat4::Zero();
  p(0, 0) = t / aspect;
  p(1, 1) = t;
  p(2, 2) = -(fa + n) / (fa - n);
  p(2, 3) = -2 * fa * n / (fa - n);
  p(3, 2) = -1;
  return p;
}

Vec3 Camera::project(const Vec3& p, int width, int height) const {
  const Vec4 c = projection(static_cast<double>(width) / height) * view() * Vec4(p.x(), p.y(), p.z(), 1);
  const double w = c.w();
  if (w <= 0) return {0, 0, w};
  return {(c.x() / w * 0.5 + 0.5) * width, (0.5 - c.y() / w * 0.5) * height, w};
}

void Camera::ray(double x, double y, int width, int height, Vec3& origin, Vec3& direction) const {
  const Mat4 inv = (projection(static_cast<double>(width) / height) * view()).inverse();
  const double nx = 2 * x / width - 1, ny = 1 - 2 * y / height;
  Vec4 a = inv * Vec4(nx, ny, -1, 1), b = inv * Vec4(nx, ny, 1, 1);
  const Vec3 pa = a.head<3>() / a.w(), pb = b.head<3>() / b.w();
  origin = eye();
  direction = (pb - pa).normalized();
}

void Camera::orbit(double dyaw, double dpitch) {
  yaw += dyaw;
  pitch = std::clamp(pitch + dpitch, -1.5, 1.5);
}

void Camera::pan(double dx, double dy) {
  const Mat4 v = view();
  const Vec3 right = v.block<1, 3>(0, 0).transpose(), up = v.block<1, 3>(1, 0).transpose();
  target += distance * (dx * right + dy * up);
}

void Camera::zoom(double factor) { distance = std::clamp(distance * factor, 1e-3, 1e5); }

Camera frame_box(const Aabb& box, double yaw, double pitch, double aspect) {
  Camera c;
  c.yaw = yaw;
  c.pitch = pitch;
  if (!(box.min.array() <= box.max.array()).all() || !box.min.allFinite() || !box.max.allFinite()) return c;
  c.target = 0.5 * (box.min + box.max);
  const double r = std::max(0.5 * (box.max - box.min).norm(), 1e-3);
  const double half = std::min(c.fov_y / 2, std::atan(std::tan(c.fov_y / 2) * aspect));
  c.distance = r / std::sin(half) * 1.05;
  return c;
}

}  // namespace shatter::render
