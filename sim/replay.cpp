#include "sim/replay.hpp"

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>

#include "base/input_error.hpp"
#include "devices/mock_device.hpp"
#include "devices/pose_log.hpp"
#include "haptics/haptic_loop.hpp"
#include "haptics/tool_queue.hpp"
#include "mesh/io/mesh_io.hpp"
#include "mesh/quality.hpp"
#include "mesh/topology.hpp"
#include "mesh/validate.hpp"
#include "sim/piece_events.hpp"
#include "sim/quantile.hpp"
#include "sim/simulation.hpp"
#include "sim/task_score.hpp"
#include "sim/version.hpp"

namespace scalpel {

namespace {

using json = nlohmann::ordered_json;

// The wound's gape is measured at surface cut nodes within this many task tolerances of the path,
// and its middle over this window [m] around the path's midpoint.
constexpr double kWoundBand = 3.0;
constexpr double kWoundWindow = 4e-3;
// A node displaced by more than this fraction of the mesh's diagonal is a warning: skin gapes and is
// dragged by millimetres, not by a fifth of the patch.
constexpr double kDisplacementLimit = 0.2;
// [s] The longest time between two samples of an interpolated log (docs/formats.md).
constexpr double kMaxSampleGap = 10.0;

json percentiles(const std::vector<double>& v, double scale) {
  json j;
  if (v.empty()) return j;
  j["p50"] = quantile(v, 0.50) * scale;
  j["p95"] = quantile(v, 0.95) * scale;
  j["p99"] = quantile(v, 0.99) * scale;
  j["max"] = quantile(v, 1.0) * scale;
  return j;
}

// The blade's presses on the surface (sim/indentation.hpp, docs/formats.md).
json indentation_json(const Indentation& press, const Simulation& sim) {
  json punctures = json::array();
  for (const PunctureEvent& e : press.punctures())
    punctures.push_back({{"t", e.t},
                         {"touched", e.touched},
                         {"depth", e.depth},
                         {"force", e.force},
                         {"threshold", e.threshold},
                         {"sharp_load", e.sharp},
                         {"region", e.region},
                         {"point", {e.point.x(), e.point.y(), e.point.z()}}});
  json error = percentiles(sim.press_model_errors(), 1.0);
  error["frames"] = sim.press_model_errors().size();
  return {{"presses", press.presses()},
          {"punctures", punctures},
          {"lifted_off", press.lifted()},
          {"entries_without_press", press.unpressed_entries()},
          {"max_normal_force", press.max_normal_force()},
          {"local_model_error", error}};
}

// The blade's flats and the handle on the tissue (sim/tool_body.hpp, docs/formats.md).
json body_json(const BodyContact& body, const Simulation& sim) {
  json error = percentiles(sim.body_model_errors(), 1.0);
  error["frames"] = sim.body_model_errors().size();
  return {{"blade_width", sim.body_size().blade_width},
          {"handle", sim.body_size().handle_radius > 0.0 ? json{{"radius", sim.body_size().handle_radius},
                                                                {"length", sim.body_size().handle_length}}
                                                         : json(nullptr)},
          {"frames", body.stats().frames_in_contact},
          {"pushes", body.stats().pushes},
          {"max_held_nodes", body.stats().max_held},
          {"max_force", body.stats().max_force},
          {"local_model_error", error}};
}

json mesh_json(const MeshSummary& s) {
  return {
      {"nodes", s.nodes},
      {"tetrahedra", s.tets},
      {"boundary_faces", s.boundary_faces},
      {"components", s.components},
      {"regions", s.regions},
      {"rest_volume", s.rest_volume},
      {"quality",
       {{"min", s.quality_min}, {"mean", s.quality_mean}, {"max", s.quality_max}, {"slivers", s.slivers}}}};
}

// The task's score as report JSON (docs/scoring.md, docs/formats.md).
json task_json(const TaskScore& t) {
  json j;
  j["score"] = t.score;
  j["passed"] = t.passed;
  j["pass_score"] = t.pass_score;
  json components = json::array();
  for (const ScoreComponent& c : t.components) {
    json jc;
    jc["name"] = c.name;
    jc["value"] = c.value;
    jc["unit"] = c.unit;
    jc["threshold"] = c.threshold ? json(*c.threshold) : json(nullptr);
    jc["pass_when"] = c.threshold ? (c.at_most ? "value <= threshold" : "value >= threshold") : "always";
    jc["passed"] = c.passed;
    jc["points"] = c.points;
    jc["points_max"] = c.points_max;
    jc["why"] = c.why;
    components.push_back(jc);
  }
  j["components"] = components;
  json incisions = json::array();
  for (const IncisionScore& s : t.incisions) {
    json path = json::array();
    for (const Vec3& p : s.path) path.push_back({p.x(), p.y(), p.z()});
    incisions.push_back({{"path", path},
                         {"path_length", s.path_length},
                         {"tolerance", s.tolerance},
                         {"coverage", s.coverage},
                         {"cut_points", s.cut_points},
                         {"cut_points_outside_tolerance", s.cut_points_outside},
                         {"lateral_deviation",
                          {{"mean", s.deviation_mean}, {"max", s.deviation_max}, {"frechet", s.frechet}}},
                         {"depth",
                          {{"max", s.depth_max},
                           {"mean", s.depth_mean},
                           {"in_band", s.depth_in_band},
                           {"min_accepted", s.depth_min},
                           {"max_accepted", s.depth_max_accepted}}},
                         {"bevel_deg", {{"mean", s.bevel_mean_deg}, {"max", s.bevel_max_deg}}},
                         {"strokes", s.strokes},
                         {"hesitations", s.hesitations}});
  }
  j["incisions"] = incisions;
  j["targets_length"] = t.targets_length;
  j["time_in_tissue"] = t.time_in_tissue;
  j["path_in_tissue"] = t.path_in_tissue;
  j["hand_force_while_cutting"] = {{"max", t.force_max}, {"mean", t.force_mean}};
  j["cut_area"] = t.cut_area;
  j["collateral_area"] = t.collateral_area;
  j["protected_area"] = t.protected_area;
  return j;
}

void write_mesh_vtu(const Simulation& sim, const std::filesystem::path& path) {
  const TetMesh& m = sim.mesh();
  const auto comps = connected_components(m);
  VtuData data;
  VtuIntCellArray component{"component", std::vector<std::int64_t>(m.tet_capacity(), -1)};
  VtuIntCellArray parent{"parent", std::vector<std::int64_t>(m.tet_capacity(), -1)};
  VtuIntCellArray state{"cut_state", std::vector<std::int64_t>(m.tet_capacity(), 0)};
  for (const TetId t : m.tets()) {
    component.values[t.index] = comps.of_tet[t.index];
    parent.values[t.index] = m.parent(t);
    state.values[t.index] = sim.cutter().state_code_of(sim.cutter().coarse_of(t));
  }
  data.cell_ints = {std::move(component), std::move(parent), std::move(state)};
  VtuVectorPointArray rest{"rest_position", m.rest_positions()};
  VtuVectorPointArray displacement{"displacement", std::vector<Vec3>(m.node_capacity(), Vec3::Zero())};
  for (const NodeId n : m.nodes()) displacement.values[n.index] = m.position(n) - m.rest(n);
  data.point_vectors = {std::move(rest), std::move(displacement)};
  write_vtu(m, path.string(), data);
}

// The lateral gape of the wound at the tissue surface (sim/wound.hpp), across the task's first
// incision.
json wound_json(const Simulation& sim, const Scenario& scenario) {
  std::vector<Vec3> path;
  double band = 0;
  if (scenario.task) {
    path = scenario.task->incisions.front().path;
    band = kWoundBand * scenario.task->incisions.front().tolerance;
  }
  const WoundGape g = sim.wound_gape(path, band, kWoundWindow);
  json profile = json::array();
  for (const WoundGape::Point& p : g.profile) profile.push_back({p.s, p.gape});
  return {{"mean", g.mean},       {"max", g.max},
          {"middle", g.middle},   {"surface_cut_nodes", g.surface_nodes},
          {"bridges", g.bridges}, {"profile", profile}};
}

// Pieces cuts severed from every fixed node, held where they lay (sim/simulation.hpp).
json severed_json(const Simulation& sim) {
  json pieces = json::array();
  for (const Simulation::SeveredPiece& p : sim.severed_pieces())
    pieces.push_back(
        {{"time", p.time}, {"rest_volume", p.rest_volume}, {"tetrahedra", p.tets}, {"region", p.region}});
  return pieces;
}

}  // namespace

std::vector<InputWarning> scenario_warnings(const Scenario& scenario, const TetMesh& mesh) {
  std::vector<InputWarning> out;
  const MeshSummary initial = summarize(mesh);
  const double diagonal = (initial.box_max - initial.box_min).norm();
  // Units: a mesh written in millimetres is a thousand times the blade.
  const double blade = (scenario.tool.blade_back - scenario.tool.blade_tip).norm();
  if (diagonal > 100 * blade || diagonal < 0.1 * blade) {
    std::ostringstream m;
    m << "the mesh is " << diagonal << " m across, " << diagonal / blade << " times the blade's length ("
      << blade << " m); " << (diagonal > blade ? "is it in millimetres?" : "is the blade in millimetres?")
      << " (SI units throughout, docs/formats.md)";
    out.push_back({"mesh_scale", m.str()});
  }
  if (scenario.task)
    for (const Incision& in : scenario.task->incisions)
      for (const Vec3& p : in.path)
        if ((p.head<2>().array() < initial.box_min.head<2>().array() - 1e-9 * diagonal).any() ||
            (p.head<2>().array() > initial.box_max.head<2>().array() + 1e-9 * diagonal).any()) {
          std::ostringstream m;
          m << "the task's path point [" << p.x() << ", " << p.y() << ", " << p.z()
            << "] lies outside the mesh's extent in x and y";
          out.push_back({"task_outside_mesh", m.str()});
        }
  return out;
}

ReplayResult replay(const Scenario& scenario, const std::filesystem::path& log_path,
                    const ReplayOptions& options) {
  const auto wall_start = std::chrono::steady_clock::now();
  ReplayResult result;
  // A live session's recording is played sample by sample, in the frames that took them
  // (docs/formats.md).
  std::vector<ToolSample> log;
  std::vector<std::uint64_t> sample_frames;
  std::uint64_t frame_count = 0;
  bool verbatim = false;
  std::vector<PieceEvent> piece_events;  // the trainee's moves of pieces, in frame order
  json warnings = json::array();         // on the session's input and physics (docs/formats.md)
  const auto warn = [&warnings](const std::string& code, const std::string& message) {
    warnings.push_back({{"code", code}, {"message", message}});
  };
  {
    PoseLogReader reader(log_path.string());
    if (const auto recorded_on = reader.metadata("scenario"); recorded_on && *recorded_on != scenario.name)
      warn("log_scenario", log_path.filename().string() + " was recorded on scenario '" + *recorded_on +
                               "', replayed on '" + scenario.name + "'");
    const std::optional<std::string> playback = reader.metadata("playback");
    if (playback && *playback != "verbatim" && *playback != "interpolate")
      throw InputError(log_path.string(), 0, 0, "playback",
                       "'" + *playback + "' is not a playback: verbatim or interpolate");
    verbatim = playback && *playback == "verbatim";
    if (verbatim && !reader.has_frame())
      throw InputError(log_path.string(), 0, 0, "playback", "verbatim playback needs the frame column");
    for (ToolSample s; reader.next(s);) {
      // Interpolated playback steps the tissue through every frame between two samples: a gap is
      // a recording fault, not a pause (a live session's pause is in its verbatim frames).
      if (!verbatim && !log.empty() && s.t - log.back().t > kMaxSampleGap)
        throw InputError(log_path.string(), reader.line(), 0, "t",
                         "the log jumps " + std::to_string(s.t - log.back().t) +
                             " s after the sample before; interpolated playback allows at most " +
                             std::to_string(static_cast<int>(kMaxSampleGap)) + " s between samples");
      log.push_back(s);
      if (verbatim) sample_frames.push_back(reader.frame());
    }
    if (reader.torn_line() != 0) warn("log_torn", reader.torn_warning());
    for (std::size_t i = 0; i < reader.metadata().size(); ++i) {
      if (reader.metadata()[i].first != kPieceEventKey) continue;
      const int line = reader.metadata_line(i);
      if (!verbatim)
        throw InputError(log_path.string(), line, 0, "piece", "piece events need verbatim playback");
      piece_events.push_back(parse_piece_event(reader.metadata()[i].second, log_path.string(), line));
      if (piece_events.size() > 1 && piece_events.back().frame < piece_events[piece_events.size() - 2].frame)
        throw InputError(log_path.string(), line, 0, "piece.frame", "piece events go back in frames");
    }
    if (log.empty()) throw InputError(log_path.string(), 0, 0, "", "the pose log holds no samples");
    if (verbatim) {
      // The session's frames, also those after its last sample (the trailer a finished session
      // writes); a killed one's end with the frame of its last sample.
      frame_count = sample_frames.empty() ? 0 : sample_frames.back();
      if (const auto trailer = reader.metadata("frames")) {
        std::uint64_t n = 0;
        const auto [end, ec] = std::from_chars(trailer->data(), trailer->data() + trailer->size(), n);
        if (ec != std::errc() || end != trailer->data() + trailer->size() || n < frame_count)
          throw InputError(log_path.string(), 0, 0, "frames",
                           "'" + *trailer + "' is not the number of frames of the session");
        frame_count = n;
      }
      // A killed session's last moves of pieces may come after its last sample.
      if (!piece_events.empty()) frame_count = std::max(frame_count, piece_events.back().frame);
    }
  }
  Simulation sim(scenario);
  const MeshSummary initial = summarize(sim.mesh());
  const double diagonal = (initial.box_max - initial.box_min).norm();
  for (const InputWarning& w : scenario_warnings(scenario, sim.mesh())) warn(w.code, w.message);
  // Tissue carried far from where it started: the largest displacement and the frame it was first
  // beyond kDisplacementLimit of the mesh's diagonal.
  double displacement_max = 0.0;
  std::vector<std::pair<double, std::string>> series_files;  // the mesh time series: time, file
  std::size_t displaced_frame = 0;
  // The time series beside the report (docs/formats.md, frames.csv): one row per frame, the tool
  // at the frame's last sample.
  // Outputs a run with other options left in a reused folder would be taken for this run's.
  for (const char* stale : {"mesh.pvd", "series", "top.png", "oblique.png", "section.png", "frames"})
    std::filesystem::remove_all(options.out_dir / stale);
  std::filesystem::create_directories(options.out_dir);
  std::ofstream series(options.out_dir / "frames.csv");
  series << "frame,t,tip_x,tip_y,tip_z,in_tissue,depth,material_depth,bevel_deg,incision,path_s,deviation,"
            "speed,hand_force,"
            "cutting,edges_cut\n";
  series.precision(9);
  std::size_t edges_before = 0;

  // The spine: mock device -> haptic loop -> queue -> simulation, on the virtual clock.
  MockDevice device(log, verbatim ? MockDevice::Playback::Verbatim : MockDevice::Playback::Interpolate);
  ToolQueue queue(static_cast<std::size_t>(scenario.device.queue_capacity));
  ForceChannel forces;
  HapticLoopConfig config;
  config.rate = scenario.device.rate;
  config.realtime_priority = false;
  HapticLoop loop(device, queue, forces, config);

  const double duration = log.back().t - log.front().t;
  const double visual_rate = scenario.simulation.visual_rate;
  // Verbatim: the frames the session ran (frame_count, above).
  auto frames = verbatim ? static_cast<std::size_t>(frame_count)
                         : static_cast<std::size_t>(std::ceil(duration * visual_rate)) + 1;
  // simulation.duration: the session stops there, whatever the log holds after it.
  if (scenario.simulation.duration)
    frames =
        std::min(frames, static_cast<std::size_t>(std::ceil(*scenario.simulation.duration * visual_rate)));
  if (!piece_events.empty() && piece_events.back().frame > frames)
    warn("piece_events_after_end", "the log's moves of pieces after frame " + std::to_string(frames) +
                                       " (simulation.duration) are not applied");
  std::size_t cycles = 0;
  std::vector<double> frame_seconds;
  ToolSample sample;
  std::size_t taken = 0;  // verbatim: samples taken by the simulation
  std::size_t next_event = 0;
  for (std::size_t k = 1; k <= frames; ++k) {
    const auto frame_start = std::chrono::steady_clock::now();
    const double end = static_cast<double>(k) / visual_rate;
    if (verbatim) {
      // The samples frame k of the live session took (sim/session.hpp), one haptic cycle each.
      while (taken < log.size() && sample_frames[taken] <= k) {
        if (!queue.pop(sample)) {
          cycles += loop.run_cycles(1);
          continue;
        }
        sim.on_sample(sample);
        ++taken;
      }
      // The moves of pieces the session applied at the end of this frame.
      for (; next_event < piece_events.size() && piece_events[next_event].frame <= k; ++next_event)
        sim.queue_move(piece_events[next_event].move);
    } else {
      // Haptic cycles up to the end of frame k: t < k / visual_rate.
      const auto target =
          static_cast<std::size_t>(std::ceil(static_cast<double>(k) * config.rate / visual_rate));
      while (cycles < target) {
        cycles += loop.run_cycles(target - cycles);
        while (queue.pop(sample)) sim.on_sample(sample);  // a full queue only pauses the producer
      }
    }
    sim.end_frame(end, forces);
    {
      const ToolTracePoint& p = sim.scorer().last();
      const std::size_t edges = sim.cutter().totals().edges_cut;
      series << k << ',' << end << ',' << p.tip.x() << ',' << p.tip.y() << ',' << p.tip.z() << ','
             << (p.in_tissue ? 1 : 0) << ',' << p.depth << ',';
      if (p.has_material_depth) series << p.material_depth;
      series << ',' << p.bevel_deg << ',' << p.incision << ',' << p.path_s << ',' << p.deviation << ','
             << p.speed << ',' << p.force << ',' << (p.cutting ? 1 : 0) << ',' << edges - edges_before
             << '\n';
      edges_before = edges;
    }
    frame_seconds.push_back(
        std::chrono::duration<double>(std::chrono::steady_clock::now() - frame_start).count());
    {
      const TetMesh& m = sim.mesh();
      double d = 0.0;
      for (const NodeId n : m.nodes()) d = std::max(d, (m.position(n) - m.rest(n)).norm());
      displacement_max = std::max(displacement_max, d);
      if (displaced_frame == 0 && d > kDisplacementLimit * diagonal) displaced_frame = k;
    }
    if (options.mesh_every > 0 && (k % options.mesh_every == 0 || k == frames)) {
      char name[32];
      std::snprintf(name, sizeof name, "series/mesh_%06zu.vtu", k);
      std::filesystem::create_directories(options.out_dir / "series");
      write_mesh_vtu(sim, options.out_dir / name);
      series_files.emplace_back(end, name);
    }
    if (options.on_frame) options.on_frame(sim, k, k == frames);
    if (options.progress) options.progress(static_cast<double>(k) / static_cast<double>(frames));
  }

  const ValidationReport check =
      validate(sim.mesh(), {.reference_volume = sim.initial_volume() - sim.deleted_volume()});
  const CutEngine& cutter = sim.cutter();
  const CutTotals& totals = cutter.totals();
  const HapticStats hs = loop.stats();

  // Rigid tissue moves only as the scenario's moves take its pieces, on purpose.
  if (displaced_frame > 0 && !scenario.tissue.rigid) {
    std::ostringstream m;
    m << "tissue moved up to " << displacement_max << " m from where it started, beyond "
      << 100 * kDisplacementLimit << " % of the mesh's diagonal (" << diagonal << " m) from frame "
      << displaced_frame << ": dragged or flung, not cut";
    warn("tissue_displaced", m.str());
  }
  if (sim.scorer().time_in_tissue() == 0.0 && cutter.totals().edges_cut == 0)
    warn("blade_never_met_tissue", "the blade never went under the tissue surface and cut nothing");

  json report;
  report["format"] = "scalpelsim-report 1";
  report["version"] = version();
  report["inputs"] = {{"scenario", scenario.file.string()},
                      {"scenario_name", scenario.name},
                      {"log", log_path.string()},
                      {"log_samples", log.size()},
                      {"log_duration", duration}};
  report["replay"] = {{"haptic_rate", config.rate},
                      {"visual_rate", visual_rate},
                      {"frames", frames},
                      {"haptic_cycles", hs.cycles},
                      {"samples", sim.samples()},
                      {"merged_samples", hs.merged_samples},
                      {"device_not_ok_cycles", hs.device_not_ok}};
  report["mesh"] = {{"initial", mesh_json(initial)}, {"final", mesh_json(summarize(sim.mesh()))}};

  json transitions = json::object();
  for (const auto& [name, count] : cutter.transitions_by_label()) transitions[name] = count;
  const auto sizes = cutter.subdivision_sizes();
  json histogram = json::object();
  std::map<std::size_t, std::size_t> by_size;
  double mean_size = 0;
  for (const auto s : sizes) {
    ++by_size[s];
    mean_size += static_cast<double>(s) / static_cast<double>(sizes.size());
  }
  for (const auto& [s, n] : by_size) histogram[std::to_string(s)] = n;
  report["cutting"] = {{"edges_cut", totals.edges_cut},
                       {"backward_crossings", totals.backward_crossings},
                       {"replaced_crossings", totals.replaced_crossings},
                       {"recrossed_edges", totals.recrossed_edges},
                       {"recrossed_faces", totals.recrossed_faces},
                       {"face_pierces", totals.face_pierces},
                       {"undone_face_subdivisions", totals.undone_faces},
                       {"recursive_continuations", totals.recursions},
                       {"recursive_continuations_within_stroke", totals.stroke_recursions},
                       {"sealed_crossings", totals.sealed_events},
                       {"final_pierces", totals.final_pierces},
                       {"tetrahedra_promoted", totals.promoted_tets},
                       {"max_recursion_depth", totals.max_recursion_depth},
                       {"recursion_fallbacks", totals.recursion_fallbacks},
                       {"tetrahedra_created", totals.tets_created},
                       {"tetrahedra_removed", totals.tets_removed},
                       {"nodes_created", totals.nodes_created},
                       {"coarse_tetrahedra_cut", totals.coarse_tets_cut},
                       {"tetrahedra_per_cut_tetrahedron", {{"mean", mean_size}, {"histogram", histogram}}},
                       {"transitions", transitions},
                       {"cut_surface_area", cutter.cut_surface_area()}};
  json violations = json::array();
  for (const auto& v : check.violations) violations.push_back(v.what);
  report["invariants"] = {{"oriented", check.passed[1]},
                          {"conforming", check.passed[2]},
                          {"watertight", check.passed[3]},
                          {"volume", check.passed[4]},
                          {"violations", violations}};
  {
    const auto& steps = sim.tissue_steps();
    std::size_t converged = 0, capped = 0, non_finite = 0;
    double iterations = 0, max_residual = 0;
    int max_iterations = 0;
    std::size_t max_limited = 0, local_steps = 0, max_local_nodes = 0;
    double local_iterations = 0;
    for (const StepStats& st : steps) {
      max_limited = std::max(max_limited, st.strain_limited);
      if (st.local_nodes > 0) {
        ++local_steps;
        local_iterations += st.local_iterations;
        max_local_nodes = std::max(max_local_nodes, st.local_nodes);
      }
      converged += st.status == StepStatus::Converged ? 1 : 0;
      capped += st.status == StepStatus::IterationCap ? 1 : 0;
      non_finite += st.status == StepStatus::NonFinite ? 1 : 0;
      iterations += st.cg_iterations;
      max_iterations = std::max(max_iterations, st.cg_iterations);
      max_residual = std::max(max_residual, st.residual);
    }
    const double n = std::max<double>(1.0, static_cast<double>(steps.size()));
    for (const StepStats& st : steps)
      if (st.status == StepStatus::NonFinite) {
        result.failure = "the tissue solve failed in " + std::to_string(non_finite) + " of " +
                         std::to_string(steps.size()) + " steps (the first: " + st.message + ")";
        break;
      }
    report["tissue"] = {
        {"model", scenario.tissue.rigid ? "rigid" : to_string(scenario.tissue.model)},
        {"rate", scenario.tissue.rate},
        {"steps", steps.size()},
        {"converged", converged},
        {"iteration_cap", capped},
        {"non_finite", non_finite},
        {"cg_iterations", {{"mean", iterations / n}, {"max", max_iterations}}},
        {"local_solves",
         {{"steps", local_steps},
          {"iterations_mean", local_iterations / std::max<double>(1.0, static_cast<double>(local_steps))},
          {"nodes_max", max_local_nodes}}},
        {"relative_residual", {{"max", max_residual}, {"last", steps.empty() ? 0.0 : steps.back().residual}}},
        {"energy",
         {{"elastic", steps.empty() ? 0.0 : steps.back().elastic_energy},
          {"kinetic", steps.empty() ? 0.0 : steps.back().kinetic_energy}}},
        {"strain_limited_elements",
         {{"max", max_limited}, {"last", steps.empty() ? std::size_t{0} : steps.back().strain_limited}}},
        {"wound_opening", wound_json(sim, scenario)},
        {"severed_pieces", severed_json(sim)}};
  }
  {
    std::size_t frames_in_contact = 0;
    double force_max = 0, force_sum = 0;
    for (const double f : sim.contact_forces()) {
      if (f > 0.0) ++frames_in_contact;
      force_max = std::max(force_max, f);
      force_sum += f;
    }
    report["tool_contact"] = {
        {"cutting_resistance", scenario.tool.cutting_resistance},
        {"frames", frames_in_contact},
        {"force_on_tissue",
         {{"max", force_max},
          {"mean_in_contact", force_sum / std::max<double>(1.0, static_cast<double>(frames_in_contact))}}}};
    if (const Indentation* press = sim.indentation())
      report["tool_contact"]["indentation"] = indentation_json(*press, sim);
    if (const BodyContact* body = sim.body_contact()) report["tool_contact"]["body"] = body_json(*body, sim);
  }
  if (const auto score = sim.task_score()) report["task"] = task_json(*score);
  if (!sim.moves().empty()) {
    nlohmann::ordered_json moves = nlohmann::ordered_json::array();
    for (const Simulation::MoveRecord& m : sim.moves())
      moves.push_back({{"time", m.time},
                       {"kind", m.action == PieceAction::Undo     ? "undo"
                                : m.action == PieceAction::Delete ? "delete"
                                                                  : "move"},
                       {"done", m.refused.empty()},
                       {"refused", m.refused},
                       {"tetrahedra", m.tets},
                       {"rest_volume_mm3", m.rest_volume * 1e9}});
    report["piece_moves"] = moves;
    for (std::size_t i = 0; i < sim.moves().size(); ++i)
      if (!sim.moves()[i].refused.empty())
        warn("piece_move_refused", "piece_moves[" + std::to_string(i) + "] at " +
                                       std::to_string(sim.moves()[i].time) +
                                       " s did nothing: " + sim.moves()[i].refused);
  }
  report["warnings"] = warnings;
  // Tissue steps right after a cut (the mesh changed since the step before) and the others.
  std::vector<double> after_cut, without_cut;
  for (std::size_t k = 0; k < sim.tissue_step_seconds().size(); ++k)
    (sim.tissue_step_after_cut()[k] ? after_cut : without_cut).push_back(sim.tissue_step_seconds()[k]);
  // Where a tissue step's time goes (StepStats::seconds).
  json stages;
  for (const auto& [name, field] :
       {std::pair{"elements", &StepStats::Seconds::elements},
        std::pair{"assembly", &StepStats::Seconds::assembly}, std::pair{"local", &StepStats::Seconds::local},
        std::pair{"solve", &StepStats::Seconds::solve}}) {
    std::vector<double> seconds;
    for (const StepStats& st : sim.tissue_steps()) seconds.push_back(st.seconds.*field);
    stages[name] = percentiles(seconds, 1e3);
  }
  json run;
  // The program's version and build belong here, not in report.json: a report is the same from
  // build to build, so CI can compare it with a stored hash.
#ifdef SCALPEL_VALIDATE
  constexpr bool kInvariantsChecked = true;
#else
  constexpr bool kInvariantsChecked = false;
#endif
  run["build"] = {{"version", version()},
                  {"build", build_description()},
                  {"invariants_checked_after_every_step", kInvariantsChecked}};
  run["timings"] = {
      {"cut_step_us", percentiles(sim.cut_step_seconds(), 1e6)},
      {"tissue_step_ms", percentiles(sim.tissue_step_seconds(), 1e3)},
      {"tissue_step_after_cut_ms", percentiles(after_cut, 1e3)},
      {"tissue_step_without_cut_ms", percentiles(without_cut, 1e3)},
      {"tissue_stage_ms", stages},
      {"frame_ms", percentiles(frame_seconds, 1e3)},
      {"total_s", std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count()}};

  std::filesystem::create_directories(options.out_dir);
  // The frame rate depends on the machine: a warning of the run, not of the session.
  json run_warnings = json::array();
  if (!frame_seconds.empty() && quantile(frame_seconds, 0.95) > 1.0 / visual_rate) {
    std::ostringstream m;
    m << "frames took " << 1e3 * quantile(frame_seconds, 0.95) << " ms at the 95th percentile: this machine "
      << "cannot hold the scenario's visual rate of " << visual_rate << " Hz live";
    run_warnings.push_back({{"code", "frame_rate"}, {"message", m.str()}});
  }
  run["warnings"] = run_warnings;
  for (const auto& [name, body] : {std::pair{"report.json", &report}, std::pair{"run.json", &run}}) {
    std::ofstream out(options.out_dir / name);
    out << body->dump(2) << '\n';
    if (!out) throw std::runtime_error("cannot write " + (options.out_dir / name).string());
  }
  series.flush();
  if (!series) throw std::runtime_error("cannot write " + (options.out_dir / "frames.csv").string());
  write_mesh_vtu(sim, options.out_dir / "mesh.vtu");
  if (options.exports) {
    std::map<int, std::string> names;
    // A region's own name over its region_<id> form.
    for (const auto& [name, id] : sim.regions())
      if (!names.contains(id) || names[id].starts_with("region_")) names[id] = name;
    write_msh(sim.mesh(), (options.out_dir / "mesh.msh").string(), names);
    write_boundary_stl(sim.mesh(), (options.out_dir / "surface.stl").string());
    write_boundary_obj(sim.mesh(), (options.out_dir / "surface.obj").string());
    write_boundary_ply(sim.mesh(), (options.out_dir / "surface.ply").string());
  }
  if (!series_files.empty()) {
    std::ofstream pvd(options.out_dir / "mesh.pvd");
    pvd.precision(9);
    pvd << "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\">\n  <Collection>\n";
    for (const auto& [t, file] : series_files)
      pvd << "    <DataSet timestep=\"" << t << "\" part=\"0\" file=\"" << file << "\"/>\n";
    pvd << "  </Collection>\n</VTKFile>\n";
    if (!pvd) throw std::runtime_error("cannot write " + (options.out_dir / "mesh.pvd").string());
  }
  result.report = std::move(report);
  result.run = std::move(run);
  result.invariants_ok = check.ok();
  return result;
}

}  // namespace scalpel
