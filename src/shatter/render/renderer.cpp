#include "shatter/render/renderer.h"

#include <epoxy/gl.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "shatter/core/hash.h"

namespace shatter::render {
namespace {

// Shaders. Colours are linear; the main pass writes gamma 2.
constexpr const char* kMainVs = R"(#version 330 core
layout(location = 0) in vec3 a_pos;     // body frame, m
layout(location = 1) in vec3 a_normal;  // body frame
layout(location = 2) in vec3 a_rest;    // rest coordinates for solid textures, m
layout(location = 3) in float a_stress; // display stress of the face's tet, Pa
uniform mat4 u_model;
uniform mat4 u_view_proj;
uniform mat4 u_light_vp;
uniform float u_stress_inv_scale;
out vec3 v_world;
out vec3 v_normal;
out vec3 v_rest;
out float v_stress;
out vec4 v_light;
void main() {
  vec4 w = u_model * vec4(a_pos, 1.0);
  v_world = w.xyz;
  v_normal = mat3(u_model) * a_normal;
  v_rest = a_rest;
  v_stress = a_stress * u_stress_inv_scale;
  v_light = u_light_vp * w;
  gl_Position = u_view_proj * w;
}
)";

// Compiled three times, with PART 0 for a body's outer faces, 1 for the faces its cracks opened and 2
// for the stress view: llvmpipe runs both sides of every branch under a mask, so one shader with a
// branch per kind of face would pay every fragment for the crack faces' four octaves of noise.
constexpr const char* kMainFs = R"(
in vec3 v_world;
in vec3 v_normal;
in vec3 v_rest;
in float v_stress;
in vec4 v_light;
uniform vec3 u_eye;
uniform vec3 u_light_dir;
uniform sampler2DShadow u_shadow;
uniform int u_use_shadow;
uniform vec3 u_outside;
uniform vec3 u_inside;
uniform float u_gloss;
uniform float u_highlight;
out vec4 o_color;

float hash3(vec3 p) {
  p = fract(p * 0.3183099 + vec3(0.71, 0.113, 0.419));
  p *= 17.0;
  return fract(p.x * p.y * p.z * (p.x + p.y + p.z));
}
float noise3(vec3 x) {
  vec3 i = floor(x);
  vec3 f = fract(x);
  f = f * f * (3.0 - 2.0 * f);
  return mix(mix(mix(hash3(i), hash3(i + vec3(1, 0, 0)), f.x),
                 mix(hash3(i + vec3(0, 1, 0)), hash3(i + vec3(1, 1, 0)), f.x), f.y),
             mix(mix(hash3(i + vec3(0, 0, 1)), hash3(i + vec3(1, 0, 1)), f.x),
                 mix(hash3(i + vec3(0, 1, 1)), hash3(i + vec3(1, 1, 1)), f.x), f.y), f.z);
}
float fbm(vec3 p) {
  float s = 0.0, a = 0.5;
  for (int i = 0; i < 3; ++i) { s += a * noise3(p); p *= 2.03; a *= 0.5; }
  return s;
}
// Solid textures in rest coordinates (m): the same at a point in every fragment of a body. One
// formula for every grain, its numbers per grain as uniforms (set_grain): llvmpipe runs both
// sides of every branch under a mask, so a branch per grain would cost every grain's noise.
uniform vec3 u_in_noise;   // inside: base, amplitude, frequency (1/m) of fbm
uniform float u_specks;    // inside: weight of dark specks (stone)
uniform vec3 u_out_noise;  // outside: base, amplitude, frequency (1/m) of one noise octave
uniform float u_bands;     // outside: weight of cobalt bands (glazed porcelain)
vec3 inside_color(vec3 r) {
  vec3 c = u_inside * (u_in_noise.x + u_in_noise.y * fbm(r * u_in_noise.z));
  float speck = u_specks * step(0.8, noise3(r * 160.0));
  return mix(c, c * 0.45, speck);
}
vec3 outside_color(vec3 r) {
  vec3 c = u_outside * (u_out_noise.x + u_out_noise.y * noise3(r * u_out_noise.z));
  float band = smoothstep(0.35, 0.45, abs(fract(r.y * 9.0) - 0.5));
  return mix(c, vec3(0.06, 0.12, 0.45), u_bands * 0.85 * band);
}
float shadow_factor(vec3 n) {
  if (u_use_shadow == 0) return 1.0;
  vec3 p = v_light.xyz / v_light.w * 0.5 + 0.5;
  if (p.x < 0.0 || p.x > 1.0 || p.y < 0.0 || p.y > 1.0 || p.z > 1.0) return 1.0;
  float bias = 0.0008 + 0.002 * (1.0 - max(dot(n, u_light_dir), 0.0));
  // Four bilinear compare taps (each a 2x2 filter in hardware): soft edges at a third of the cost
  // of a 3x3 kernel, which matters on a software rasterizer.
  vec2 texel = 0.75 / vec2(textureSize(u_shadow, 0));
  float s = texture(u_shadow, vec3(p.xy + vec2(-texel.x, -texel.y), p.z - bias));
  s += texture(u_shadow, vec3(p.xy + vec2(texel.x, -texel.y), p.z - bias));
  s += texture(u_shadow, vec3(p.xy + vec2(-texel.x, texel.y), p.z - bias));
  s += texture(u_shadow, vec3(p.xy + vec2(texel.x, texel.y), p.z - bias));
  return 0.25 * s;
}
void main() {
  vec3 n = normalize(v_normal);
#if PART == 2
  float t = clamp(abs(v_stress), 0.0, 1.0);
  vec3 albedo = v_stress >= 0.0 ? mix(vec3(0.8), vec3(0.85, 0.03, 0.02), t) : mix(vec3(0.8), vec3(0.05, 0.7, 0.08), t);
  float gloss = 0.1;
#elif PART == 1
  vec3 albedo = inside_color(v_rest);
  float gloss = 0.05;
#else
  vec3 albedo = outside_color(v_rest);
  float gloss = u_gloss;
#endif
  vec3 v = normalize(u_eye - v_world);
  float ndl = max(dot(n, u_light_dir), 0.0);
  float sh = shadow_factor(n);
  vec3 h = normalize(u_light_dir + v);
  float spec = pow(max(dot(n, h), 0.0), mix(8.0, 120.0, gloss)) * gloss * 0.8;
  vec3 ambient = mix(vec3(0.22, 0.2, 0.18), vec3(0.38, 0.42, 0.5), n.y * 0.5 + 0.5);
  vec3 c = albedo * (ambient + 0.95 * ndl * sh * vec3(1.0, 0.97, 0.92)) + spec * sh * vec3(1.0);
  c = mix(c, vec3(1.0, 0.75, 0.2), 0.3 * u_highlight);
  o_color = vec4(sqrt(max(c, vec3(0.0))), 1.0);  // gamma 2: cheaper than pow, close to sRGB
}
)";

