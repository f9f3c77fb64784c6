#include "sim/simulation.hpp"

#include <chrono>

namespace scalpel {

ScenarioMesh load_scenario_mesh(const Scenario& scenario) {
  ScenarioMesh out;
  if (scenario.mesh.kind != MeshKind::File) {
    out.mesh = build_generated_mesh(scenario);
    out.regions = generated_region_ids(scenario);
    return out;
  }
  MeshFileInfo info;
  out.mesh = read_mesh(scenario.mesh.file.string(), &info);
  for (const MeshRegion& r : info.regions) {
    if (!r.name.empty()) out.regions[r.name] = r.id;
    out.regions["region_" + std::to_string(r.id)] = r.id;
  }
  return out;
}

Simulation::Simulation(const Scenario& scenario) : scenario_(scenario) {
  ScenarioMesh m = load_scenario_mesh(scenario_);
  mesh_ = std::move(m.mesh);
  regions_ = std::move(m.regions);
  initial_volume_ = mesh_.total_rest_volume();
  cutter_ = std::make_unique<CutEngine>(mesh_);
}

Simulation::~Simulation() = default;

BladePose Simulation::blade(const ToolSample& s) const {
  const DeviceMapping& map = scenario_.device.mapping;
  const Vec3 position = map.rotation * (map.scale * s.position) + map.offset;
  const Eigen::Quaterniond orientation = map.rotation * s.orientation;
  return {position + orientation * scenario_.tool.blade_back,
          position + orientation * scenario_.tool.blade_tip, Vec3::Zero()};
}

void Simulation::on_sample(const ToolSample& s) {
  const auto start = std::chrono::steady_clock::now();
  const CutStepStats stats = cutter_->step(blade(s));
  cut_seconds_.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  edges_cut_in_frame_ += stats.edges_cut;
  last_ = s;
  ++samples_;
}

void Simulation::end_frame(double t, ForceChannel& forces) {
  cutter_->refit();
  // The force model the haptic loop renders until the next frame. The tissue does not constrain the
  // tool yet, so the coupling holds it where it is; while edges are being cut the blade meets a
  // resistance of the order measured for scalpels in skin (about 1 N).
  constexpr double kCuttingResistance = 1.0;  // [N]
  ForceModel model;
  model.sequence = ++force_sequence_;
  model.t = t;
  model.constrained_position = last_.position;
  model.cutting_resistance = edges_cut_in_frame_ > 0 ? kCuttingResistance : 0.0;
  forces.publish(model);
  edges_cut_in_frame_ = 0;
}

}  // namespace scalpel
