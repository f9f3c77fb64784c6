// Headless replay of a recorded pose log (docs/architecture.md and docs/formats.md): the same path a real
// device takes. A MockDevice replays the log inside the HapticLoop, which pushes ToolSamples into the
// lock-free queue; the simulation drains it once per visual frame. Both run on a virtual clock in
// one thread, rate/visual_rate haptic cycles then one frame, so a replay is deterministic and runs
// as fast as the machine allows.
#pragma once

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "sim/scenario.hpp"

namespace scalpel {

class Simulation;

struct ReplayOptions {
  std::filesystem::path
      out_dir;  // report.json, run.json, frames.csv and mesh.vtu go here (created if missing)
  // Called after every frame with the fraction done, for a progress bar.
  std::function<void(double)> progress;
  // Called after every frame with the simulation as it stands, the frame's number (from 1) and
  // whether it is the last, for pictures. It must not change the simulation.
  std::function<void(const Simulation&, std::size_t, bool)> on_frame;
  // A ParaView time series of the mesh: every this many frames and at the last, the mesh as
  // out_dir/series/mesh_<frame>.vtu, listed with its time in out_dir/mesh.pvd; 0: none.
  std::size_t mesh_every = 0;
  // The final mesh also as out_dir/mesh.msh (Gmsh 2.2) and its boundary surface as surface.stl,
  // surface.obj and surface.ply (sculpting, paper section 7.3).
  bool exports = false;
};

struct ReplayResult {
  // Written as out_dir/report.json: what the session did, identical from run to run and build to
  // build (docs/formats.md), with `warnings` on the session's input and physics.
  nlohmann::ordered_json report;
  // Written as out_dir/run.json: what depends on the machine and the build (wall-clock timings, the
  // build's checks, the frame-rate warning).
  nlohmann::ordered_json run;
  bool invariants_ok = false;
  // What made the run fail although it ran to the end: tissue steps that met NaN or infinity (the
  // tissue then stood still where it was last good). Empty when none did.
  std::string failure;
};

// What makes a scenario's figures doubtful before it runs (docs/formats.md, `warnings`): a mesh
// whose size is implausible beside the blade (millimetres read as metres), a task path outside the
// mesh. Replay and `scalpelsim validate` report them.
struct InputWarning {
  std::string code;
  std::string message;
};
[[nodiscard]] std::vector<InputWarning> scenario_warnings(const Scenario& scenario, const TetMesh& mesh);

// Throws InputError for a bad scenario or log.
[[nodiscard]] ReplayResult replay(const Scenario& scenario, const std::filesystem::path& log_path,
                                  const ReplayOptions& options);

}  // namespace scalpel