// The ground: most of the picture, so as little work per pixel as possible (a software rasterizer
// spends its time here): a checker in the sun, the fade into the sky. No shadow-map lookup, which
// would cost every ground pixel a filtered compare tap: the bodies' shadows are drawn onto it
// afterwards as geometry (kGroundShadowVs).
constexpr const char* kGroundFs = R"(#version 330 core
in vec3 v_world;
uniform vec3 u_eye;
uniform vec3 u_sky;        // ambient light from the sky
uniform vec3 u_sun_light;  // the sun's light on the level ground
uniform vec3 u_background;
uniform float u_ground_fade;
out vec4 o_color;
void main() {
  float c = mod(floor(v_world.x * 2.0) + floor(v_world.z * 2.0), 2.0);
  vec3 albedo = mix(vec3(0.17, 0.17, 0.16), vec3(0.21, 0.21, 0.2), c);
  vec3 col = albedo * (u_sky + u_sun_light);
  float d = length(v_world - u_eye);
  col = mix(col, u_background, smoothstep(0.3 * u_ground_fade, u_ground_fade, d));
  o_color = vec4(sqrt(col), 1.0);
}
)";

// The bodies' shadows on the ground, exact for a directional light: each body's triangles projected
// along the light onto the ground plane, each ground pixel darkened once (the stencil counts), by
// the ratio of the ground's colour without the sun to its colour with it (gamma-encoded, so one
// multiplication of what the ground shader wrote). Fades with the ground.
constexpr const char* kGroundShadowVs = R"(#version 330 core
layout(location = 0) in vec3 a_pos;  // body frame, m
uniform mat4 u_model;
uniform mat4 u_view_proj;
uniform vec4 u_plane;      // the ground, dot(xyz, x) = w, unit normal
uniform vec3 u_light_dir;  // toward the light, unit, dot(u_plane.xyz, u_light_dir) > 0
out vec3 v_world;
void main() {
  vec3 w = (u_model * vec4(a_pos, 1.0)).xyz;
  // Along the light down to the ground; a point below it stays where it is, hidden by the ground.
  float t = max(dot(u_plane.xyz, w) - u_plane.w, 0.0) / dot(u_plane.xyz, u_light_dir);
  v_world = w - u_light_dir * t;
  gl_Position = u_view_proj * vec4(v_world, 1.0);
}
)";
constexpr const char* kGroundShadowFs = R"(#version 330 core
in vec3 v_world;
uniform vec3 u_eye;
uniform vec3 u_shade;  // the ground's gamma-encoded colour in shadow over that in the sun
uniform float u_ground_fade;
out vec4 o_color;
void main() {
  float d = length(v_world - u_eye);
  o_color = vec4(mix(u_shade, vec3(1.0), smoothstep(0.3 * u_ground_fade, u_ground_fade, d)), 1.0);
}
)";

constexpr const char* kShadowVs = R"(#version 330 core
layout(location = 0) in vec3 a_pos;
uniform mat4 u_model;
uniform mat4 u_light_vp;
void main() { gl_Position = u_light_vp * u_model * vec4(a_pos, 1.0); }
)";
constexpr const char* kShadowFs = R"(#version 330 core
void main() {}
)";

// Unlit lines and triangles with per-vertex colour (gamma-encoded already): marks and the legend.
constexpr const char* kFlatVs = R"(#version 330 core
layout(location = 0) in vec3 a_pos;
layout(location = 1) in vec4 a_color;
uniform mat4 u_view_proj;
out vec4 v_color;
void main() { v_color = a_color; gl_Position = u_view_proj * vec4(a_pos, 1.0); }
)";
constexpr const char* kFlatFs = R"(#version 330 core
in vec4 v_color;
out vec4 o_color;
void main() { o_color = v_color; }
)";

Result<GLuint> compile(GLenum type, const char* source, const char* name) {
  const GLuint s = glCreateShader(type);
  glShaderSource(s, 1, &source, nullptr);
  glCompileShader(s);
  GLint ok = 0;
  glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[4096];
    glGetShaderInfoLog(s, sizeof log, nullptr, log);
    glDeleteShader(s);
    return make_error(std::string("renderer: shader ") + name + " does not compile: " + log);
  }
  return s;
}

Result<GLuint> link(const char* vs, const char* fs, const char* name) {
  SHATTER_TRY(v, compile(GL_VERTEX_SHADER, vs, name));
  SHATTER_TRY(f, compile(GL_FRAGMENT_SHADER, fs, name));
  const GLuint p = glCreateProgram();
  glAttachShader(p, *v);
  glAttachShader(p, *f);
  glLinkProgram(p);
  glDeleteShader(*v);
  glDeleteShader(*f);
  GLint ok = 0;
  glGetProgramiv(p, GL_LINK_STATUS, &ok);
  if (!ok) {
    char log[4096];
    glGetProgramInfoLog(p, sizeof log, nullptr, log);
    glDeleteProgram(p);
    return make_error(std::string("renderer: program ") + name + " does not link: " + log);
  }
  return p;
}

using Mat4f = Eigen::Matrix4f;

// A byte offset into the bound vertex buffer, as glVertexAttribPointer takes it.
const void* buffer_offset(std::size_t bytes) {
  return reinterpret_cast<const void*>(bytes);  // NOLINT(performance-no-int-to-ptr): the GL API's form
}

void set_mat(GLuint program, const char* name, const Mat4& m) {
  const Mat4f f = m.cast<float>();
  glUniformMatrix4fv(glGetUniformLocation(program, name), 1, GL_FALSE, f.data());  // column-major
}
void set_vec(GLuint program, const char* name, const Vec3& v) {
  glUniform3f(glGetUniformLocation(program, name), static_cast<float>(v.x()), static_cast<float>(v.y()),
              static_cast<float>(v.z()));
}
void set_float(GLuint program, const char* name, double v) {
  glUniform1f(glGetUniformLocation(program, name), static_cast<float>(v));
}
void set_int(GLuint program, const char* name, int v) { glUniform1i(glGetUniformLocation(program, name), v); }

Mat4 ortho(double half, double n, double f) {
  Mat4 p = Mat4::Identity();
  p(0, 0) = 1 / half;
  p(1, 1) = 1 / half;
  p(2, 2) = -2 / (f - n);
  p(2, 3) = -(f + n) / (f - n);
  return p;
}

// The solid-texture numbers of a grain (the main shader's u_in_noise, u_specks, u_out_noise,
// u_bands): inside, base + amplitude * fbm(r * frequency), stone with dark specks; outside, one
// noise octave for stone and clay, cobalt bands for porcelain.
void set_grain(GLuint program, Appearance::Grain grain) {
  using G = Appearance::Grain;
  Vec3 in(0.9, 0.15, 120), out(1, 0, 1);
  double specks = 0, bands = 0;
  switch (grain) {
    case G::stone: in = {0.75, 0.45, 35}, out = {0.8, 0.4, 20}, specks = 1; break;  // aggregate, specks
    case G::porcelain: in = {0.93, 0.1, 90}, bands = 1; break;                      // white bisque, glaze
    case G::clay: in = {0.8, 0.35, 25}, out = {0.85, 0.3, 12}; break;               // kneaded streaks
    case G::glass: in = {0.95, 0.08, 60}; break;
    case G::none:
    case G::metal: break;
  }
  set_vec(program, "u_in_noise", in);
  set_float(program, "u_specks", specks);
  set_vec(program, "u_out_noise", out);
  set_float(program, "u_bands", bands);
}

