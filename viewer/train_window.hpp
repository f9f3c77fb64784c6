// The trainee's window (`scalpelsim train`): a GLFW window on a live Session. The window's thread
// only draws the newest published frame and turns the mouse and keys into the pointer device's
// input and the session's controls; cutting and tissue run in the session's threads.
//
// Mouse and keys (also listed in the window's help panel and the README):
//   pointer device: the cursor moves the blade over the skin, the wheel lowers and raises it
//                   (Up/Down arrows too), Left/Right arrows turn its edge, PageUp/PageDown tilt it
//   right drag: orbit the camera; middle drag or Shift + right drag: pan; Ctrl + wheel, + and -: zoom
//   Space: pause; R: reset to the scenario's start; T: see-through skin; F: tetrahedra's edges;
//   P: screenshot; [ and ]: slower and faster playback; H: help; Esc: close.
//   rigid tissue: Ctrl + left drag moves the piece under the cursor, Ctrl + Shift + left drag turns
//                 it, Delete deletes it, U undoes the last move (sent to the session, which records
//                 them for replay)
#pragma once

#include <atomic>
#include <filesystem>
#include <functional>
#include <string>

#include "devices/playback_device.hpp"
#include "devices/pointer_device.hpp"
#include "sim/session.hpp"

namespace scalpel {

struct TrainWindowOptions {
  std::string title = "scalpelsim";
  int width = 1024, height = 640;
  double close_after = 0.0;                    // [s] close by itself after this long; 0: never
  bool close_at_end = false;                   // close when a played-back log has been cut to its end
  std::filesystem::path screenshot_dir = ".";  // where P writes
  std::filesystem::path final_screenshot;      // written just before the window closes, if set
  bool transparent = false, wireframe = false;
  const std::atomic<bool>* stop = nullptr;  // closes the window when it becomes true (Ctrl-C)
};

struct TrainWindowResult {
  std::vector<double> render_seconds;  // [s] per rendered frame: drawing, overlay and swap
  std::vector<std::filesystem::path> screenshots;
};

// Opens the window, starts the session, runs until the window is closed (or close_after), then
// stops the session. `pointer` is the session's device when it is the mouse, `playback` when it
// plays back a log. Throws RenderError when there is no display or no OpenGL 3.3 context (before
// the session starts).
TrainWindowResult run_train_window(Session& session, PointerDevice* pointer, PlaybackDevice* playback,
                                   const TrainWindowOptions& options);

}  // namespace scalpel
