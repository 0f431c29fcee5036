#include "shatter/scene/gltf.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>

namespace shatter {
namespace {

using Json = nlohmann::json;

// glTF constants.
constexpr int kFloat = 5126;
constexpr int kUnsignedInt = 5125;
constexpr int kArrayBuffer = 34962;
constexpr int kElementArrayBuffer = 34963;

// The binary chunk and the JSON lists that point into it.
class Builder {
 public:
  Json views = Json::array(), accessors = Json::array();
  std::string bin;

  int view(const void* data, std::size_t bytes, int target) {
    while (bin.size() % 4) bin.push_back('\0');
    Json v{{"buffer", 0}, {"byteOffset", bin.size()}, {"byteLength", bytes}};
    if (target) v["target"] = target;
    bin.append(static_cast<const char*>(data), bytes);
    views.push_back(v);
    return static_cast<int>(views.size()) - 1;
  }
  // Floats, `width` per element ("SCALAR", "VEC3", "VEC4"), with min and max when asked.
  int floats(const std::vector<float>& data, int width, bool bounds, int target = 0) {
    const int v = view(data.data(), data.size() * sizeof(float), target);
    const char* type = width == 1 ? "SCALAR" : width == 3 ? "VEC3" : "VEC4";
    Json a{{"bufferView", v},
           {"componentType", kFloat},
           {"count", data.size() / static_cast<std::size_t>(width)},
           {"type", type}};
    if (bounds && !data.empty()) {
      Json lo = Json::array(), hi = Json::array();
      for (int c = 0; c < width; ++c) {
        float mn = std::numeric_limits<float>::infinity(), mx = -mn;
        for (std::size_t i = static_cast<std::size_t>(c); i < data.size(); i += static_cast<std::size_t>(width)) {
          mn = std::min(mn, data[i]);
          mx = std::max(mx, data[i]);
        }
        lo.push_back(mn);
        hi.push_back(mx);
      }
      a["min"] = lo;
      a["max"] = hi;
    }
    accessors.push_back(a);
    return static_cast<int>(accessors.size()) - 1;
  }
  int indices(const std::vector<std::uint32_t>& data) {
    const int v = view(data.data(), data.size() * sizeof(std::uint32_t), kElementArrayBuffer);
    accessors.push_back(
        {{"bufferView", v}, {"componentType", kUnsignedInt}, {"count", data.size()}, {"type", "SCALAR"}});
    return static_cast<int>(accessors.size()) - 1;
  }
};

void push3(std::vector<float>& out, const Vec3& v) {
  out.push_back(static_cast<float>(v.x()));
  out.push_back(static_cast<float>(v.y()));
  out.push_back(static_cast<float>(v.z()));
}

std::vector<float> vertex_normals(const GltfRecorder::Version& v) {
  std::vector<Vec3> n(v.positions.size(), Vec3::Zero());
  for (const TriIndices& t : v.triangles) {
    const Vec3 fn = (v.positions[t[1]] - v.positions[t[0]]).cross(v.positions[t[2]] - v.positions[t[0]]);
    for (Index i : t) n[static_cast<std::size_t>(i)] += fn;
  }
  std::vector<float> out;
  out.reserve(n.size() * 3);
  for (const Vec3& x : n) push3(out, x.squaredNorm() > 0 ? Vec3(x.normalized()) : Vec3::UnitY());
  return out;
}

// Materials, one per colour and finish.
int material(Json& materials, std::map<std::string, int>& known, const Vec3& colour, const Appearance& look) {
  const double metallic = look.grain == Appearance::Grain::metal ? 0.8 : 0.0;
  const double roughness = 1.0 - 0.8 * look.gloss;
  char key[128];
  std::snprintf(key, sizeof key, "%.4f %.4f %.4f %.3f %.3f", colour.x(), colour.y(), colour.z(), metallic, roughness);
  if (auto it = known.find(key); it != known.end()) return it->second;
  materials.push_back({{"pbrMetallicRoughness",
                        {{"baseColorFactor", {colour.x(), colour.y(), colour.z(), 1.0}},
                         {"metallicFactor", metallic},
                         {"roughnessFactor", roughness}}}});
  const int id = static_cast<int>(materials.size()) - 1;
  known[key] = id;
  return id;
}

}  // namespace

void GltfRecorder::add_frame(const World& world) {
  const double t = world.time();
  if (!times_.empty() && !(t > times_.back())) return;  // times must increase
  times_.push_back(t);
  const std::size_t frame = times_.size() - 1;
  if (track_of_.size() < static_cast<std::size_t>(world.body_count()))
    track_of_.resize(static_cast<std::size_t>(world.body_count()), 0);
  for (Index slot = 0; slot < world.body_count(); ++slot) {
    const BodyId id = world.body_id(slot);
    if (const Plane* p = world.plane(id)) {
      if (!have_ground_) {
        have_ground_ = true;
        ground_ = *p;
      }
      continue;
    }
    const BodyModel* m = world.model(id);
    if (!m || world.removed(id)) continue;
    std::size_t& ti = track_of_[static_cast<std::size_t>(slot)];
    if (ti == 0 || tracks_[ti - 1].id != id) {  // a body first seen (or a slot given to a new body)
      tracks_.push_back({.id = id, .versions = {}, .samples = {}});
      ti = tracks_.size();
    }
    Track& track = tracks_[ti - 1];
    const std::uint64_t h = surface_hash(*m);
    if (track.versions.empty() || track.versions.back().hash != h)
      track.versions.push_back({.positions = m->surface.positions,
                                .triangles = m->surface.triangles,
                                .crack_face = m->crack_face,
                                .look = appearance_for(m->fem.material),
                                .hash = h});
    const RigidState& r = world.rigid_state(id);
    track.samples.push_back({frame, track.versions.size() - 1, r.position, r.orientation.normalized()});
  }
}

std::string GltfRecorder::glb() const {
  Builder b;
  Json nodes = Json::array(), meshes = Json::array(), materials = Json::array();
  Json channels = Json::array(), samplers = Json::array();
  std::map<std::string, int> known_materials;
  std::vector<float> times;
  times.reserve(times_.size());
  for (const double t : times_) times.push_back(static_cast<float>(t));
  const int time_accessor = times.empty() ? -1 : b.floats(times, 1, true);

  // The ground: a square of 40 m under the bodies.
  if (have_ground_) {
    Vec3 t1 = ground_.normal.cross(Vec3::UnitX());
    if (t1.squaredNorm() < 1e-6) t1 = ground_.normal.cross(Vec3::UnitZ());
    t1.normalize();
    const Vec3 t2 = ground_.normal.cross(t1);  // t1, t2, normal right-handed: the face points up
    const Vec3 o = ground_.offset * ground_.normal;
    std::vector<float> pos, nrm;
    for (const auto& [a, c] : {std::pair{-1, -1}, std::pair{1, -1}, std::pair{1, 1}, std::pair{-1, 1}}) {
      push3(pos, o + 20.0 * (a * t1 + c * t2));
      push3(nrm, ground_.normal);
    }
    const int p = b.floats(pos, 3, true, kArrayBuffer);
    const int n = b.floats(nrm, 3, false, kArrayBuffer);
    const int i = b.indices({0, 1, 2, 0, 2, 3});
    const int mat = material(materials, known_materials, Vec3(0.2, 0.2, 0.19), Appearance{.gloss = 0.05});
    meshes.push_back(
        {{"name", "ground"},
         {"primitives",
          Json::array({{{"attributes", {{"POSITION", p}, {"NORMAL", n}}}, {"indices", i}, {"material", mat}}})}});
    nodes.push_back({{"name", "ground"}, {"mesh", static_cast<int>(meshes.size()) - 1}});
  }

  for (const Track& track : tracks_) {
    // Segments: runs of versions with the same triangles (dents move vertices only), each one node
    // whose later versions are morph targets of its first.
    std::size_t first = 0;
    int segment = 0;
    while (first < track.versions.size()) {
      const Version& base = track.versions[first];
      std::size_t last = first;
      while (last + 1 < track.versions.size() && track.versions[last + 1].triangles == base.triangles &&
             track.versions[last + 1].positions.size() == base.positions.size())
        ++last;
      // Offsets o_k (body frame): the translation that best lays version k over the base (least
      // squares), so that morph displacements are small; the node's translation makes up for it.
      std::vector<Vec3> offset(last - first + 1, Vec3::Zero());
      for (std::size_t k = first + 1; k <= last; ++k) {
        Vec3 sum = Vec3::Zero();
        for (std::size_t i = 0; i < base.positions.size(); ++i)
          sum += base.positions[i] - track.versions[k].positions[i];
        offset[k - first] = sum / static_cast<double>(std::max<std::size_t>(base.positions.size(), 1));
      }
      // Mesh.
      std::vector<float> pos;
      for (const Vec3& p : base.positions) push3(pos, p);
      const int pa = b.floats(pos, 3, true, kArrayBuffer);
      const int na = b.floats(vertex_normals(base), 3, false, kArrayBuffer);
      Json targets = Json::array();
      for (std::size_t k = first + 1; k <= last; ++k) {
        std::vector<float> d;
        const Version& v = track.versions[k];
        for (std::size_t i = 0; i < base.positions.size(); ++i)
          push3(d, v.positions[i] + offset[k - first] - base.positions[i]);
        targets.push_back({{"POSITION", b.floats(d, 3, true, kArrayBuffer)}});
      }
      Json primitives = Json::array();
      for (const bool crack : {false, true}) {
        std::vector<std::uint32_t> idx;
        for (std::size_t t = 0; t < base.triangles.size(); ++t) {
          const bool is_crack = t < base.crack_face.size() && base.crack_face[t] != 0;
          if (is_crack != crack) continue;
          for (Index i : base.triangles[t]) idx.push_back(static_cast<std::uint32_t>(i));
        }
        if (idx.empty()) continue;
        Json prim{{"attributes", {{"POSITION", pa}, {"NORMAL", na}}},
                  {"indices", b.indices(idx)},
                  {"material",
                   material(materials, known_materials, crack ? base.look.inside : base.look.outside, base.look)}};
        if (!targets.empty()) prim["targets"] = targets;
        primitives.push_back(prim);
      }
      if (primitives.empty()) {
        first = last + 1;
        ++segment;
        continue;
      }
      const std::string name =
          "body " + std::to_string(track.id.index) + (segment ? "." + std::to_string(segment) : "");
      Json mesh{{"name", name}, {"primitives", primitives}};
      const std::size_t n_targets = last - first;
      if (n_targets) mesh["weights"] = std::vector<double>(n_targets, 0.0);
      meshes.push_back(mesh);
      const int mesh_id = static_cast<int>(meshes.size()) - 1;

      // Keys at every frame: the pose while this segment is shown, scale 0 (and the nearest pose)
      // before and after.
      std::vector<const Sample*> at(times_.size(), nullptr);
      for (const Sample& s : track.samples)
        if (s.version >= first && s.version <= last) at[s.frame] = &s;
      const Sample* nearest = nullptr;
      for (const Sample* s : at)
        if (s) {
          nearest = s;
          break;
        }
      std::vector<float> tr, rot, scl, wts;
      for (std::size_t f = 0; f < times_.size(); ++f) {
        const Sample* s = at[f] ? at[f] : nearest;
        if (at[f]) nearest = at[f];
        const Vec3 o = s ? offset[s->version - first] : Vec3::Zero();
        const Quat q = s ? s->orientation : Quat::Identity();
        push3(tr, s ? Vec3(s->position - q * o) : Vec3::Zero());
        rot.insert(rot.end(), {static_cast<float>(q.x()), static_cast<float>(q.y()), static_cast<float>(q.z()),
                               static_cast<float>(q.w())});
        const float shown = at[f] ? 1.0F : 0.0F;
        scl.insert(scl.end(), {shown, shown, shown});
        for (std::size_t k = 1; k <= n_targets; ++k) wts.push_back(at[f] && at[f]->version == first + k ? 1.0F : 0.0F);
      }
      Json node{{"name", name}, {"mesh", mesh_id}, {"extras", {{"body", track.id.index}}}};
      if (!times_.empty()) {
        node["translation"] = {tr[0], tr[1], tr[2]};
        node["rotation"] = {rot[0], rot[1], rot[2], rot[3]};
        node["scale"] = {scl[0], scl[1], scl[2]};
        const int node_id = static_cast<int>(nodes.size());
        auto channel = [&](const char* path, const std::vector<float>& values, int width, const char* interpolation) {
          samplers.push_back(
              {{"input", time_accessor}, {"output", b.floats(values, width, false)}, {"interpolation", interpolation}});
          channels.push_back(
              {{"sampler", static_cast<int>(samplers.size()) - 1}, {"target", {{"node", node_id}, {"path", path}}}});
        };
        channel("translation", tr, 3, "LINEAR");
        channel("rotation", rot, 4, "LINEAR");
        channel("scale", scl, 3, "STEP");
        if (n_targets) channel("weights", wts, 1, "STEP");
      }
      nodes.push_back(node);
      first = last + 1;
      ++segment;
    }
  }

  Json gltf{{"asset", {{"version", "2.0"}, {"generator", "shatter 0.1.0"}}}, {"scene", 0}};
  Json scene_nodes = Json::array();
  for (std::size_t i = 0; i < nodes.size(); ++i) scene_nodes.push_back(i);
  gltf["scenes"] = Json::array({{{"nodes", scene_nodes}}});
  if (!nodes.empty()) gltf["nodes"] = nodes;
  if (!meshes.empty()) gltf["meshes"] = meshes;
  if (!materials.empty()) gltf["materials"] = materials;
  if (!channels.empty())
    gltf["animations"] = Json::array({{{"name", "run"}, {"channels", channels}, {"samplers", samplers}}});
  while (b.bin.size() % 4) b.bin.push_back('\0');
  if (!b.bin.empty()) {
    gltf["buffers"] = Json::array({{{"byteLength", b.bin.size()}}});
    gltf["bufferViews"] = b.views;
    gltf["accessors"] = b.accessors;
  }

  std::string json = gltf.dump();
  while (json.size() % 4) json.push_back(' ');
  std::string out;
  auto u32 = [&](std::uint32_t v) {
    for (int k = 0; k < 4; ++k) out.push_back(static_cast<char>((v >> (8 * k)) & 0xff));  // little-endian
  };
  const std::size_t total = 12 + 8 + json.size() + (b.bin.empty() ? 0 : 8 + b.bin.size());
  u32(0x46546C67U);  // "glTF"
  u32(2);
  u32(static_cast<std::uint32_t>(total));
  u32(static_cast<std::uint32_t>(json.size()));
  u32(0x4E4F534AU);  // "JSON"
  out += json;
  if (!b.bin.empty()) {
    u32(static_cast<std::uint32_t>(b.bin.size()));
    u32(0x004E4942U);  // "BIN\0"
    out += b.bin;
  }
  return out;
}

}  // namespace shatter
