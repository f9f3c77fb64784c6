#include "viewer/train_window.hpp"

// GLFW's header after ours, without its own GL header: viewer/gl.hpp has declared OpenGL.
#include "viewer/gl.hpp"
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl3.h>
#include <imgui.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <exception>
#include <optional>
#include <string>
#include <thread>

#include "sim/quantile.hpp"
#include "viewer/camera.hpp"
#include "viewer/picking.hpp"
#include "viewer/pictures.hpp"
#include "viewer/renderer.hpp"

namespace scalpel {

namespace {

using Clock = std::chrono::steady_clock;

constexpr float kPanelWidth = 360.0f;  // [px] the overlay's width

// What the GLFW callbacks change, reached through the window's user pointer.
struct InputState {
  double scroll = 0.0;  // [notches] the pointer's depth wheel, accumulated
  double zoom = 0.0;    // [notches] camera zoom, this frame
  bool pointer_mode = false;
  std::uint64_t events = 0;  // input events so far: a new one asks for a new picture
};

InputState& state_of(GLFWwindow* window) {
  return *static_cast<InputState*>(glfwGetWindowUserPointer(window));
}
void on_cursor(GLFWwindow* w, double, double) {
  ++state_of(w).events;
}
void on_button(GLFWwindow* w, int, int, int) {
  ++state_of(w).events;
}
void on_key(GLFWwindow* w, int, int, int, int) {
  ++state_of(w).events;
}
void on_resize(GLFWwindow* w, int, int) {
  ++state_of(w).events;
}
void on_focus(GLFWwindow* w, int) {
  ++state_of(w).events;
}

void on_scroll(GLFWwindow* window, double, double dy) {
  auto* s = &state_of(window);
  ++s->events;
  if (ImGui::GetCurrentContext() && ImGui::GetIO().WantCaptureMouse) return;
  const bool ctrl = glfwGetKey(window, GLFW_KEY_LEFT_CONTROL) == GLFW_PRESS ||
                    glfwGetKey(window, GLFW_KEY_RIGHT_CONTROL) == GLFW_PRESS;
  if (s->pointer_mode && !ctrl)
    s->scroll += dy;
  else
    s->zoom += dy;
}

void on_glfw_error(int code, const char* description) {
  std::fprintf(stderr, "GLFW error %d: %s\n", code, description);
}

// Owns GLFW and Dear ImGui for the window's lifetime.
class WindowSystem {
 public:
  WindowSystem(const TrainWindowOptions& o, InputState& input) {
    glfwSetErrorCallback(on_glfw_error);
    if (!glfwInit())
      throw RenderError("no display for the window: set DISPLAY, or run under xvfb-run for a virtual one");
    glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
    glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
    glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
    glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
    glfwWindowHint(GLFW_SAMPLES, 0);
    window = glfwCreateWindow(o.width, o.height, o.title.c_str(), nullptr, nullptr);
    if (!window) {
      glfwTerminate();
      throw RenderError("no OpenGL 3.3 core context on this display");
    }
    glfwMakeContextCurrent(window);
    glfwSwapInterval(1);
    glfwSetWindowUserPointer(window, &input);
    // Before ImGui, which chains to them.
    glfwSetScrollCallback(window, on_scroll);
    glfwSetCursorPosCallback(window, on_cursor);
    glfwSetMouseButtonCallback(window, on_button);
    glfwSetKeyCallback(window, on_key);
    glfwSetFramebufferSizeCallback(window, on_resize);
    glfwSetWindowFocusCallback(window, on_focus);
    IMGUI_CHECKVERSION();
    ImGui::CreateContext();
    ImGui::GetIO().IniFilename = nullptr;  // no imgui.ini in the user's folder
    ImGui::StyleColorsDark();
    ImGui_ImplGlfw_InitForOpenGL(window, true);
    ImGui_ImplOpenGL3_Init("#version 330 core");
  }
  ~WindowSystem() {
    ImGui_ImplOpenGL3_Shutdown();
    ImGui_ImplGlfw_Shutdown();
    ImGui::DestroyContext();
    glfwDestroyWindow(window);
    glfwTerminate();
  }
  WindowSystem(const WindowSystem&) = delete;
  WindowSystem& operator=(const WindowSystem&) = delete;