// Whether the framebuffer drawn into has stencil bits (the ground's shadows count on them).
bool has_stencil(GLint target) {
  const GLenum attachment = target == 0 ? GL_STENCIL : GL_STENCIL_ATTACHMENT;
  GLint type = GL_NONE;
  glGetFramebufferAttachmentParameteriv(GL_FRAMEBUFFER, attachment, GL_FRAMEBUFFER_ATTACHMENT_OBJECT_TYPE, &type);
  if (type == GL_NONE) return false;
  GLint bits = 0;
  glGetFramebufferAttachmentParameteriv(GL_FRAMEBUFFER, attachment, GL_FRAMEBUFFER_ATTACHMENT_STENCIL_SIZE, &bits);
  return bits > 0;
}

Mat4 body_matrix(const DrawBody& b) {
  Mat4 m = Mat4::Identity();
  m.block<3, 3>(0, 0) = b.orientation.normalized().toRotationMatrix();
  m.block<3, 1>(0, 3) = b.position;
  return m;
}

// 5x7 glyphs for the legend's numbers and units (rows top to bottom, bit 4 = left column).
struct Glyph {
  char c;
  std::array<std::uint8_t, 7> rows;
};
constexpr std::array<Glyph, 19> kGlyphs = {{
    {'0', {0x0e, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0e}},
    {'1', {0x04, 0x0c, 0x04, 0x04, 0x04, 0x04, 0x0e}},
    {'2', {0x0e, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1f}},
    {'3', {0x1e, 0x01, 0x01, 0x0e, 0x01, 0x01, 0x1e}},
    {'4', {0x02, 0x06, 0x0a, 0x12, 0x1f, 0x02, 0x02}},
    {'5', {0x1f, 0x10, 0x1e, 0x01, 0x01, 0x11, 0x0e}},
    {'6', {0x06, 0x08, 0x10, 0x1e, 0x11, 0x11, 0x0e}},
    {'7', {0x1f, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08}},
    {'8', {0x0e, 0x11, 0x11, 0x0e, 0x11, 0x11, 0x0e}},
    {'9', {0x0e, 0x11, 0x11, 0x0f, 0x01, 0x02, 0x0c}},
    {'.', {0x00, 0x00, 0x00, 0x00, 0x00, 0x0c, 0x0c}},
    {'-', {0x00, 0x00, 0x00, 0x1f, 0x00, 0x00, 0x00}},
    {'+', {0x00, 0x04, 0x04, 0x1f, 0x04, 0x04, 0x00}},
    {'M', {0x11, 0x1b, 0x15, 0x15, 0x11, 0x11, 0x11}},
    {'P', {0x1e, 0x11, 0x11, 0x1e, 0x10, 0x10, 0x10}},
    {'a', {0x00, 0x00, 0x0e, 0x01, 0x0f, 0x11, 0x0f}},
    {'k', {0x10, 0x10, 0x12, 0x14, 0x18, 0x14, 0x12}},
    {'G', {0x0e, 0x11, 0x10, 0x17, 0x11, 0x11, 0x0f}},
    {' ', {0, 0, 0, 0, 0, 0, 0}},
}};

std::string stress_label(double pa) {
  const double a = std::abs(pa);
  const char* unit = "Pa";
  double v = pa;
  if (a >= 1e9) {
    v = pa / 1e9;
    unit = "GPa";
  } else if (a >= 1e6) {
    v = pa / 1e6;
    unit = "MPa";
  } else if (a >= 1e3) {
    v = pa / 1e3;
    unit = "kPa";
  }
  char buf[32];
  const double av = std::abs(v);
  std::snprintf(buf, sizeof buf, av >= 100 ? "%+.0f %s" : av >= 10 ? "%+.1f %s" : "%+.2f %s", v, unit);
  return buf;
}

struct FlatVertex {
  float x, y, z, r, g, b, a;
};

}  // namespace

// A model's surface on the GPU: per-corner position, normal and rest coordinate (one buffer, made
// once), and the display stress of each corner's tet (refilled when it changes). The outer faces
// come first, then the crack faces, each drawn by its own shader.
struct GpuMesh {
  GLuint vao = 0, vbo = 0, stress_vbo = 0;
  GLsizei count = 0;             // corners
  GLsizei crack_begin = 0;       // first corner of the crack faces
  std::vector<Index> triangles;  // the surface triangle of each drawn triangle
  std::uint64_t geometry_hash = 0, stress_hash = 1;
  bool used = false;
};

// The parts of the main fragment shader (kMainFs's PART).
enum MainPart : std::uint8_t { kOuterFaces = 0, kCrackFaces = 1, kStressView = 2 };

struct Renderer::Impl {
  std::array<GLuint, 3> main{};  // by MainPart
  GLuint shadow = 0, flat = 0, ground = 0, ground_shadow = 0;
  GLuint shadow_fbo = 0, shadow_tex = 0;
  // The map spans the bodies only (their shadows on the ground are geometry): 512² texels over the
  // bodies' bounding sphere. A software rasterizer pays for every texel it clears and fills.
  int shadow_size = 512;
  GLuint ground_vao = 0, ground_vbo = 0, ground_stress = 0;
  GLuint flat_vao = 0, flat_vbo = 0;
  std::unordered_map<const BodyModel*, GpuMesh> meshes;  // looked up only, never iterated for output

  ~Impl() {
    for (auto& [model, m] : meshes) release(m);
    for (const GLuint p : main) glDeleteProgram(p);
    glDeleteProgram(shadow);
    glDeleteProgram(flat);
    glDeleteProgram(ground);
    glDeleteProgram(ground_shadow);
    glDeleteFramebuffers(1, &shadow_fbo);
    glDeleteTextures(1, &shadow_tex);
    glDeleteVertexArrays(1, &ground_vao);
    glDeleteBuffers(1, &ground_vbo);
    glDeleteBuffers(1, &ground_stress);
    glDeleteVertexArrays(1, &flat_vao);
    glDeleteBuffers(1, &flat_vbo);
  }
  static void release(GpuMesh& m) {
    glDeleteVertexArrays(1, &m.vao);
    glDeleteBuffers(1, &m.vbo);
    glDeleteBuffers(1, &m.stress_vbo);
    m = {};
  }

