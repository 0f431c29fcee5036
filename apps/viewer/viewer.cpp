#include "viewer.h"

#include <epoxy/gl.h>
// GLFW after epoxy: epoxy provides the GL declarations.
#include <GLFW/glfw3.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl3.h>
#include <fmt/format.h>
#include <imgui.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "shatter/fem/material.h"
#include "shatter/mesh/io/mesh_io.h"
#include "shatter/render/frame.h"
#include "shatter/render/renderer.h"
#include "shatter/rigid/body.h"
#include "shatter/scene/scene.h"

namespace shatter::viewer {
namespace {

using Clock = std::chrono::steady_clock;
using Json = nlohmann::json;

enum class Tool : int { drag = 0, hammer = 1, press = 2, throw_asset = 3, slice = 4 };
constexpr const char* kToolNames[] = {"Drag", "Hammer", "Press", "Throw", "Slice"};
constexpr int kTools = 5;

std::string g_glfw_error;
extern "C" void on_glfw_error(int code, const char* message) {
  g_glfw_error = fmt::format("{} (GLFW error 0x{:x})", message ? message : "unknown", code);
}

// A scripted action (docs/viewer.md): at a frame, do what the mouse or keys would.
struct ScriptStep {
  int frame = 0;
  std::string action;  // tool, click, screenshot, view, play, pause, step, reset, quit, expect_bodies_at_least
  Json args;
  std::size_t order = 0;
};

Result<std::vector<ScriptStep>> read_script(const std::string& path) {
  std::ifstream in(path);
  if (!in) return make_error(path + ": cannot open the script");
  Json j;
  try {
    j = Json::parse(in);
  } catch (const std::exception& e) {
    return make_error(path + ": not JSON: " + e.what());
  }
  if (!j.is_array()) return make_error(path + ": expected an array of steps");
  std::vector<ScriptStep> steps;
  const std::vector<std::string> known = {"tool",
                                          "click",
                                          "drag",
                                          "screenshot",
                                          "view",
                                          "play",
                                          "pause",
                                          "step",
                                          "reset",
                                          "quit",
                                          "expect_bodies_at_least"};
  for (std::size_t i = 0; i < j.size(); ++i) {
    const Json& s = j[i];
    const std::string where = path + ": [" + std::to_string(i) + "]";
    if (!s.is_object() || !s.contains("frame") || !s["frame"].is_number_integer() || !s.contains("action") ||
        !s["action"].is_string())
      return make_error(where + ": expected {\"frame\": <integer>, \"action\": <name>, ...}");
    ScriptStep st{s["frame"].get<int>(), s["action"].get<std::string>(), s, 0};
    if (std::find(known.begin(), known.end(), st.action) == known.end())
      return make_error(where + ".action: unknown action \"" + st.action + "\"");
    auto point = [&](const char* key) {
      return s.contains(key) && s[key].is_array() && s[key].size() == 2 && s[key][0].is_number() &&
             s[key][1].is_number();
    };
    if (st.action == "drag" && !(s.contains("across") && s["across"].is_string()) && (!point("from") || !point("to")))
      return make_error(where + ": a drag needs \"from\": [x, y] and \"to\": [x, y] (pixels), or \"across\": <body>");
    if (st.action == "click" && !(s.contains("body") && s["body"].is_string()) &&
        !(s.contains("x") && s["x"].is_number() && s.contains("y") && s["y"].is_number()))
      return make_error(where + ": a click needs \"body\": <name> or \"x\" and \"y\" (pixels)");
    for (const char* key : {"impulse", "speed", "force", "radius", "count"})
      if (s.contains(key) && !s[key].is_number()) return make_error(where + "." + key + ": expected a number");
    for (const char* key : {"tool", "path", "view"})
      if (s.contains(key) && !s[key].is_string()) return make_error(where + "." + key + ": expected a string");
    steps.push_back(std::move(st));
  }
  // By frame, in file order within a frame.
  for (std::size_t i = 0; i < steps.size(); ++i) steps[i].order = i;
  std::sort(steps.begin(), steps.end(),
            [](const auto& a, const auto& b) { return a.frame != b.frame ? a.frame < b.frame : a.order < b.order; });
  return steps;
}

struct Recorded {
  WorldSnapshot snapshot;
  std::size_t next_action = 0;
};

class Viewer {
 public:
  explicit Viewer(const ViewerOptions& o) : opt_(o) {}
  ~Viewer();
  int run();

 private:
  // Scene and world.
  bool load_scene(const std::string& path);
  void rebuild();  // from scene_ (after a material edit)
  void reset();
  void step_once();
  void record();
  void scrub_to(std::size_t index);
  void log(const std::string& line);
  void log_events();
  // Input and tools.
  void handle_mouse();
  void tool_down(double x, double y);
  void tool_drag(double x, double y);
  void tool_up();
  void apply_tools_before_step();
  void throw_asset(bool drop);
  void slice_along_stroke();
  void focus_selection();
  // Frame.
  void ui();
  void cover_window();
  void run_script();
  /// The window pixel of a live scene body's centre of mass (scripts); logs and gives nothing when
  /// no live body has the name.
  std::optional<Vec2> body_on_screen(const std::string& name);
  bool screenshot(const std::string& path);