  GLFWwindow* window = nullptr;
};

bool key_down(GLFWwindow* w, int key) {
  return glfwGetKey(w, key) == GLFW_PRESS;
}

// A key that went down since the last frame.
class KeyEdges {
 public:
  bool pressed(GLFWwindow* w, int key) {
    const bool down = key_down(w, key);
    bool& was = state_[static_cast<std::size_t>(key) % state_.size()];
    const bool edge = down && !was;
    was = down;
    return edge;
  }

 private:
  std::array<bool, GLFW_KEY_LAST + 1> state_{};
};

// A piece of rigid tissue the trainee drags (Ctrl + left button): where the drag has taken it so
// far, shown in the window until the simulation has moved it there.
struct PieceDrag {
  std::uint32_t piece = 0;     // in the snapshot's pieces
  Vec3 inside = Vec3::Zero();  // a point in the piece where it was grabbed (Simulation::move_piece)
  Vec3 grab = Vec3::Zero();    // the grabbed surface point, moved with the drag
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  // about the piece's centroid
  Vec3 translation = Vec3::Zero();
  std::uint64_t request = 0;  // once released: the number of requests sent with it
};

void text_row(const char* label, const char* format, double value) {
  ImGui::TextUnformatted(label);
  ImGui::SameLine(170);
  ImGui::Text(format, value);
}

}  // namespace

TrainWindowResult run_train_window(Session& session, PointerDevice* pointer, PlaybackDevice* playback,
                                   const TrainWindowOptions& o) {
  InputState input;
  input.pointer_mode = pointer != nullptr;
  WindowSystem ws(o, input);
  GLFWwindow* window = ws.window;
  Renderer renderer;
  const auto* gl_renderer = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
  const std::string renderer_name = gl_renderer ? gl_renderer : "unknown";
  RenderOptions render_options;
  render_options.transparent_skin = o.transparent;
  render_options.wireframe = o.wireframe;
  session.set_wireframe_edges(o.wireframe);

  int fw = 0, fh = 0;
  glfwGetFramebufferSize(window, &fw, &fh);
  session.update();
  Camera camera = replay_views(session.frame().snapshot, static_cast<double>(fw) / std::max(fh, 1))[1].camera;
  // The overlay covers the left of the window: the scene's centre goes to the middle of the rest.
  camera.pan(-0.5 * kPanelWidth / std::max(fh, 1), 0.0);
  camera.zoom(1.1);
  const Camera home_camera = camera;

  TrainWindowResult result;
  KeyEdges keys;
  std::optional<PieceDrag> drag, placed;  // placed: released, until the session has taken it
  std::uint64_t piece_requests = 0;
  bool left_before = false;
  bool dropped_request = false;
  FrameSnapshot preview;  // the frame's snapshot with the dragged piece moved
  bool show_help = true, screenshot = false;
  double last_x = 0, last_y = 0;
  glfwGetCursorPos(window, &last_x, &last_y);
  const auto opened = Clock::now();
  const double frame_period = 1.0 / session.visual_rate();
  // A published frame wakes the window thread (glfwPostEmptyEvent may be called from any thread).
  session.set_on_publish([] { glfwPostEmptyEvent(); });
  // The session stops before GLFW goes, also when the loop throws: its thread calls into GLFW.
  struct StopSession {
    Session& session;
    ~StopSession() {
      session.stop();
      session.set_on_publish({});
    }
  } stop_session{session};
  session.start();
  std::uint64_t seen_events = 0;
  bool first = true;
  // Back to the scenario's start: the mouse's blade goes home too, so it does not start the new
  // attempt inside the tissue.
  const auto reset = [&] {
    if (pointer) pointer->rehome();
    session.request_reset();
  };

  while (true) {
    // A picture when there is something new to show: a frame of the session, or input. Otherwise
    // the thread sleeps, and the processor is the simulation's.
    glfwWaitEventsTimeout(0.1);
    const bool fresh = session.update();
    const bool timed_out =
        o.close_after > 0 && std::chrono::duration<double>(Clock::now() - opened).count() >= o.close_after;
    // Closing (the close button, Esc, a time limit, Ctrl-C, a failed session): one last picture.
    const bool closing =
        glfwWindowShouldClose(window) || timed_out || session.failed() || (o.stop && o.stop->load());
    if (!fresh && input.events == seen_events && !first && !closing) continue;
    seen_events = input.events;
    first = false;
    const auto frame_start = Clock::now();
    const ImGuiIO& io = ImGui::GetIO();
    glfwGetFramebufferSize(window, &fw, &fh);
    int ww = 0, wh = 0;
    glfwGetWindowSize(window, &ww, &wh);

    // Camera: right drag orbits, middle (or Shift + right) drag pans, Ctrl + wheel, + and - zoom.
    double cx = 0, cy = 0;
    glfwGetCursorPos(window, &cx, &cy);
    const double dx = cx - last_x, dy = cy - last_y;
    last_x = cx;
    last_y = cy;
    const bool shift = key_down(window, GLFW_KEY_LEFT_SHIFT) || key_down(window, GLFW_KEY_RIGHT_SHIFT);
    const bool right = glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_RIGHT) == GLFW_PRESS;
    const bool middle = glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_MIDDLE) == GLFW_PRESS;
    const bool dragging = !io.WantCaptureMouse && (right || middle);
    if (dragging && (middle || shift))
      camera.pan(-dx / std::max(wh, 1), dy / std::max(wh, 1));
    else if (dragging)
      camera.orbit(-dx * 0.008, dy * 0.008);
    if (input.zoom != 0.0) camera.zoom(std::pow(0.9, input.zoom));
    input.zoom = 0.0;