  // Corners with normals smoothed over neighbouring faces of the same kind that bend less than
  // ~35 degrees: a round vase looks round, crack faces and sharp edges stay sharp. In the order of
  // m.triangles (outer faces, then crack faces), which this sets with m.crack_begin.
  static std::vector<float> corners(const BodyModel& model, GpuMesh& m) {
    const TriSurface& s = model.surface;
    const std::size_t nt = s.triangles.size(), nv = s.positions.size();
    std::vector<Vec3> face_n(nt);  // area-weighted
    for (std::size_t t = 0; t < nt; ++t) {
      const TriIndices& tri = s.triangles[t];
      face_n[t] = (s.positions[tri[1]] - s.positions[tri[0]]).cross(s.positions[tri[2]] - s.positions[tri[0]]);
    }
    std::vector<std::size_t> start(nv + 1, 0), adj(nt * 3);
    for (const TriIndices& tri : s.triangles)
      for (Index v : tri) ++start[static_cast<std::size_t>(v) + 1];
    for (std::size_t v = 0; v < nv; ++v) start[v + 1] += start[v];
    std::vector<std::size_t> fill(start.begin(), start.end() - 1);
    for (std::size_t t = 0; t < nt; ++t)
      for (Index v : s.triangles[t]) adj[fill[static_cast<std::size_t>(v)]++] = t;
    auto crack = [&](std::size_t t) { return t < model.crack_face.size() ? model.crack_face[t] : std::uint8_t{0}; };
    const double cos_limit = std::cos(35.0 * 3.14159265358979 / 180.0);
    std::vector<float> out;
    out.reserve(nt * 3 * 9);
    m.triangles.clear();  // outer faces, then crack faces, each in surface order
    for (std::size_t t = 0; t < nt; ++t)
      if (crack(t) == 0) m.triangles.push_back(static_cast<Index>(t));
    m.crack_begin = static_cast<GLsizei>(3 * m.triangles.size());
    for (std::size_t t = 0; t < nt; ++t)
      if (crack(t) != 0) m.triangles.push_back(static_cast<Index>(t));
    for (const Index ti : m.triangles) {
      const auto t = static_cast<std::size_t>(ti);
      const Vec3 nt_unit = face_n[t].normalized();
      for (Index v : s.triangles[t]) {
        Vec3 n = Vec3::Zero();
        for (std::size_t k = start[static_cast<std::size_t>(v)]; k < start[static_cast<std::size_t>(v) + 1]; ++k) {
          const std::size_t u = adj[k];
          if (crack(u) == crack(t) && face_n[u].normalized().dot(nt_unit) > cos_limit) n += face_n[u];
        }
        if (!(n.squaredNorm() > 0)) n = nt_unit;
        n.normalize();
        const Vec3& p = s.positions[static_cast<std::size_t>(v)];
        const Vec3 r = model.material_origin + p;
        out.insert(out.end(), {static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()),
                               static_cast<float>(n.x()), static_cast<float>(n.y()), static_cast<float>(n.z()),
                               static_cast<float>(r.x()), static_cast<float>(r.y()), static_cast<float>(r.z())});
      }
    }
    return out;
  }

  GpuMesh& mesh_for(const DrawBody& b) {
    GpuMesh& m = meshes[b.model];
    const std::uint64_t gh = surface_hash(*b.model);
    if (m.vao == 0 || m.geometry_hash != gh) {
      release(m);
      const std::vector<float> data = corners(*b.model, m);
      glGenVertexArrays(1, &m.vao);
      glGenBuffers(1, &m.vbo);
      glGenBuffers(1, &m.stress_vbo);
      glBindVertexArray(m.vao);
      glBindBuffer(GL_ARRAY_BUFFER, m.vbo);
      glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(data.size() * sizeof(float)), data.data(), GL_STATIC_DRAW);
      const GLsizei stride = 9 * sizeof(float);
      glEnableVertexAttribArray(0);
      glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, stride, nullptr);
      glEnableVertexAttribArray(1);
      glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, stride, buffer_offset(3 * sizeof(float)));
      glEnableVertexAttribArray(2);
      glVertexAttribPointer(2, 3, GL_FLOAT, GL_FALSE, stride, buffer_offset(6 * sizeof(float)));
      m.count = static_cast<GLsizei>(data.size() / 9);
      glBindBuffer(GL_ARRAY_BUFFER, m.stress_vbo);
      glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(static_cast<std::size_t>(m.count) * sizeof(float)), nullptr,
                   GL_DYNAMIC_DRAW);
      glEnableVertexAttribArray(3);
      glVertexAttribPointer(3, 1, GL_FLOAT, GL_FALSE, sizeof(float), nullptr);
      glBindVertexArray(0);
      m.geometry_hash = gh;
      m.stress_hash = ~std::uint64_t{0};
    }
    const std::uint64_t sh = b.stress.empty() ? 0 : hash_bytes(b.stress.data(), b.stress.size_bytes(), 7);
    if (sh != m.stress_hash) {
      const TriSurface& s = b.model->surface;
      std::vector<float> stress(static_cast<std::size_t>(m.count), 0.0F);
      if (b.stress.size() == static_cast<std::size_t>(b.model->mesh.num_tets()))
        for (std::size_t j = 0; j < m.triangles.size(); ++j) {
          const Index tet = s.triangle_tet[static_cast<std::size_t>(m.triangles[j])];
          const auto v = static_cast<float>(b.stress[static_cast<std::size_t>(tet)]);
          stress[3 * j] = stress[3 * j + 1] = stress[3 * j + 2] = v;
        }
      glBindBuffer(GL_ARRAY_BUFFER, m.stress_vbo);
      glBufferSubData(GL_ARRAY_BUFFER, 0, static_cast<GLsizeiptr>(stress.size() * sizeof(float)), stress.data());
      m.stress_hash = sh;
    }
    m.used = true;
    return m;
  }

  void draw_flat(const std::vector<FlatVertex>& v, GLenum mode, const Mat4& view_proj) {
    if (v.empty()) return;
    glUseProgram(flat);
    set_mat(flat, "u_view_proj", view_proj);
    glBindVertexArray(flat_vao);
    glBindBuffer(GL_ARRAY_BUFFER, flat_vbo);
    glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(v.size() * sizeof(FlatVertex)), v.data(), GL_STREAM_DRAW);
    glDrawArrays(mode, 0, static_cast<GLsizei>(v.size()));
    glBindVertexArray(0);
  }
};

Renderer::Renderer() : impl_(std::make_unique<Impl>()) {}
Renderer::~Renderer() = default;

