// A run as a glTF 2.0 animation (.glb), for Blender, three.js and other glTF tools
// (docs/scenes.md#gltf). The recorder copies what each frame shows. The file has:
// - one node per body and fragment, with translation and rotation keys;
// - fragments appearing at birth and parents disappearing, by scale keys (STEP);
// - plastic dents as morph targets of the body's mesh (weights, STEP);
// - crack faces as their own primitive, with the material's inside colour.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "shatter/collide/contact.h"
#include "shatter/core/types.h"
#include "shatter/scene/appearance.h"
#include "shatter/world/world.h"

namespace shatter {

class GltfRecorder {
 public:
  /// Record the world as it is now, at world.time(): the live tet bodies' poses, and the surface
  /// of every model not seen before (copied: models may be freed later).
  void add_frame(const World& world);
  /// Number of frames recorded.
  [[nodiscard]] std::size_t frames() const { return times_.size(); }
  /// The binary glTF file of the frames recorded so far.
  [[nodiscard]] std::string glb() const;

  /// One surface of a body (a model version), body frame.
  struct Version {
    std::vector<Vec3> positions;
    std::vector<TriIndices> triangles;
    std::vector<std::uint8_t> crack_face;
    Appearance look;
    std::uint64_t hash = 0;
  };
  /// A body's pose at a frame, and which of its versions it had.
  struct Sample {
    std::size_t frame = 0;
    std::size_t version = 0;
    Vec3 position = Vec3::Zero();
    Quat orientation = Quat::Identity();
  };
  struct Track {
    BodyId id;
    std::vector<Version> versions;
    std::vector<Sample> samples;  ///< by frame; a body is sampled from its first frame to its removal
  };

 private:
  std::vector<double> times_;
  std::vector<Track> tracks_;          ///< by body slot
  std::vector<std::size_t> track_of_;  ///< slot -> index + 1 in tracks_ (0: none)
  bool have_ground_ = false;
  Plane ground_;
};

}  // namespace shatter
