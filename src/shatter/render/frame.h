// What the renderer draws, gathered from a world without any OpenGL: each live tet body with its
// pose, look and per-tet display stress, the ground, and marks of recent events (impact points,
// crack planes). Shared by `shatter view` and `shatter render`.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "shatter/collide/contact.h"
#include "shatter/core/types.h"
#include "shatter/fem/material.h"
#include "shatter/render/camera.h"
#include "shatter/scene/appearance.h"
#include "shatter/world/world.h"

namespace shatter::render {

/// One body to draw.
struct DrawBody {
  BodyId id;
  const BodyModel* model = nullptr;  ///< its rest geometry (body frame)
  Vec3 position = Vec3::Zero();      ///< body to world: x = position + orientation r
  Quat orientation = Quat::Identity();
  Appearance look;
  std::span<const double> stress;  ///< display stress per tet, Pa (may be empty)
  bool highlight = false;          ///< drawn lit up (the selection)
};

/// A recent event, drawn as a mark that fades.
struct EventMark {
  enum class Kind : std::uint8_t { impact, crack };
  Kind kind = Kind::impact;
  double time = 0;              ///< s
  Vec3 point = Vec3::Zero();    ///< impact point or crack origin, world, m
  Vec3 normal = Vec3::UnitY();  ///< crack plane normal
  double radius = 0;            ///< crack radius, m
};

/// Marks of the events of the last `keep` seconds (at most the latest kMaxMarks).
class EventMarks {
 public:
  static constexpr std::size_t kMaxMarks = 24;
  explicit EventMarks(double keep = 1.0) : keep_(keep) {}
  /// Add a step's impacts and cracks (at the world's time) and drop marks older than `keep`.
  void add(const StepEvents& events, double time);
  void clear() { marks_.clear(); }
  [[nodiscard]] const std::vector<EventMark>& marks() const { return marks_; }
  [[nodiscard]] double keep() const { return keep_; }

 private:
  double keep_;
  std::vector<EventMark> marks_;
};

/// Everything a frame shows.
struct DrawFrame {
  double time = 0;  ///< s
  std::vector<DrawBody> bodies;
  std::optional<Plane> ground;
  std::vector<EventMark> marks;
  double mark_keep = 1.0;  ///< s a mark lasts (EventMarks::keep): marks fade over it
  Aabb bounds;             ///< of the bodies, m
};

/// The live tet bodies and the first plane of a world (bodies keep spans into the world: use the
/// frame before the world steps again). `selected` is drawn highlighted.
DrawFrame frame_from_world(const World& world, const EventMarks* marks = nullptr, BodyId selected = {});

/// A camera that sees the frame's bodies and the ground below them (where they will fall), from
/// the default direction.
Camera frame_camera(const DrawFrame& frame, double aspect);

/// The body whose surface the ray (origin, unit direction) meets first, with the point and the
/// distance; index -1 when it meets none.
struct Pick {
  BodyId body;
  Vec3 point = Vec3::Zero();
  Vec3 normal = Vec3::UnitY();  ///< outward surface normal there, world
  double distance = 0;
};
Pick pick_body(const World& world, const Vec3& origin, const Vec3& direction);

}  // namespace shatter::render