Result<std::unique_ptr<Renderer>> Renderer::create() {
  const int version = epoxy_gl_version();
  if (version < 33 || epoxy_is_desktop_gl() == 0)
    return make_error("renderer: needs OpenGL 3.3 core, the context has " + std::to_string(version / 10) + "." +
                      std::to_string(version % 10));
  std::unique_ptr<Renderer> r(new Renderer);
  Impl& im = *r->impl_;
  const auto* name = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
  r->device_ = name ? name : "unknown";
  for (const MainPart part : {kOuterFaces, kCrackFaces, kStressView}) {
    const std::string fs = "#version 330 core\n#define PART " + std::to_string(static_cast<int>(part)) + "\n" + kMainFs;
    SHATTER_TRY(main, link(kMainVs, fs.c_str(), "main"));
    im.main[part] = *main;
  }
  SHATTER_TRY(shadow, link(kShadowVs, kShadowFs, "shadow"));
  im.shadow = *shadow;
  SHATTER_TRY(flat, link(kFlatVs, kFlatFs, "flat"));
  im.flat = *flat;
  SHATTER_TRY(ground, link(kMainVs, kGroundFs, "ground"));
  im.ground = *ground;
  SHATTER_TRY(ground_shadow, link(kGroundShadowVs, kGroundShadowFs, "ground shadow"));
  im.ground_shadow = *ground_shadow;

  glGenTextures(1, &im.shadow_tex);
  glBindTexture(GL_TEXTURE_2D, im.shadow_tex);
  glTexImage2D(GL_TEXTURE_2D, 0, GL_DEPTH_COMPONENT24, im.shadow_size, im.shadow_size, 0, GL_DEPTH_COMPONENT, GL_FLOAT,
               nullptr);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_COMPARE_MODE, GL_COMPARE_REF_TO_TEXTURE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_COMPARE_FUNC, GL_LEQUAL);
  glGenFramebuffers(1, &im.shadow_fbo);
  glBindFramebuffer(GL_FRAMEBUFFER, im.shadow_fbo);
  glFramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, im.shadow_tex, 0);
  glDrawBuffer(GL_NONE);
  glReadBuffer(GL_NONE);
  const GLenum status = glCheckFramebufferStatus(GL_FRAMEBUFFER);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  if (status != GL_FRAMEBUFFER_COMPLETE) return make_error("renderer: the shadow map framebuffer is incomplete");

  // The ground: one quad, placed and scaled by its model matrix (unit square in x-z).
  const float quad[] = {-1, 0, -1, 0, 1, 0, 0, 0, 0, 1, 0, -1, 0, 1, 0, 0, 0, 0, 1,  0, 1, 0, 1, 0, 0, 0, 0,
                        -1, 0, -1, 0, 1, 0, 0, 0, 0, 1, 0, 1,  0, 1, 0, 0, 0, 0, -1, 0, 1, 0, 1, 0, 0, 0, 0};
  glGenVertexArrays(1, &im.ground_vao);
  glGenBuffers(1, &im.ground_vbo);
  glGenBuffers(1, &im.ground_stress);
  glBindVertexArray(im.ground_vao);
  glBindBuffer(GL_ARRAY_BUFFER, im.ground_vbo);
  glBufferData(GL_ARRAY_BUFFER, sizeof quad, quad, GL_STATIC_DRAW);
  for (GLuint a = 0; a < 3; ++a) glEnableVertexAttribArray(a);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 9 * sizeof(float), nullptr);
  glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, 9 * sizeof(float), buffer_offset(3 * sizeof(float)));
  glVertexAttribPointer(2, 3, GL_FLOAT, GL_FALSE, 9 * sizeof(float), buffer_offset(6 * sizeof(float)));
  const float zeros[6] = {0, 0, 0, 0, 0, 0};
  glBindBuffer(GL_ARRAY_BUFFER, im.ground_stress);
  glBufferData(GL_ARRAY_BUFFER, sizeof zeros, zeros, GL_STATIC_DRAW);
  glEnableVertexAttribArray(3);
  glVertexAttribPointer(3, 1, GL_FLOAT, GL_FALSE, sizeof(float), nullptr);

  glGenVertexArrays(1, &im.flat_vao);
  glGenBuffers(1, &im.flat_vbo);
  glBindVertexArray(im.flat_vao);
  glBindBuffer(GL_ARRAY_BUFFER, im.flat_vbo);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, sizeof(FlatVertex), nullptr);
  glEnableVertexAttribArray(1);
  glVertexAttribPointer(1, 4, GL_FLOAT, GL_FALSE, sizeof(FlatVertex), buffer_offset(3 * sizeof(float)));
  glBindVertexArray(0);
  return r;
}

