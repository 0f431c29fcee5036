#include "shatter/render/frame.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace shatter::render {
void EventMarks::add(const StepEvents& events, double time) {
  for (const ImpactRecord& r : events.impacts)
    marks_.push_back({.kind = EventMark::Kind::impact, .time = time, .point = r.point, .radius = r.collision_radius});
  for (const CrackRecord& c : events.cracks)
    marks_.push_back(
        {.kind = EventMark::Kind::crack, .time = time, .point = c.origin, .normal = c.normal, .radius = c.radius});
  std::erase_if(marks_, [&](const EventMark& m) { return m.time < time - keep_ || m.time > time; });
  // A collapse makes hundreds of events: only the latest stay readable.
  if (marks_.size() > kMaxMarks) marks_.erase(marks_.begin(), marks_.end() - static_cast<std::ptrdiff_t>(kMaxMarks));
}

DrawFrame frame_from_world(const World& world, const EventMarks* marks, BodyId selected) {
  DrawFrame f;
  f.time = world.time();
  for (Index slot = 0; slot < world.body_count(); ++slot) {
    const BodyId id = world.body_id(slot);
    if (world.removed(id)) continue;
    if (const Plane* p = world.plane(id)) {
      if (!f.ground) f.ground = *p;
      continue;
    }
    const BodyModel* m = world.model(id);
    if (!m) continue;
    const RigidState& r = world.rigid_state(id);
    DrawBody b;
    b.id = id;
    b.model = m;
    b.position = r.position;
    b.orientation = r.orientation;
    b.look = appearance_for(m->fem.material);
    b.stress = world.display_stress(id);
    b.highlight = id == selected && selected.index >= 0;
    f.bodies.push_back(b);
    const Aabb box = world.bounds(id);
    f.bounds.extend(box.min);
    f.bounds.extend(box.max);
  }
  if (marks) {
    f.marks = marks->marks();
    f.mark_keep = marks->keep();
  }
  return f;
}

Camera frame_camera(const DrawFrame& frame, double aspect) {
  Aabb box = frame.bounds;
  if (!(box.min.array() <= box.max.array()).all()) {
    box.extend(Vec3(-1, 0, -1));
    box.extend(Vec3(1, 1, 1));
  }
  if (frame.ground && frame.ground->normal.y() > 0.5) {  // down to the ground
    const double y = frame.ground->offset / frame.ground->normal.y();
    box.extend(Vec3(box.min.x(), y, box.min.z()));
  }
  Camera c = frame_box(box, 0.6, 0.4, aspect);
  // Closer while every corner of the box stays inside the picture with a margin.
  constexpr int kW = 1000;
  const int kH = std::max(1, static_cast<int>(kW / aspect));
  auto fits = [&](const Camera& cam) {
    for (int k = 0; k < 8; ++k) {
      const Vec3 corner((k & 1) ? box.max.x() : box.min.x(), (k & 2) ? box.max.y() : box.min.y(),
                        (k & 4) ? box.max.z() : box.min.z());
      const Vec3 px = cam.project(corner, kW, kH);
      if (px.z() <= 0 || px.x() < 0.05 * kW || px.x() > 0.95 * kW || px.y() < 0.05 * kH || px.y() > 0.95 * kH)
        return false;
    }
    return true;
  };
  for (int i = 0; i < 40; ++i) {
    Camera closer = c;
    closer.distance *= 0.95;
    if (!fits(closer)) break;
    c = closer;
  }
  return c;
}

Pick pick_body(const World& world, const Vec3& origin, const Vec3& direction) {
  Pick best;
  best.distance = std::numeric_limits<double>::infinity();
  for (Index slot = 0; slot < world.body_count(); ++slot) {
    const BodyId id = world.body_id(slot);
    if (world.removed(id) || !world.model(id)) continue;
    // Skip bodies whose box the ray misses (slab test).
    const Aabb box = world.bounds(id);
    double t0 = 0, t1 = best.distance;
    bool miss = false;
    for (int k = 0; k < 3 && !miss; ++k) {
      const double inv = 1.0 / direction[k];
      double a = (box.min[k] - origin[k]) * inv, b = (box.max[k] - origin[k]) * inv;
      if (a > b) std::swap(a, b);
      t0 = std::max(t0, a);
      t1 = std::min(t1, b);
      miss = t0 > t1;
    }
    if (miss) continue;
    const BodySurface s = world.surface(id);
    for (const TriIndices& t : s.triangles) {
      // Moller-Trumbore.
      const Vec3 &p0 = s.positions[t[0]], &p1 = s.positions[t[1]], &p2 = s.positions[t[2]];
      const Vec3 e1 = p1 - p0, e2 = p2 - p0, pv = direction.cross(e2);
      const double det = e1.dot(pv);
      if (std::abs(det) < 1e-18) continue;
      const Vec3 tv = origin - p0;
      const double u = tv.dot(pv) / det;
      if (u < 0 || u > 1) continue;
      const Vec3 qv = tv.cross(e1);
      const double v = direction.dot(qv) / det;
      if (v < 0 || u + v > 1) continue;
      const double d = e2.dot(qv) / det;
      if (d > 0 && d < best.distance) {
        best.distance = d;
        best.body = id;
        best.point = origin + d * direction;
        best.normal = e1.cross(e2).normalized();
      }
    }
  }
  if (best.body.index < 0) best.distance = 0;
  return best;
}

}  // namespace shatter::render