  ViewerOptions opt_;
  GLFWwindow* window_ = nullptr;
  std::unique_ptr<render::Renderer> renderer_;
  Scene scene_;
  std::string scene_path_;
  std::optional<SceneWorld> built_;
  std::size_t next_action_ = 0;
  std::deque<Recorded> recording_;
  std::size_t cursor_ = 0;  // index in recording_ of the state shown
  static constexpr std::size_t kMaxRecording = 3600;
  render::EventMarks marks_;
  render::Camera camera_;
  render::RenderOptions render_options_;
  BodyId selected_;
  bool playing_ = true;
  double time_scale_ = 1.0;
  double accumulator_ = 0;
  Tool tool_ = Tool::hammer;
  // Tool parameters.
  double hammer_impulse_ = 20;  // N s
  double hammer_speed_ = 8;     // m/s
  double hammer_radius_ = 0;    // m (0: Hertz's patch)
  double press_force_ = 2000;   // N
  double press_radius_ = 0.02;  // m
  double throw_speed_ = 6;      // m/s
  int asset_ = 0;
  std::vector<std::pair<std::string, std::shared_ptr<const BodyModel>>> assets_;  // name, model (lazily)
  // Tool state.
  bool tool_active_ = false;
  BodyId tool_body_;
  Vec3 tool_local_ = Vec3::Zero();   // grabbed or pressed point, body frame
  Vec3 tool_normal_ = Vec3::Zero();  // pressed surface normal, body frame
  double drag_depth_ = 0;            // distance of the grab plane from the eye
  Vec3 drag_target_ = Vec3::Zero();
  double stroke_x0_ = 0, stroke_y0_ = 0, stroke_x1_ = 0, stroke_y1_ = 0;  // slice stroke, pixels
  // Mouse.
  double last_x_ = 0, last_y_ = 0;
  // Stats and log.
  std::deque<std::string> log_;
  double fps_ = 0;
  double frame_ms_ = 0, draw_ms_ = 0;
  StepStats last_stats_;
  double last_step_ms_ = 0;
  std::int64_t frame_ = 0;
  // Script.
  std::vector<ScriptStep> script_;
  std::size_t script_next_ = 0;
  bool quit_ = false;
  int exit_code_ = 0;
  // Scene picker and material editor.
  std::vector<std::string> scene_files_;
  int scene_pick_ = -1;
  int screenshot_count_ = 0;
};

Viewer::~Viewer() {
  if (window_) {
    renderer_.reset();
    ImGui_ImplOpenGL3_Shutdown();
    ImGui_ImplGlfw_Shutdown();
    ImGui::DestroyContext();
    glfwDestroyWindow(window_);
  }
  // No glfwTerminate: it unloads the OpenGL driver, whose remaining allocations then show up as
  // leaks; the process ends right after anyway.
}

void Viewer::log(const std::string& line) {
  log_.push_back(line);
  while (log_.size() > 300) log_.pop_front();
}

bool Viewer::load_scene(const std::string& path) {
  auto scene = read_scene(path);
  if (!scene) {
    log("error: " + scene.error().to_string());
    std::fprintf(stderr, "shatter: error: %s\n", scene.error().to_string().c_str());
    return false;
  }
  scene_ = std::move(*scene);
  scene_path_ = path;
  rebuild();
  if (!built_) return false;
  // The scenes beside this one, for the picker; the bundled assets, for throwing.
  scene_files_.clear();
  std::error_code ec;
  const std::filesystem::path dir = std::filesystem::path(path).parent_path();
  for (const auto& e : std::filesystem::directory_iterator(dir.empty() ? "." : dir, ec))
    if (e.path().extension() == ".json") scene_files_.push_back(e.path().string());
  std::sort(scene_files_.begin(), scene_files_.end());
  scene_pick_ = static_cast<int>(std::find(scene_files_.begin(), scene_files_.end(), path) - scene_files_.begin());
  assets_.clear();
  for (const char* name : {"vase", "teddy", "cinder_block"}) {
    const std::filesystem::path mesh = dir / ".." / "assets" / "meshes" / (std::string(name) + ".msh");
    if (std::filesystem::is_regular_file(mesh, ec)) assets_.emplace_back(mesh.lexically_normal().string(), nullptr);
  }
  camera_ =
      render::frame_camera(render::frame_from_world(*built_->world), static_cast<double>(opt_.width) / opt_.height);
  return true;
}

void Viewer::rebuild() {
  auto built = build_scene(scene_);
  if (!built) {
    log("error: " + built.error().to_string());
    std::fprintf(stderr, "shatter: error: %s\n", built.error().to_string().c_str());
    return;
  }
  built_ = std::move(*built);
  next_action_ = 0;
  recording_.clear();
  cursor_ = 0;
  marks_.clear();
  selected_ = {};
  tool_active_ = false;
  record();
  log(fmt::format("scene {}: {} bodies", scene_.name, scene_.bodies.size()));
}

void Viewer::reset() {
  if (!built_ || recording_.empty()) return;
  scrub_to(0);
  recording_.resize(1);
  log("reset");
}

void Viewer::record() {
  // Stepping after scrubbing back forgets the states after the one shown.
  if (!recording_.empty()) recording_.resize(cursor_ + 1);
  recording_.push_back({built_->world->save(), next_action_});
  if (recording_.size() > kMaxRecording) recording_.erase(recording_.begin() + 1);  // keep the first
  cursor_ = recording_.size() - 1;
}

void Viewer::scrub_to(std::size_t index) {
  index = std::min(index, recording_.size() - 1);
  if (auto ok = built_->world->restore(recording_[index].snapshot); !ok) {
    log("error: " + ok.error().message);
    return;
  }
  next_action_ = recording_[index].next_action;
  cursor_ = index;
  marks_.clear();
  tool_active_ = false;
  if (selected_.index >= 0 && !built_->world->valid(selected_)) selected_ = {};
}

void Viewer::step_once() {
  World& w = *built_->world;
  if (cursor_ + 1 < recording_.size()) {  // replaying the recording
    scrub_to(cursor_ + 1);
    return;
  }
  apply_tools_before_step();
  if (auto acted = apply_due_actions(scene_, *built_, next_action_); !acted) log("error: " + acted.error().message);
  const auto t0 = Clock::now();
  w.step();
  last_step_ms_ = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  last_stats_ = w.stats();
  marks_.add(w.events(), w.time());
  log_events();
  record();
  if (tool_active_ && (!w.valid(tool_body_) || w.removed(tool_body_))) tool_active_ = false;
  if (selected_.index >= 0 && w.removed(selected_)) selected_ = {};
}

void Viewer::log_events() {
  const World& w = *built_->world;
  const StepEvents& ev = w.events();
  for (const ImpactRecord& r : ev.impacts)
    log(fmt::format("{:.3f} s  impact body {} ({:.1f} m/s, {:.3g} N{}): {}{}{}", w.time(), r.body.index,
                    r.approach_speed, r.force,
                    r.converged ? "" : fmt::format(", solved to {:.0f} % of it", 100 * r.load_fraction),
                    r.dented ? "dented " : "", r.cracks ? fmt::format("{} crack(s) ", r.cracks) : "",
                    r.fragments ? fmt::format("-> {} fragments", r.fragments) : ""));
  if (!ev.fragments.empty()) log(fmt::format("{:.3f} s  {} fragment(s) born", w.time(), ev.fragments.size()));
}

void Viewer::apply_tools_before_step() {
  if (!tool_active_) return;
  World& w = *built_->world;
  if (!w.valid(tool_body_) || w.removed(tool_body_)) {
    tool_active_ = false;
    return;
  }
  const RigidState& r = w.rigid_state(tool_body_);
  const Vec3 point = r.position + r.orientation * tool_local_;
  const double dt = w.settings().time_step;
  if (tool_ == Tool::drag && w.body_type(tool_body_) == BodyType::dynamic) {
    // A critically damped spring (10 rad/s) pulls the grabbed point to the cursor, and the
    // body's weight is carried, through impulses at the point.
    const double m = 1.0 / w.inertia(tool_body_).inverse_mass;
    const double omega = 10;
    const Vec3 v_point = r.linear_velocity + r.angular_velocity.cross(point - r.position);
    const Vec3 accel = omega * omega * (drag_target_ - point) - 2 * omega * v_point - w.settings().gravity;
    (void)w.apply_impulse(tool_body_, m * dt * accel, point);
  } else if (tool_ == Tool::press) {
    const Vec3 normal = r.orientation * tool_normal_;
    if (auto ok = w.press(tool_body_, point, -press_force_ * normal, press_radius_, dt); !ok)
      log("press: " + ok.error().message);
  }
}

void Viewer::tool_down(double x, double y) {
  World& w = *built_->world;
  int fbw = 0, fbh = 0;
  glfwGetWindowSize(window_, &fbw, &fbh);
  Vec3 origin, dir;
  camera_.ray(x, y, fbw, fbh, origin, dir);
  if (tool_ == Tool::throw_asset) {
    throw_asset(false);
    return;
  }
  if (tool_ == Tool::slice) {  // a stroke on the screen: the plane through the eye and the stroke
    tool_active_ = true;
    stroke_x0_ = stroke_x1_ = x;
    stroke_y0_ = stroke_y1_ = y;
    return;
  }
  const render::Pick hit = render::pick_body(w, origin, dir);
  selected_ = hit.body;
  if (hit.body.index < 0) return;
  if (cursor_ + 1 < recording_.size()) recording_.resize(cursor_ + 1);  // acting on a past state: go on from it
  const RigidState& r = w.rigid_state(hit.body);
  const Quat inv = r.orientation.conjugate();
  tool_body_ = hit.body;
  tool_local_ = inv * (hit.point - r.position);
  tool_normal_ = inv * hit.normal;
  switch (tool_) {
    case Tool::drag:
      tool_active_ = true;
      drag_depth_ = hit.distance;
      drag_target_ = hit.point;
      break;
    case Tool::hammer: {
      const Vec3 impulse = hammer_impulse_ * dir;
      if (auto ok = w.strike(hit.body, hit.point, impulse, hammer_speed_, hammer_radius_); !ok)
        log("hammer: " + ok.error().message);
      else
        log(fmt::format("{:.3f} s  hammer on body {}: {:.3g} N s at {:.3g} m/s", w.time(), hit.body.index,
                        hammer_impulse_, hammer_speed_));
      break;
    }
    case Tool::press:
      tool_active_ = true;
      log(fmt::format("{:.3f} s  press on body {}: {:.3g} N", w.time(), hit.body.index, press_force_));
      break;
    case Tool::throw_asset:
    case Tool::slice: break;
  }
}

void Viewer::tool_drag(double x, double y) {
  if (tool_active_ && tool_ == Tool::slice) {
    stroke_x1_ = x;
    stroke_y1_ = y;
    return;
  }
  if (!tool_active_ || tool_ != Tool::drag) return;
  int fbw = 0, fbh = 0;
  glfwGetWindowSize(window_, &fbw, &fbh);
  Vec3 origin, dir;
  camera_.ray(x, y, fbw, fbh, origin, dir);
  drag_target_ = origin + drag_depth_ * dir;
}

void Viewer::tool_up() {
  if (tool_active_ && tool_ == Tool::slice) slice_along_stroke();
  tool_active_ = false;
}

// The plane holds the eye and the rays through both ends of the stroke; it cuts every dynamic
// body that a ray along the stroke meets (World::slice).
void Viewer::slice_along_stroke() {
  World& w = *built_->world;
  if (std::hypot(stroke_x1_ - stroke_x0_, stroke_y1_ - stroke_y0_) < 5) return;
  int ww = 0, wh = 0;
  glfwGetWindowSize(window_, &ww, &wh);
  Vec3 eye, d0, d1;
  camera_.ray(stroke_x0_, stroke_y0_, ww, wh, eye, d0);
  camera_.ray(stroke_x1_, stroke_y1_, ww, wh, eye, d1);
  const Vec3 normal = d0.cross(d1);
  if (!(normal.norm() > 1e-9)) return;
  std::vector<BodyId> hit;
  constexpr int kSamples = 32;
  for (int k = 0; k <= kSamples; ++k) {
    const double t = static_cast<double>(k) / kSamples;
    Vec3 o, d;
    camera_.ray(stroke_x0_ + t * (stroke_x1_ - stroke_x0_), stroke_y0_ + t * (stroke_y1_ - stroke_y0_), ww, wh, o, d);
    const render::Pick p = render::pick_body(w, o, d);
    if (p.body.index >= 0 && w.body_type(p.body) == BodyType::dynamic &&
        std::find(hit.begin(), hit.end(), p.body) == hit.end())
      hit.push_back(p.body);
  }
  std::sort(hit.begin(), hit.end());
  if (cursor_ + 1 < recording_.size()) recording_.resize(cursor_ + 1);
  for (const BodyId id : hit) {
    auto pieces = w.slice(id, eye, normal.normalized());
    if (!pieces)
      log("slice: " + pieces.error().message);
    else
      log(fmt::format("{:.3f} s  sliced body {} into {} pieces", w.time(), id.index, *pieces));
  }
  if (!hit.empty()) record();
}

void Viewer::throw_asset(bool drop) {
  if (assets_.empty()) {
    log("throw: no assets found beside the scene (assets/meshes)");
    return;
  }
  auto& [path, model] = assets_[static_cast<std::size_t>(asset_)];
  if (!model) {
    auto mesh = read_mesh(path);
    if (!mesh) {
      log("throw: " + mesh.error().to_string());
      return;
    }
    const std::string name = std::filesystem::path(path).stem().string();
    const char* material = name == "teddy" ? "modelling_clay" : name == "cinder_block" ? "concrete" : "porcelain";
    auto m = make_body_model(mesh->mesh, *material_preset(material));
    if (!m) {
      log("throw: " + m.error().message);
      return;
    }
    model = std::make_shared<const BodyModel>(std::move(*m));
  }
  World& w = *built_->world;
  RigidState r;
  const Mat4 view = camera_.view();
  const Vec3 forward = -view.block<1, 3>(2, 0).transpose();
  if (drop) {
    r.position = camera_.target + Vec3(0, 1.0, 0);
  } else {
    r.position = camera_.eye() + 0.6 * forward;
    r.linear_velocity = throw_speed_ * forward;
  }
  if (cursor_ + 1 < recording_.size()) recording_.resize(cursor_ + 1);
  auto id = w.add_body(model, {.rigid = r});
  if (!id)
    log("throw: " + id.error().message);
  else
    log(fmt::format("{:.3f} s  {} body {}", w.time(), drop ? "dropped" : "threw", id->index));
}

void Viewer::focus_selection() {
  const World& w = *built_->world;
  if (selected_.index < 0 || !w.valid(selected_)) return;
  const Aabb b = w.bounds(selected_);
  camera_.target = 0.5 * (b.min + b.max);
  camera_.distance = std::max(0.3, 2.5 * (b.max - b.min).norm());
}

void Viewer::handle_mouse() {
  ImGuiIO& io = ImGui::GetIO();
  const double x = io.MousePos.x, y = io.MousePos.y;
  const double dx = x - last_x_, dy = y - last_y_;
  last_x_ = x;
  last_y_ = y;
  if (!io.WantCaptureMouse) {
    if (io.MouseWheel != 0) camera_.zoom(std::pow(0.88, io.MouseWheel));
    if (ImGui::IsMouseDown(ImGuiMouseButton_Right)) {
      if (io.KeyShift)
        camera_.pan(-dx * 0.0015, dy * 0.0015);
      else
        camera_.orbit(-dx * 0.006, dy * 0.006);
    }
    if (ImGui::IsMouseDown(ImGuiMouseButton_Middle)) camera_.pan(-dx * 0.0015, dy * 0.0015);
    if (ImGui::IsMouseClicked(ImGuiMouseButton_Left)) tool_down(x, y);
  }
  if (ImGui::IsMouseDown(ImGuiMouseButton_Left)) tool_drag(x, y);
  if (ImGui::IsMouseReleased(ImGuiMouseButton_Left)) tool_up();
  if (!io.WantCaptureKeyboard) {
    if (ImGui::IsKeyPressed(ImGui::GetKeyIndex(ImGuiKey_Space))) playing_ = !playing_;
    if (ImGui::IsKeyPressed(ImGui::GetKeyIndex(ImGuiKey_Escape))) glfwSetWindowShouldClose(window_, 1);
    if (ImGui::IsKeyPressed('R')) reset();
    if (ImGui::IsKeyPressed('F')) focus_selection();
    if (ImGui::IsKeyPressed('V'))
      render_options_.view =
          render_options_.view == render::ViewMode::stress ? render::ViewMode::material : render::ViewMode::stress;
    if (ImGui::IsKeyPressed('S') && !playing_) step_once();
    if (ImGui::IsKeyPressed('P'))
      screenshot(fmt::format("{}/screenshot_{:03d}.png", opt_.out_dir, screenshot_count_++));
    for (int k = 0; k < kTools; ++k)
      if (ImGui::IsKeyPressed('1' + k)) tool_ = static_cast<Tool>(k);
  }
}

// The panels are opaque: the renderer leaves the pixels under them unshaded.
void Viewer::cover_window() {
  const ImVec2 pos = ImGui::GetWindowPos(), size = ImGui::GetWindowSize();
  const ImVec2 scale = ImGui::GetIO().DisplayFramebufferScale;
  render_options_.covered.push_back({.x = static_cast<int>(std::ceil(pos.x * scale.x)),
                                     .y = static_cast<int>(std::ceil(pos.y * scale.y)),
                                     .width = static_cast<int>(std::floor(size.x * scale.x)) - 1,
                                     .height = static_cast<int>(std::floor(size.y * scale.y)) - 1});
}

void Viewer::ui() {
  World& w = *built_->world;
  render_options_.covered.clear();
  ImGui::SetNextWindowPos(ImVec2(10, 10), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowSize(ImVec2(400, 0), ImGuiCond_FirstUseEver);
  ImGui::Begin("shatter");
  cover_window();
  // Scene.
  if (!scene_files_.empty()) {
    const std::string current =
        scene_pick_ >= 0 && scene_pick_ < static_cast<int>(scene_files_.size())
            ? std::filesystem::path(scene_files_[static_cast<std::size_t>(scene_pick_)]).stem().string()
            : scene_.name;
    if (ImGui::BeginCombo("scene", current.c_str())) {
      for (std::size_t i = 0; i < scene_files_.size(); ++i)
        if (ImGui::Selectable(std::filesystem::path(scene_files_[i]).stem().string().c_str(),
                              static_cast<int>(i) == scene_pick_)) {
          const std::string path = scene_files_[i];
          if (load_scene(path)) scene_pick_ = static_cast<int>(i);
        }
      ImGui::EndCombo();
    }
  }
  // Time.
  if (ImGui::Button(playing_ ? "Pause" : "Play")) playing_ = !playing_;
  ImGui::SameLine();
  if (ImGui::Button("Step")) {
    playing_ = false;
    step_once();
  }
  ImGui::SameLine();
  if (ImGui::Button("Reset")) reset();
  float scale = static_cast<float>(time_scale_);
  if (ImGui::SliderFloat("time scale", &scale, 0.05F, 2.0F, "%.2f")) time_scale_ = scale;
  int cursor = static_cast<int>(cursor_);
  const int last = static_cast<int>(recording_.size()) - 1;
  if (ImGui::SliderInt("recording", &cursor, 0, std::max(last, 0), "step %d")) {
    playing_ = false;
    scrub_to(static_cast<std::size_t>(cursor));
  }
  ImGui::Text("t = %.3f s (%lld steps)", w.time(), static_cast<long long>(w.step_count()));
  // Tools.
  ImGui::Separator();
  ImGui::TextDisabled("tool");
  int tool = static_cast<int>(tool_);
  for (int k = 0; k < kTools; ++k) {
    if (k) ImGui::SameLine();
    ImGui::RadioButton(kToolNames[k], &tool, k);
  }
  tool_ = static_cast<Tool>(tool);
  auto input = [](const char* label, double& v, double lo, double hi, const char* format) {
    float f = static_cast<float>(v);
    if (ImGui::SliderFloat(label, &f, static_cast<float>(lo), static_cast<float>(hi), format,
                           ImGuiSliderFlags_Logarithmic))
      v = f;
  };
  switch (tool_) {
    case Tool::hammer:
      input("impulse, N s", hammer_impulse_, 0.1, 500, "%.3g");
      input("hammer speed, m/s", hammer_speed_, 0.5, 50, "%.3g");
      {
        float r = static_cast<float>(hammer_radius_ * 1000);
        if (ImGui::SliderFloat("face radius, mm (0: Hertz)", &r, 0.0F, 100.0F, "%.1f")) hammer_radius_ = r / 1000.0;
      }
      break;
    case Tool::press:
      input("force, N", press_force_, 1, 1e6, "%.3g");
      input("radius, m", press_radius_, 0.002, 0.2, "%.3g");
      break;
    case Tool::throw_asset:
      if (!assets_.empty()) {
        const std::string name = std::filesystem::path(assets_[static_cast<std::size_t>(asset_)].first).stem().string();
        if (ImGui::BeginCombo("asset", name.c_str())) {
          for (std::size_t i = 0; i < assets_.size(); ++i)
            if (ImGui::Selectable(std::filesystem::path(assets_[i].first).stem().string().c_str(),
                                  static_cast<int>(i) == asset_))
              asset_ = static_cast<int>(i);
          ImGui::EndCombo();
        }
      }
      input("throw speed, m/s", throw_speed_, 0.5, 40, "%.3g");
      if (ImGui::Button("Drop from above")) throw_asset(true);
      ImGui::SameLine();
      ImGui::TextDisabled("(click: throw)");
      break;
    case Tool::drag: ImGui::TextDisabled("click and drag a body"); break;
    case Tool::slice: ImGui::TextDisabled("draw a line across bodies: the plane through it cuts them"); break;
  }
  if (tool_active_ && tool_ == Tool::slice)
    ImGui::GetForegroundDrawList()->AddLine(ImVec2(static_cast<float>(stroke_x0_), static_cast<float>(stroke_y0_)),
                                            ImVec2(static_cast<float>(stroke_x1_), static_cast<float>(stroke_y1_)),
                                            IM_COL32(255, 220, 60, 255), 2.0F);
  // View.
  ImGui::Separator();
  ImGui::TextDisabled("view");
  bool stress = render_options_.view == render::ViewMode::stress;
  if (ImGui::Checkbox("stress (V)", &stress))
    render_options_.view = stress ? render::ViewMode::stress : render::ViewMode::material;
  ImGui::SameLine();
  ImGui::Checkbox("marks", &render_options_.marks);
  ImGui::SameLine();
  ImGui::Checkbox("shadows", &render_options_.shadows);
  if (stress) {
    float mpa = static_cast<float>(render_options_.stress_scale / 1e6);
    if (ImGui::SliderFloat("scale, MPa (0 auto)", &mpa, 0.0F, 200.0F, "%.3g", ImGuiSliderFlags_Logarithmic))
      render_options_.stress_scale = mpa * 1e6;
  }
  if (ImGui::Button("Screenshot (P)"))
    screenshot(fmt::format("{}/screenshot_{:03d}.png", opt_.out_dir, screenshot_count_++));
  // Selection: its material (for the scene's own bodies: edit and restart).
  if (selected_.index >= 0 && w.valid(selected_) && w.model(selected_)) {
    ImGui::Separator();
    ImGui::TextDisabled("selected");
    const BodyModel& m = *w.model(selected_);
    ImGui::Text(
        "body %d: %d tets, %.3g kg%s", selected_.index, static_cast<int>(m.mesh.num_tets()), m.mass.mass,
        w.parent(selected_).index >= 0 ? fmt::format(" (from body {})", w.parent(selected_).index).c_str() : "");
    const auto it = std::find(built_->bodies.begin(), built_->bodies.end(), selected_);
    if (it != built_->bodies.end()) {
      Material& mat = scene_.bodies[static_cast<std::size_t>(it - built_->bodies.begin())].material;
      if (ImGui::BeginCombo("preset", mat.name.c_str())) {
        for (const char* p : {"porcelain", "glass", "concrete", "granite", "marble", "terracotta", "modelling_clay",
                              "steel", "aluminium", "lead", "abs", "acrylic"})
          if (ImGui::Selectable(p, mat.name == p)) mat = *material_preset(p);
        ImGui::EndCombo();
      }
      input("E, Pa", mat.youngs_modulus, 1e4, 4e11, "%.3g");
      float nu = static_cast<float>(mat.poisson_ratio);
      if (ImGui::SliderFloat("Poisson", &nu, 0.0F, 0.49F, "%.2f")) mat.poisson_ratio = nu;
      input("density", mat.density, 100, 20000, "%.4g");
      input("tensile strength", mat.tensile_strength, 1e3, 1e10, "%.3g");
      input("yield stress", mat.yield_stress, 1e3, 1e10, "%.3g");
      if (ImGui::Button("Apply and restart")) {
        if (auto ok = validate_material(mat); !ok) {
          log("material: " + ok.error().message);
        } else {
          const BodyId keep = selected_;
          rebuild();
          selected_ = keep;
        }
      }
    } else {
      ImGui::Text("%s: E %.3g Pa, tensile %.3g Pa", m.fem.material.name.c_str(), m.fem.material.youngs_modulus,
                  m.fem.material.tensile_strength);
    }
  }
  // Statistics.
  ImGui::Separator();
  ImGui::TextDisabled("statistics");
  std::int64_t tets = 0, fragments = 0;
  for (Index s = 0; s < w.body_count(); ++s) {
    const BodyId id = w.body_id(s);
    if (w.removed(id) || !w.model(id)) continue;
    tets += w.model(id)->mesh.num_tets();
    if (w.parent(id).index >= 0) ++fragments;
  }
  ImGui::Text("%.0f fps, frame %.1f ms, draw %.1f ms", fps_, frame_ms_, draw_ms_);
  ImGui::Text("step %.2f ms: broad %.2f, narrow %.2f, solve %.2f, deformable %.2f, impacts %.2f", last_step_ms_,
              last_stats_.broad_phase_ms, last_stats_.narrow_phase_ms, last_stats_.solver_ms, last_stats_.deformable_ms,
              last_stats_.impact_ms);
  ImGui::Text("%d bodies, %lld tets, %lld fragments, %lld contacts", static_cast<int>(w.live_body_count()),
              static_cast<long long>(tets), static_cast<long long>(fragments),
              static_cast<long long>(last_stats_.contacts));
  ImGui::End();

  // Event log.
  const ImVec2 display = ImGui::GetIO().DisplaySize;
  ImGui::SetNextWindowPos(ImVec2(std::max(10.0F, display.x - 430), std::max(10.0F, display.y - 140)),
                          ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowSize(ImVec2(420, 130), ImGuiCond_FirstUseEver);
  ImGui::Begin("events");
  cover_window();
  for (const std::string& line : log_) ImGui::TextUnformatted(line.c_str());
  if (ImGui::GetScrollY() >= ImGui::GetScrollMaxY()) ImGui::SetScrollHereY(1.0F);
  ImGui::End();
}

bool Viewer::screenshot(const std::string& path) {
  int fbw = 0, fbh = 0;
  glfwGetFramebufferSize(window_, &fbw, &fbh);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  glReadBuffer(GL_BACK);
  const render::Image img = render::read_framebuffer(fbw, fbh);
  if (auto ok = render::write_png(path, img); !ok) {
    log("screenshot: " + ok.error().message);
    std::fprintf(stderr, "shatter: error: %s\n", ok.error().message.c_str());
    return false;
  }
  log("screenshot " + path);
  std::printf("screenshot %s\n", path.c_str());
  return true;
}

std::optional<Vec2> Viewer::body_on_screen(const std::string& name) {
  const World& w = *built_->world;
  std::size_t i = 0;
  while (i < scene_.bodies.size() && scene_.bodies[i].name != name) ++i;
  if (i == scene_.bodies.size() || built_->bodies[i].index < 0 || !w.valid(built_->bodies[i]) ||
      w.removed(built_->bodies[i])) {
    log("script: no live body named " + name);
    return std::nullopt;
  }
  int ww = 0, wh = 0;
  glfwGetWindowSize(window_, &ww, &wh);
  const Vec3 p = camera_.project(w.rigid_state(built_->bodies[i]).position, ww, wh);
  return Vec2(p.x(), p.y());
}

// Script steps due at this frame. Clicks go through the same tool path as the mouse.
void Viewer::run_script() {
  while (script_next_ < script_.size() && script_[script_next_].frame <= frame_) {
    const ScriptStep& s = script_[script_next_++];
    World& w = *built_->world;
    if (s.action == "tool") {
      std::string lower = s.args.value("tool", "");
      for (char& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
      if (lower == "drag") tool_ = Tool::drag;
      if (lower == "hammer") tool_ = Tool::hammer;
      if (lower == "press") tool_ = Tool::press;
      if (lower == "throw") tool_ = Tool::throw_asset;
      if (lower == "slice") tool_ = Tool::slice;
      if (s.args.contains("impulse")) hammer_impulse_ = s.args["impulse"].get<double>();
      if (s.args.contains("speed")) hammer_speed_ = s.args["speed"].get<double>();
      if (s.args.contains("force")) press_force_ = s.args["force"].get<double>();
      if (s.args.contains("radius"))
        (tool_ == Tool::press ? press_radius_ : hammer_radius_) = s.args["radius"].get<double>();
    } else if (s.action == "click") {
      // At a pixel, or at the projected centre of a scene body.
      double x = 0, y = 0;
      if (s.args.contains("body")) {
        const auto p = body_on_screen(s.args["body"].get<std::string>());
        if (!p) continue;
        x = p->x();
        y = p->y();
      } else {
        x = s.args.value("x", 0.0);
        y = s.args.value("y", 0.0);
      }
      tool_down(x, y);
      tool_up();
    } else if (s.action == "drag") {  // press at "from", move to "to", release (the slice tool's stroke)
      double x0 = 0, y0 = 0, x1 = 0, y1 = 0;
      if (s.args.contains("across")) {  // a level stroke 300 px long through a body's centre on screen
        const auto c = body_on_screen(s.args["across"].get<std::string>());
        if (!c) continue;
        x0 = c->x() - 150;
        x1 = c->x() + 150;
        y0 = y1 = c->y();
      } else {
        x0 = s.args["from"][0].get<double>();
        y0 = s.args["from"][1].get<double>();
        x1 = s.args["to"][0].get<double>();
        y1 = s.args["to"][1].get<double>();
      }
      tool_down(x0, y0);
      tool_drag(x1, y1);
      tool_up();
    } else if (s.action == "screenshot") {
      if (!screenshot(s.args.value("path", fmt::format("{}/screenshot_{:03d}.png", opt_.out_dir, screenshot_count_++))))
        exit_code_ = 4;
    } else if (s.action == "view") {
      render_options_.view =
          s.args.value("view", "material") == "stress" ? render::ViewMode::stress : render::ViewMode::material;
    } else if (s.action == "play") {
      playing_ = true;
    } else if (s.action == "pause") {
      playing_ = false;
    } else if (s.action == "step") {
      step_once();
    } else if (s.action == "reset") {
      reset();
    } else if (s.action == "quit") {
      quit_ = true;
    } else if (s.action == "expect_bodies_at_least") {
      const int n = s.args.value("count", 0);
      const int live = w.live_body_count() - (built_->ground.index >= 0 ? 1 : 0);
      std::printf("bodies %d (expected at least %d)\n", live, n);
      if (live < n) exit_code_ = 1;
    }
  }
}

int Viewer::run() {
  glfwSetErrorCallback(on_glfw_error);
  if (!glfwInit()) {
    std::fprintf(stderr,
                 "shatter: error: cannot open a window: %s\n"
                 "  (no display? render without one: shatter render %s --out DIR)\n",
                 g_glfw_error.c_str(), opt_.scene.c_str());
    return 1;
  }
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
  glfwWindowHint(GLFW_SAMPLES, opt_.msaa);
  glfwWindowHint(GLFW_STENCIL_BITS, 8);  // the ground's shadows count pixels in it
  window_ = glfwCreateWindow(opt_.width, opt_.height, "shatter", nullptr, nullptr);
  if (!window_) {
    std::fprintf(stderr,
                 "shatter: error: cannot open an OpenGL 3.3 window: %s\n"
                 "  (render without one: shatter render %s --out DIR)\n",
                 g_glfw_error.c_str(), opt_.scene.c_str());
    return 1;
  }
  glfwMakeContextCurrent(window_);
  glfwSwapInterval(opt_.vsync ? 1 : 0);
  auto renderer = render::Renderer::create();
  if (!renderer) {
    std::fprintf(stderr, "shatter: error: %s\n", renderer.error().message.c_str());
    return 1;
  }
  renderer_ = std::move(*renderer);
  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;  // no imgui.ini left in the user's folder
  ImGui::StyleColorsDark();
  // Opaque panels (the scene is not drawn under them, Viewer::cover_window).
  ImGui::GetStyle().Colors[ImGuiCol_WindowBg].w = 1.0F;
  ImGui::GetStyle().Colors[ImGuiCol_TitleBgCollapsed].w = 1.0F;
  ImGui_ImplGlfw_InitForOpenGL(window_, true);
  ImGui_ImplOpenGL3_Init("#version 330 core");

  if (!load_scene(opt_.scene)) return 3;
  if (!opt_.script.empty()) {
    auto script = read_script(opt_.script);
    if (!script) {
      std::fprintf(stderr, "shatter: error: %s\n", script.error().message.c_str());
      return 3;
    }
    script_ = std::move(*script);
  }
  std::printf("viewer: %s on %s\n", scene_.name.c_str(), renderer_->device().c_str());
  auto last = Clock::now();
  double fps_time = 0;
  int fps_frames = 0;
  double total_time = 0;
  std::int64_t total_frames = 0;
  while (!glfwWindowShouldClose(window_) && !quit_ && (opt_.frames < 0 || frame_ < opt_.frames)) {
    glfwPollEvents();
    const auto now = Clock::now();
    const double wall = std::chrono::duration<double>(now - last).count();
    last = now;
    ImGui_ImplOpenGL3_NewFrame();
    ImGui_ImplGlfw_NewFrame();
    ImGui::NewFrame();
    handle_mouse();
    run_script();
    if (playing_) {
      const double dt = built_->world->settings().time_step;
      if (opt_.fixed_step) {
        step_once();
      } else {
        accumulator_ = std::min(accumulator_ + wall * time_scale_, 4 * dt);  // no spiral when slow
        while (accumulator_ >= dt) {
          step_once();
          accumulator_ -= dt;
        }
      }
    }
    ui();
    ImGui::Render();
    int fbw = 0, fbh = 0;
    glfwGetFramebufferSize(window_, &fbw, &fbh);
    const auto d0 = Clock::now();
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    renderer_->draw(render::frame_from_world(*built_->world, &marks_, selected_), camera_, fbw, fbh, render_options_);
    ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
    draw_ms_ = std::chrono::duration<double, std::milli>(Clock::now() - d0).count();
    glfwSwapBuffers(window_);
    ++frame_;
    frame_ms_ = wall * 1000;
    fps_time += wall;
    ++fps_frames;
    if (frame_ > 1) {
      total_time += wall;
      ++total_frames;
    }
    if (fps_time >= 0.5) {
      fps_ = fps_frames / fps_time;
      fps_time = 0;
      fps_frames = 0;
    }
  }
  if (total_frames > 0)
    std::printf("viewer: %lld frames at %dx%d, %.1f fps on average, %.3f s simulated\n",
                static_cast<long long>(total_frames), opt_.width, opt_.height, total_frames / total_time,
                built_->world->time());
  return exit_code_;
}

}  // namespace

int run_viewer(const ViewerOptions& options) {
  Viewer v(options);
  return v.run();
}

}  // namespace shatter::viewer