RenderStats Renderer::draw(const DrawFrame& frame, const Camera& camera, int width, int height,
                           const RenderOptions& options) {
  Impl& im = *impl_;
  RenderStats stats;
  GLint target = 0;
  glGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &target);
  for (auto& [model, m] : im.meshes) m.used = false;

  // The stress that takes the full colour.
  // Auto: the 95th percentile of the loaded tets' magnitudes, so a few tets under the contact do
  // not wash out the rest of the body.
  double scale = options.stress_scale;
  if (!(scale > 0)) {
    std::vector<double> magnitudes;
    for (const DrawBody& b : frame.bodies)
      for (double s : b.stress)
        if (s != 0) magnitudes.push_back(std::abs(s));
    scale = 1e3;
    if (!magnitudes.empty()) {
      const auto k = static_cast<std::size_t>(0.95 * static_cast<double>(magnitudes.size() - 1));
      std::nth_element(magnitudes.begin(), magnitudes.begin() + static_cast<std::ptrdiff_t>(k), magnitudes.end());
      scale = std::max(scale, magnitudes[k]);
    }
  }
  stats.stress_scale = scale;

  const Vec3 light = options.light.norm() > 0 && options.light.allFinite() ? Vec3(options.light.normalized())
                                                                           : Vec3(RenderOptions{}.light.normalized());
  const bool have_bounds = (frame.bounds.min.array() <= frame.bounds.max.array()).all();
  Vec3 center = have_bounds ? Vec3(0.5 * (frame.bounds.min + frame.bounds.max)) : camera.target;
  const double bodies_radius = have_bounds ? std::max(0.5 * (frame.bounds.max - frame.bounds.min).norm(), 0.25) : 1.0;
  // The shadow map covers the bodies only: their shadows on the ground are drawn as geometry.
  const double light_radius = std::min(bodies_radius * 1.3, 200.0);
  const Mat4 light_vp =
      ortho(light_radius, 0.01, 4 * light_radius) * look_at(center + 2 * light_radius * light, center, Vec3::UnitY());
  double reach = bodies_radius;  // the ground reaches well beyond the bodies and the ground below them
  if (frame.ground) reach = std::max(reach, std::abs(frame.ground->normal.dot(center) - frame.ground->offset) + 0.25);
  reach = std::min(reach * 1.3, 200.0);
  const double aspect = static_cast<double>(width) / std::max(height, 1);
  const Mat4 view_proj = camera.projection(aspect) * camera.view();

  std::vector<GpuMesh*> meshes;
  meshes.reserve(frame.bodies.size());
  for (const DrawBody& b : frame.bodies) meshes.push_back(&im.mesh_for(b));

  // Shadow pass.
  const bool shadows = options.shadows && !frame.bodies.empty();
  if (shadows) {
    glBindFramebuffer(GL_FRAMEBUFFER, im.shadow_fbo);
    glViewport(0, 0, im.shadow_size, im.shadow_size);
    glClear(GL_DEPTH_BUFFER_BIT);
    glEnable(GL_DEPTH_TEST);
    glDisable(GL_CULL_FACE);
    glEnable(GL_POLYGON_OFFSET_FILL);
    glPolygonOffset(2.0F, 4.0F);
    glUseProgram(im.shadow);
    set_mat(im.shadow, "u_light_vp", light_vp);
    for (std::size_t i = 0; i < frame.bodies.size(); ++i) {
      set_mat(im.shadow, "u_model", body_matrix(frame.bodies[i]));
      glBindVertexArray(meshes[i]->vao);
      glDrawArrays(GL_TRIANGLES, 0, meshes[i]->count);
    }
    glDisable(GL_POLYGON_OFFSET_FILL);
  }

  // Main pass.
  glBindFramebuffer(GL_FRAMEBUFFER, static_cast<GLuint>(target));
  glViewport(0, 0, width, height);
  const Vec3 bg = options.background.array().max(0.0).sqrt();
  glClearColor(static_cast<float>(bg.x()), static_cast<float>(bg.y()), static_cast<float>(bg.z()), 1.0F);
  glClearStencil(0);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT | GL_STENCIL_BUFFER_BIT);
  // Under the panels the depth is the nearest there is: every fragment fails the depth test before
  // it is shaded.
  if (!options.covered.empty()) {
    glEnable(GL_SCISSOR_TEST);
    glClearDepth(0.0);
    for (const PixelRect& r : options.covered) {
      const int x0 = std::clamp(r.x, 0, width), x1 = std::clamp(r.x + r.width, 0, width);
      const int y0 = std::clamp(height - (r.y + r.height), 0, height), y1 = std::clamp(height - r.y, 0, height);
      if (x1 <= x0 || y1 <= y0) continue;
      glScissor(x0, y0, x1 - x0, y1 - y0);
      glClear(GL_DEPTH_BUFFER_BIT);
    }
    glClearDepth(1.0);
    glDisable(GL_SCISSOR_TEST);
  }
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDisable(GL_BLEND);
  // Body surfaces are closed and outward (counter-clockwise seen from outside): their back faces
  // are hidden, and not shading them halves the work of a software rasterizer.
  glEnable(GL_CULL_FACE);
  glCullFace(GL_BACK);
  glFrontFace(GL_CCW);
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D, im.shadow_tex);
  auto use_main = [&](MainPart part) {
    const GLuint p = im.main[part];
    glUseProgram(p);
    set_mat(p, "u_view_proj", view_proj);
    set_mat(p, "u_light_vp", light_vp);
    set_vec(p, "u_eye", camera.eye());
    set_vec(p, "u_light_dir", light);
    set_int(p, "u_use_shadow", shadows ? 1 : 0);
    set_float(p, "u_stress_inv_scale", 1.0 / scale);
    set_int(p, "u_shadow", 0);
    return p;
  };
  auto set_body = [&](GLuint p, const DrawBody& b) {
    set_mat(p, "u_model", body_matrix(b));
    set_vec(p, "u_outside", b.look.outside);
    set_vec(p, "u_inside", b.look.inside);
    set_float(p, "u_gloss", b.look.gloss);
    set_grain(p, b.look.grain);
    set_float(p, "u_highlight", b.highlight ? 1.0 : 0.0);
  };

  // Nearest first: what they hide fails the depth test before it is shaded.
  std::vector<std::size_t> order(frame.bodies.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  const Vec3 eye = camera.eye();
  std::sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) {
    const double dx = (frame.bodies[x].position - eye).squaredNorm();
    const double dy = (frame.bodies[y].position - eye).squaredNorm();
    return dx != dy ? dx < dy : x < y;
  });
  // The stress view in one pass; the material view in two, each with its own shader: every body's
  // outer faces, then every body's crack faces.
  auto draw_corners = [&](MainPart part, auto range) {
    const GLuint p = use_main(part);
    for (const std::size_t i : order) {
      const GpuMesh& m = *meshes[i];
      const auto [first, end] = range(m);
      if (end <= first) continue;
      set_body(p, frame.bodies[i]);
      glBindVertexArray(m.vao);
      glDrawArrays(GL_TRIANGLES, first, end - first);
    }
  };
  if (options.view == ViewMode::stress) {
    draw_corners(kStressView, [](const GpuMesh& m) { return std::pair<GLsizei, GLsizei>(0, m.count); });
  } else {
    draw_corners(kOuterFaces, [](const GpuMesh& m) { return std::pair<GLsizei, GLsizei>(0, m.crack_begin); });
    draw_corners(kCrackFaces, [](const GpuMesh& m) { return std::pair(m.crack_begin, m.count); });
  }
  for (const GpuMesh* m : meshes) {
    ++stats.bodies;
    stats.triangles += m->count / 3;
  }
  glDisable(GL_CULL_FACE);
  // The ground after the bodies: its fragments behind them fail the depth test before shading.
  if (options.ground && frame.ground) {
    const Plane& p = *frame.ground;
    const double extent = std::max(50.0, 20 * reach);
    Vec3 t1 = p.normal.cross(Vec3::UnitX());
    if (t1.squaredNorm() < 1e-6) t1 = p.normal.cross(Vec3::UnitZ());
    t1.normalize();
    const Vec3 t2 = t1.cross(p.normal);
    const Vec3 origin = p.offset * p.normal + (camera.target - p.normal.dot(camera.target) * p.normal);
    Mat4 m = Mat4::Identity();
    m.block<3, 1>(0, 0) = extent * t2;
    m.block<3, 1>(0, 1) = p.normal;
    m.block<3, 1>(0, 2) = extent * t1;
    m.block<3, 1>(0, 3) = origin;
    // The ground's light; in the shadows the sun's part is missing (kGroundShadowVs).
    const double sun = std::max(0.0, p.normal.dot(light));
    const Vec3 sky(0.38, 0.42, 0.5), sun_light = 0.95 * sun * Vec3(1.0, 0.97, 0.92);
    glUseProgram(im.ground);
    set_mat(im.ground, "u_model", m);
    set_mat(im.ground, "u_view_proj", view_proj);
    set_vec(im.ground, "u_eye", camera.eye());
    set_vec(im.ground, "u_sky", sky);
    set_vec(im.ground, "u_sun_light", sun_light);
    set_vec(im.ground, "u_background", options.background);
    set_float(im.ground, "u_ground_fade", extent);
    glBindVertexArray(im.ground_vao);
    glDrawArrays(GL_TRIANGLES, 0, 6);
    // The bodies' shadows on it (kGroundShadowVs): drawn where the ground is visible (depth test,
    // pulled a little toward the eye so they do not fight the ground's depth), once per pixel.
    if (shadows && sun > 0.05 && has_stencil(target)) {
      const Vec3 shade = sky.cwiseQuotient(sky + sun_light).cwiseSqrt();  // gamma-encoded, as the ground
      const GLuint gs = im.ground_shadow;
      glUseProgram(gs);
      set_mat(gs, "u_view_proj", view_proj);
      glUniform4f(glGetUniformLocation(gs, "u_plane"), static_cast<float>(p.normal.x()),
                  static_cast<float>(p.normal.y()), static_cast<float>(p.normal.z()), static_cast<float>(p.offset));
      set_vec(gs, "u_light_dir", light);
      set_vec(gs, "u_eye", camera.eye());
      set_vec(gs, "u_shade", shade);
      set_float(gs, "u_ground_fade", extent);
      glEnable(GL_STENCIL_TEST);
      glStencilFunc(GL_EQUAL, 0, 0xFF);
      glStencilOp(GL_KEEP, GL_KEEP, GL_INCR);
      glDepthMask(GL_FALSE);
      glDepthFunc(GL_LEQUAL);
      glEnable(GL_POLYGON_OFFSET_FILL);
      glPolygonOffset(-1.0F, -4.0F);
      glEnable(GL_BLEND);
      glBlendFunc(GL_ZERO, GL_SRC_COLOR);  // destination x shade
      // A closed surface's faces toward the light alone cover its shadow, and they keep their
      // winding when projected (seen from above the ground): the others are culled.
      glEnable(GL_CULL_FACE);
      glCullFace(GL_BACK);
      glFrontFace(GL_CCW);
      for (std::size_t i = 0; i < frame.bodies.size(); ++i) {
        set_mat(gs, "u_model", body_matrix(frame.bodies[i]));
        glBindVertexArray(meshes[i]->vao);
        glDrawArrays(GL_TRIANGLES, 0, meshes[i]->count);
      }
      glDisable(GL_CULL_FACE);
      glDisable(GL_BLEND);
      glDisable(GL_POLYGON_OFFSET_FILL);
      glDepthFunc(GL_LESS);
      glDepthMask(GL_TRUE);
      glDisable(GL_STENCIL_TEST);
    }
  }
  glBindVertexArray(0);

  // Marks: a cross at each impact point, a translucent disc in each crack plane, fading with age.
  if (options.marks && !frame.marks.empty()) {
    std::vector<FlatVertex> lines, discs;
    for (const EventMark& mk : frame.marks) {
      const auto alpha =
          static_cast<float>(std::clamp(1.0 - (frame.time - mk.time) / std::max(frame.mark_keep, 1e-9), 0.15, 1.0));
      const Vec3& p = mk.point;
      if (mk.kind == EventMark::Kind::impact) {
        const double s = std::max(0.02, 0.04 * bodies_radius);
        for (int k = 0; k < 3; ++k) {
          const Vec3 a = p - s * Vec3::Unit(k), b = p + s * Vec3::Unit(k);
          lines.push_back({float(a.x()), float(a.y()), float(a.z()), 1.0F, 0.85F, 0.1F, alpha});
          lines.push_back({float(b.x()), float(b.y()), float(b.z()), 1.0F, 0.85F, 0.1F, alpha});
        }
        // The held region: with the paper's hold, everything beyond r_coll from the load was
        // anchored; three orange circles show the sphere.
        if (mk.radius > 0) {
          constexpr int kSegments = 48;
          for (int k = 0; k < 3; ++k) {
            const Vec3 u = Vec3::Unit((k + 1) % 3), v = Vec3::Unit((k + 2) % 3);
            for (int j = 0; j < kSegments; ++j) {
              const double a0 = 2 * 3.14159265358979 * j / kSegments, a1 = 2 * 3.14159265358979 * (j + 1) / kSegments;
              const Vec3 q0 = p + mk.radius * (std::cos(a0) * u + std::sin(a0) * v);
              const Vec3 q1 = p + mk.radius * (std::cos(a1) * u + std::sin(a1) * v);
              lines.push_back({float(q0.x()), float(q0.y()), float(q0.z()), 1.0F, 0.55F, 0.1F, 0.6F * alpha});
              lines.push_back({float(q1.x()), float(q1.y()), float(q1.z()), 1.0F, 0.55F, 0.1F, 0.6F * alpha});
            }
          }
        }
      } else {
        Vec3 u = mk.normal.cross(Vec3::UnitX());
        if (u.squaredNorm() < 1e-6) u = mk.normal.cross(Vec3::UnitY());
        u.normalize();
        const Vec3 v = mk.normal.cross(u);
        const double r = std::min(mk.radius, 0.3 * bodies_radius);  // where it cuts, not its whole reach
        constexpr int kSegments = 32;
        for (int k = 0; k < kSegments; ++k) {
          const double a0 = 2 * 3.14159265358979 * k / kSegments, a1 = 2 * 3.14159265358979 * (k + 1) / kSegments;
          const Vec3 q0 = p + r * (std::cos(a0) * u + std::sin(a0) * v);
          const Vec3 q1 = p + r * (std::cos(a1) * u + std::sin(a1) * v);
          for (const Vec3& q : {p, q0, q1})
            discs.push_back({float(q.x()), float(q.y()), float(q.z()), 0.2F, 0.8F, 1.0F, 0.12F * alpha});
          lines.push_back({float(q0.x()), float(q0.y()), float(q0.z()), 0.2F, 0.8F, 1.0F, 0.5F * alpha});
          lines.push_back({float(q1.x()), float(q1.y()), float(q1.z()), 0.2F, 0.8F, 1.0F, 0.5F * alpha});
        }
      }
    }
    glEnable(GL_BLEND);
    glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
    glDepthMask(GL_FALSE);
    im.draw_flat(discs, GL_TRIANGLES, view_proj);
    glDisable(GL_DEPTH_TEST);  // points and outlines show through
    im.draw_flat(lines, GL_LINES, view_proj);
    glEnable(GL_DEPTH_TEST);
    glDepthMask(GL_TRUE);
    glDisable(GL_BLEND);
  }

  // Legend of the stress view: a bar from +scale (red) through 0 to -scale (green), labelled.
  if (options.view == ViewMode::stress && options.legend) {
    std::vector<FlatVertex> tris;
    const double px = 1.0;  // in pixels; converted to clip space below
    const int glyph = std::max(1, height / 300);
    auto quad = [&](double x0, double y0, double x1, double y1, const Vec3& c0, const Vec3& c1) {
      // Pixel rectangle (y down) to clip space; c0 at the top, c1 at the bottom.
      auto X = [&](double x) { return static_cast<float>(2 * x / width - 1); };
      auto Y = [&](double y) { return static_cast<float>(1 - 2 * y / height); };
      const FlatVertex a{X(x0), Y(y0), 0, float(c0.x()), float(c0.y()), float(c0.z()), 1};
      const FlatVertex b{X(x1), Y(y0), 0, float(c0.x()), float(c0.y()), float(c0.z()), 1};
      const FlatVertex c{X(x1), Y(y1), 0, float(c1.x()), float(c1.y()), float(c1.z()), 1};
      const FlatVertex d{X(x0), Y(y1), 0, float(c1.x()), float(c1.y()), float(c1.z()), 1};
      tris.insert(tris.end(), {a, b, c, a, c, d});
    };
    auto gamma = [](const Vec3& c) { return Vec3(c.array().sqrt()); };
    const double bar_w = 16.0 * glyph * px, bar_h = 0.6 * height;
    const double x1 = width - 12.0 * glyph, x0 = x1 - bar_w;
    const double y0 = 0.2 * height, ymid = y0 + bar_h / 2, y1 = y0 + bar_h;
    const Vec3 red(0.85, 0.03, 0.02), grey(0.8, 0.8, 0.8), green(0.05, 0.7, 0.08);
    quad(x0 - 2, y0 - 2, x1 + 2, y1 + 2, Vec3(0.1, 0.1, 0.1), Vec3(0.1, 0.1, 0.1));
    constexpr int kSteps = 16;
    for (int k = 0; k < kSteps; ++k) {  // the shader's linear ramps, in gamma space
      const double ta = 1.0 - static_cast<double>(k) / kSteps, tb = 1.0 - static_cast<double>(k + 1) / kSteps;
      quad(x0, y0 + (bar_h / 2) * k / kSteps, x1, y0 + (bar_h / 2) * (k + 1) / kSteps, gamma(grey + ta * (red - grey)),
           gamma(grey + tb * (red - grey)));
      quad(x0, ymid + (bar_h / 2) * k / kSteps, x1, ymid + (bar_h / 2) * (k + 1) / kSteps,
           gamma(grey + (1 - ta) * (green - grey)), gamma(grey + (1 - tb) * (green - grey)));
    }
    auto text = [&](const std::string& s, double right, double top) {
      const double adv = 6.0 * glyph;
      double x = right - adv * static_cast<double>(s.size());
      for (char ch : s) {
        const auto* g = std::find_if(kGlyphs.begin(), kGlyphs.end(), [&](const Glyph& gl) { return gl.c == ch; });
        if (g != kGlyphs.end())
          for (int row = 0; row < 7; ++row)
            for (int col = 0; col < 5; ++col)
              if ((g->rows[static_cast<std::size_t>(row)] >> (4 - col)) & 1)
                quad(x + col * glyph, top + row * glyph, x + (col + 1) * glyph, top + (row + 1) * glyph,
                     Vec3(0.05, 0.05, 0.05), Vec3(0.05, 0.05, 0.05));
        x += adv;
      }
    };
    const double gap = 6.0 * glyph;
    text(stress_label(scale), x0 - gap, y0 - 3.5 * glyph);
    text("0", x0 - gap, ymid - 3.5 * glyph);
    text(stress_label(-scale), x0 - gap, y1 - 3.5 * glyph);
    glDisable(GL_DEPTH_TEST);
    im.draw_flat(tris, GL_TRIANGLES, Mat4::Identity());
    glEnable(GL_DEPTH_TEST);
  }

  // Forget the meshes of models no longer drawn (dented or broken bodies).
  for (auto it = im.meshes.begin(); it != im.meshes.end();) {
    if (!it->second.used) {
      Impl::release(it->second);
      it = im.meshes.erase(it);
    } else {
      ++it;
    }
  }
  glUseProgram(0);
  return stats;
}