    // Pieces of rigid tissue (paper section 7.1): Ctrl + left drag moves the piece under the
    // cursor in the view's plane, with Shift it turns about its centroid (sideways about the
    // vertical, up and down about the view's horizontal); released, the move goes to the
    // simulation, which applies it at the end of its next frame and records it.
    const SessionFrame& f = session.frame();
    const SessionStatus& st = f.status;
    const bool pieces = !f.snapshot.pieces.empty() && fw > 0 && fh > 0 && ww > 0 && wh > 0;
    const bool ctrl = key_down(window, GLFW_KEY_LEFT_CONTROL) || key_down(window, GLFW_KEY_RIGHT_CONTROL);
    const bool left = glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_LEFT) == GLFW_PRESS;
    const bool left_pressed = left && !left_before;
    left_before = left;
    const auto cursor_ray = [&](double x, double y) {
      return camera_ray(camera, (x + 0.5) * fw / std::max(ww, 1), (y + 0.5) * fh / std::max(wh, 1), fw, fh);
    };
    const Vec3 view_axis = (camera.target - camera.eye()).normalized();
    const auto request = [&](const PieceMove& m) {
      if (session.request_piece(m))
        ++piece_requests;
      else
        dropped_request = true;  // the simulation has not taken the last 16 yet
    };
    const auto undo = [&] {
      PieceMove m;
      m.action = PieceAction::Undo;
      request(m);
    };
    if (placed && st.pieces_taken >= placed->request) placed.reset();
    // A frame that changed the pieces (a cut, a deletion) calls off a drag of one that is gone.
    if (drag && drag->piece >= f.snapshot.pieces.size()) drag.reset();
    if (placed && placed->piece >= f.snapshot.pieces.size()) placed.reset();
    if (pieces && !drag && ctrl && left_pressed && !io.WantCaptureMouse)
      if (const std::optional<PieceHit> hit = pick_piece(f.snapshot, cursor_ray(cx, cy)))
        drag = PieceDrag{hit->piece, hit->inside, hit->surface, Eigen::Matrix3d::Identity(), Vec3::Zero(), 0};
    if (drag && !left) {
      if (!drag->rotation.isIdentity(0.0) || drag->translation != Vec3::Zero()) {
        PieceMove m;
        m.action = PieceAction::Move;
        m.point = drag->inside;
        m.translation = drag->translation;
        m.rotation = Eigen::Quaterniond(drag->rotation).normalized();
        request(m);
        drag->request = piece_requests;
        placed = drag;
      }
      drag.reset();
    } else if (drag && shift) {
      const Vec3 across = view_axis.cross(Vec3::UnitZ());
      const Eigen::Matrix3d turn =
          (Eigen::AngleAxisd(dx * 0.01, Vec3::UnitZ()) *
           Eigen::AngleAxisd(dy * 0.01, across.norm() > 1e-6 ? Vec3(across.normalized()) : Vec3::UnitX()))
              .toRotationMatrix();
      drag->rotation = turn * drag->rotation;
    } else if (drag) {
      const std::optional<Vec3> from = ray_plane(cursor_ray(cx - dx, cy - dy), drag->grab, view_axis);
      const std::optional<Vec3> to = ray_plane(cursor_ray(cx, cy), drag->grab, view_axis);
      if (from && to) {
        drag->translation += *to - *from;
        drag->grab += *to - *from;
      }
    }

    if (!io.WantCaptureKeyboard) {
      if (keys.pressed(window, GLFW_KEY_ESCAPE)) {
        if (drag)
          drag.reset();  // the drag is called off; the piece stays where it was
        else
          glfwSetWindowShouldClose(window, GLFW_TRUE);
      }
      if (pieces && !drag && keys.pressed(window, GLFW_KEY_DELETE))
        if (const std::optional<PieceHit> hit = pick_piece(f.snapshot, cursor_ray(cx, cy))) {
          PieceMove m;
          m.action = PieceAction::Delete;
          m.point = hit->inside;
          request(m);
        }
      if (pieces && !drag && keys.pressed(window, GLFW_KEY_U)) undo();
      if (keys.pressed(window, GLFW_KEY_SPACE)) session.set_paused(!session.paused());
      if (keys.pressed(window, GLFW_KEY_R)) reset();
      if (keys.pressed(window, GLFW_KEY_T))
        render_options.transparent_skin = !render_options.transparent_skin;
      if (keys.pressed(window, GLFW_KEY_F)) render_options.wireframe = !render_options.wireframe;
      if (keys.pressed(window, GLFW_KEY_P)) screenshot = true;
      if (keys.pressed(window, GLFW_KEY_H)) show_help = !show_help;
      if (keys.pressed(window, GLFW_KEY_C)) camera = home_camera;
      if (keys.pressed(window, GLFW_KEY_EQUAL) || keys.pressed(window, GLFW_KEY_KP_ADD)) camera.zoom(0.8);
      if (keys.pressed(window, GLFW_KEY_MINUS) || keys.pressed(window, GLFW_KEY_KP_SUBTRACT))
        camera.zoom(1.25);
      if (playback && keys.pressed(window, GLFW_KEY_LEFT_BRACKET)) playback->set_speed(playback->speed() / 2);
      if (playback && keys.pressed(window, GLFW_KEY_RIGHT_BRACKET))
        playback->set_speed(playback->speed() * 2);
    }
    session.set_wireframe_edges(render_options.wireframe);

    if (pointer) {
      // The cursor, turned with the camera, so the blade follows the hand on the screen: right is
      // the view's right, down the screen is towards the eye.
      const double s = std::sin(camera.yaw), c = std::cos(camera.yaw);
      PointerInput in;
      in.cursor_x = -cx * s + cy * c;
      in.cursor_y = -(cx * c + cy * s);
      in.scroll = input.scroll;
      in.buttons = left && !ctrl ? 1u : 0u;
      if (!io.WantCaptureKeyboard) {
        if (key_down(window, GLFW_KEY_UP)) in.keys |= PointerDevice::Raise;
        if (key_down(window, GLFW_KEY_DOWN)) in.keys |= PointerDevice::Lower;
        if (key_down(window, GLFW_KEY_LEFT)) in.keys |= PointerDevice::YawLeft;
        if (key_down(window, GLFW_KEY_RIGHT)) in.keys |= PointerDevice::YawRight;
        if (key_down(window, GLFW_KEY_PAGE_UP)) in.keys |= PointerDevice::PitchUp;
        if (key_down(window, GLFW_KEY_PAGE_DOWN)) in.keys |= PointerDevice::PitchDown;
      }
      // The blade holds still while the camera moves, over the panel, and without the pointer.
      const bool inside = cx >= 0 && cy >= 0 && cx < ww && cy < wh;
      in.focused = glfwGetWindowAttrib(window, GLFW_FOCUSED) && inside && !dragging && !drag &&
                   !io.WantCaptureMouse && !session.paused();
      pointer->publish(in);
    }

    const FrameSnapshot* shown = &f.snapshot;
    if (const std::optional<PieceDrag>& d = drag ? drag : placed; d) {
      preview = f.snapshot;
      move_piece_preview(preview, d->piece, d->rotation, d->translation);
      shown = &preview;
    }
    renderer.draw(*shown, camera, render_options, fw, fh);

    ImGui_ImplOpenGL3_NewFrame();
    ImGui_ImplGlfw_NewFrame();
    ImGui::NewFrame();
    ImGui::SetNextWindowPos(ImVec2(10, 10), ImGuiCond_FirstUseEver);
    ImGui::SetNextWindowSize(ImVec2(kPanelWidth, 0), ImGuiCond_FirstUseEver);
    ImGui::Begin("Session");
    ImGui::Text("%s   t = %.1f s%s", o.title.c_str(), st.time, st.paused ? "   PAUSED" : "");
    if (!st.device_ok) {
      if (pointer)  // held on purpose: over the panel, the camera moving, paused, out of the window
        ImGui::TextDisabled("Blade held still");
      else
        ImGui::TextColored(ImVec4(1, 0.5f, 0.2f, 1), "%s",
                           playback ? "Playback at its end" : "Device not responding: the blade is frozen");
    }
    if (st.has_task) {
      ImGui::Separator();
      ImGui::TextDisabled("Your incision");
      const TaskScore& t = st.task;
      text_row("Score", "%.0f / 100", t.score);
      // The components as the report gives them (docs/scoring.md): green when they pass.
      for (const ScoreComponent& c : t.components) {
        if (c.points_max == 0 && !c.threshold) continue;
        ImGui::TextUnformatted(c.name.c_str());
        ImGui::SameLine(170);
        const ImVec4 colour = c.passed ? ImVec4(0.5f, 1, 0.5f, 1) : ImVec4(1, 0.6f, 0.3f, 1);
        const char* unit = c.unit == "count" || c.unit == "ratio" ? "" : c.unit.c_str();
        if (c.threshold)
          ImGui::TextColored(colour, "%.3g %s (%s %.3g)", c.value, unit, c.at_most ? "max" : "min",
                             *c.threshold);
        else
          ImGui::TextColored(colour, "%.3g %s", c.value, unit);
        if (!c.why.empty() && ImGui::IsItemHovered()) ImGui::SetTooltip("%s", c.why.c_str());
      }
      if (st.tip.in_tissue) text_row("Tip depth now", "%.2f mm", 1e3 * st.tip.depth);
    }
    ImGui::Separator();
    ImGui::TextDisabled("Hand and machine");
    text_row("Force on the hand", "%.2f N", st.hand_force);
    text_row("Haptic rate", "%.0f Hz", st.haptic_rate);
    text_row("Haptic jitter (RMS)", "%.0f us", 1e6 * st.haptic_jitter);
    text_row("Simulation frame", "%.1f ms", 1e3 * st.frame_seconds);
    text_row("  p99 (last 256)", "%.1f ms", 1e3 * st.frame_seconds_p99);
    const auto recent =
        std::min<std::ptrdiff_t>(256, static_cast<std::ptrdiff_t>(result.render_seconds.size()));
    const double render_p99 =
        recent > 10 ? quantile({result.render_seconds.end() - recent, result.render_seconds.end()}, 0.99)
                    : 0.0;
    text_row("Render frame p99", "%.1f ms", 1e3 * render_p99);
    ImGui::Text("Tetrahedra %zu, nodes %zu", f.snapshot.tetrahedra, f.snapshot.nodes);
    ImGui::TextDisabled("OpenGL: %s", renderer_name.c_str());
    if (st.recorded > 0) ImGui::Text("Recording: %zu samples", st.recorded);
    ImGui::Separator();
    if (ImGui::Button(session.paused() ? "Resume (Space)" : "Pause (Space)"))
      session.set_paused(!session.paused());
    ImGui::SameLine();
    if (ImGui::Button("Reset (R)")) reset();
    ImGui::SameLine();
    if (ImGui::Button("Screenshot (P)")) screenshot = true;
    if (pieces) {
      ImGui::Separator();
      ImGui::TextDisabled("Pieces");
      ImGui::Text("%zu piece%s", f.snapshot.pieces.size(), f.snapshot.pieces.size() == 1 ? "" : "s");
      if (drag) ImGui::Text("Moving %zu tetrahedra", f.snapshot.pieces[drag->piece].tetrahedra);
      if (!st.piece_refusal.empty())
        ImGui::TextColored(ImVec4(1, 0.6f, 0.3f, 1), "Not done: %s", st.piece_refusal.c_str());
      if (dropped_request)
        ImGui::TextColored(ImVec4(1, 0.6f, 0.3f, 1), "A move was dropped: too many waiting");
      if (ImGui::Button("Undo move (U)")) undo();
    }
    ImGui::Checkbox("See-through skin (T)", &render_options.transparent_skin);
    ImGui::Checkbox("Tetrahedra (F)", &render_options.wireframe);
    if (playback) {
      float speed = static_cast<float>(playback->speed());
      if (ImGui::SliderFloat("Speed", &speed, 0.25f, 4.0f, "%.2fx", ImGuiSliderFlags_Logarithmic))
        playback->set_speed(speed);
      ImGui::ProgressBar(
          static_cast<float>(std::min(1.0, playback->position() / std::max(playback->duration(), 1e-9))));
    }
    if (ImGui::CollapsingHeader("Controls (H)", show_help ? ImGuiTreeNodeFlags_DefaultOpen : 0)) {
      if (pointer)
        ImGui::TextWrapped(
            "Move the mouse: the blade follows over the skin. Wheel or Up/Down: lower and raise it. "
            "Left/Right: turn its edge. PageUp/PageDown: tilt it. The blade cuts where its edge moves "
            "forward through the tissue.");
      ImGui::TextWrapped(
          "Right drag: orbit. Middle or Shift+right drag: pan. %s: zoom. C: home view. Esc: close.",
          pointer ? "Ctrl+wheel, + and -" : "Wheel, + and -");
      if (playback) ImGui::TextWrapped("[ and ]: half and double speed. R: restart.");
      if (pieces)
        ImGui::TextWrapped(
            "Ctrl+left drag: move the piece under the cursor. Ctrl+Shift+left drag: turn it. Delete: "
            "delete the piece under the cursor. U: undo the last move. Esc during a drag: call it off.");
    }
    ImGui::End();
    ImGui::Render();
    ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());

    // At the end of a playback: the device has run out and the simulation has taken its last pose.
    if (o.close_at_end && playback && st.playback_ended) glfwSetWindowShouldClose(window, GLFW_TRUE);
    if (screenshot || (closing && !o.final_screenshot.empty())) {
      // Named by the wall-clock time, so a later session does not overwrite them.
      char stamp[32] = "";
      const std::time_t now = std::time(nullptr);
      std::tm local{};
      localtime_r(&now, &local);
      std::strftime(stamp, sizeof stamp, "%Y%m%d-%H%M%S", &local);
      char name[64];
      std::snprintf(name, sizeof name, "scalpelsim-%s-%zu.png", stamp, result.screenshots.size() + 1);
      const std::filesystem::path path =
          closing && !o.final_screenshot.empty() ? o.final_screenshot : o.screenshot_dir / name;
      try {
        glReadBuffer(GL_BACK);
        write_png(read_pixels(fw, fh), path);
        result.screenshots.push_back(path);
      } catch (const std::exception& e) {
        std::fprintf(stderr, "warning: %s\n", e.what());  // a lost screenshot must not end the session
      }
      screenshot = false;
    }
    glfwSwapBuffers(window);
    result.render_seconds.push_back(std::chrono::duration<double>(Clock::now() - frame_start).count());
    if (closing) break;
    // At most one picture per visual frame, also on a display without vertical sync (a virtual one).
    const double rest = frame_period - std::chrono::duration<double>(Clock::now() - frame_start).count();
    if (rest > 0) std::this_thread::sleep_for(std::chrono::duration<double>(rest));
  }
  return result;
}

}  // namespace scalpel