Result<std::unique_ptr<OffscreenTarget>> OffscreenTarget::create(int width, int height, int samples) {
  if (width <= 0 || height <= 0 || width > 16384 || height > 16384)
    return make_error("render target: size " + std::to_string(width) + "x" + std::to_string(height) +
                      " out of range (1..16384)");
  std::unique_ptr<OffscreenTarget> t(new OffscreenTarget);
  t->width_ = width;
  t->height_ = height;
  GLint max_samples = 0;
  glGetIntegerv(GL_MAX_SAMPLES, &max_samples);
  samples = std::clamp(samples, 0, static_cast<int>(max_samples));
  glGenFramebuffers(1, &t->fbo_);
  glBindFramebuffer(GL_FRAMEBUFFER, t->fbo_);
  glGenRenderbuffers(1, &t->color_);
  glBindRenderbuffer(GL_RENDERBUFFER, t->color_);
  glRenderbufferStorageMultisample(GL_RENDERBUFFER, samples, GL_RGBA8, width, height);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, t->color_);
  glGenRenderbuffers(1, &t->depth_);
  glBindRenderbuffer(GL_RENDERBUFFER, t->depth_);
  glRenderbufferStorageMultisample(GL_RENDERBUFFER, samples, GL_DEPTH24_STENCIL8, width, height);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_STENCIL_ATTACHMENT, GL_RENDERBUFFER, t->depth_);
  if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
    return make_error("render target: the multisampled framebuffer is incomplete");
  glGenFramebuffers(1, &t->resolve_fbo_);
  glBindFramebuffer(GL_FRAMEBUFFER, t->resolve_fbo_);
  glGenRenderbuffers(1, &t->resolve_color_);
  glBindRenderbuffer(GL_RENDERBUFFER, t->resolve_color_);
  glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, width, height);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, t->resolve_color_);
  if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
    return make_error("render target: the resolve framebuffer is incomplete");
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  return t;
}

OffscreenTarget::~OffscreenTarget() {
  glDeleteFramebuffers(1, &fbo_);
  glDeleteFramebuffers(1, &resolve_fbo_);
  glDeleteRenderbuffers(1, &color_);
  glDeleteRenderbuffers(1, &depth_);
  glDeleteRenderbuffers(1, &resolve_color_);
}

void OffscreenTarget::bind() {
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
  glViewport(0, 0, width_, height_);
}

Image read_framebuffer(int width, int height) {
  Image img(width, height);
  std::vector<std::uint8_t> rows(img.rgba.size());
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(0, 0, width, height, GL_RGBA, GL_UNSIGNED_BYTE, rows.data());
  const std::size_t stride = static_cast<std::size_t>(width) * 4;
  for (int y = 0; y < height; ++y)
    std::copy_n(rows.data() + static_cast<std::size_t>(height - 1 - y) * stride, stride,
                img.rgba.data() + static_cast<std::size_t>(y) * stride);
  for (std::size_t i = 3; i < img.rgba.size(); i += 4) img.rgba[i] = 255;
  return img;
}

Image OffscreenTarget::read() {
  glBindFramebuffer(GL_READ_FRAMEBUFFER, fbo_);
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, resolve_fbo_);
  glBlitFramebuffer(0, 0, width_, height_, 0, 0, width_, height_, GL_COLOR_BUFFER_BIT, GL_NEAREST);
  glBindFramebuffer(GL_FRAMEBUFFER, resolve_fbo_);
  Image img = read_framebuffer(width_, height_);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
  return img;
}

}  // namespace shatter::render
