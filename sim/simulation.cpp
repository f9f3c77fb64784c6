#include "sim/simulation.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

#include "base/input_error.hpp"
#include "mesh/manifold.hpp"
#include "mesh/overlap.hpp"
#include "mesh/topology.hpp"
#include "mesh/volume.hpp"

namespace scalpel {

namespace {

// The scenario's volume, placed by its `box` when it has one, sampled onto the mesh's nodes. A node
// farther outside the grid than one sample spacing is an error: the volume does not cover the mesh.
void attach_volume(const Scenario& scenario, TetMesh& mesh) {
  const VolumeSource& source = *scenario.volume;
  ScalarVolume volume = read_nrrd_volume(source.file);
  if (source.box) {
    volume.origin = (*source.box)[0];
    for (int a = 0; a < 3; ++a)
      volume.spacing[a] = ((*source.box)[1][a] - (*source.box)[0][a]) /
                          static_cast<double>(volume.size[static_cast<std::size_t>(a)] - 1);
  }
  const double slack = volume.spacing.maxCoeff();
  for (const NodeId n : mesh.nodes()) {
    const Vec3& x = mesh.rest(n);
    if (volume.distance_outside(x) > slack) {
      const Vec3 hi = volume.far_corner();
      std::ostringstream msg;
      msg << "the volume spans [" << volume.origin.x() << ", " << hi.x() << "] x [" << volume.origin.y()
          << ", " << hi.y() << "] x [" << volume.origin.z() << ", " << hi.z()
          << "] [m] and does not cover the mesh: node " << n.index << " at [" << x.x() << ", " << x.y()
          << ", " << x.z() << "] lies " << volume.distance_outside(x) << " m outside it";
      throw InputError(scenario.file.string(), source.where.line, source.where.column, "volume", msg.str());
    }
  }
  (void)sample_volume_onto(mesh, volume, source.field);
}

}  // namespace

ScenarioMesh load_scenario_mesh(const Scenario& scenario) {
  ScenarioMesh out = read_scenario_mesh(scenario);
  if (scenario.volume) attach_volume(scenario, out.mesh);
  return out;
}

ScenarioMesh read_scenario_mesh(const Scenario& scenario) {
  ScenarioMesh out;
  if (scenario.mesh.kind != MeshKind::File) {
    out.mesh = build_generated_mesh(scenario);
    out.regions = generated_region_ids(scenario);
    return out;
  }
  MeshFileInfo& info = out.file_info;
  out.mesh = read_mesh(scenario.mesh.file.string(), &info);
  const std::string file = scenario.mesh.file.string();
  if (static_cast<long long>(out.mesh.tet_count()) > kMaxTetrahedra)
    throw InputError(file, 0, 0, "",
                     std::to_string(out.mesh.tet_count()) + " tetrahedra, more than the " +
                         std::to_string(kMaxTetrahedra) +
                         " a scenario may hold (a replay needs about 2.2 kB each)");
  // A bow-tie, or tissue laid over tissue, is a mesh the cutter cannot cut consistently
  // (mesh/manifold.hpp, mesh/overlap.hpp): refused here.
  if (const ManifoldReport manifold = check_manifold(out.mesh); !manifold.ok())
    throw InputError(file, 0, 0, "", "not a manifold: " + manifold.summary(out.mesh));
  if (const OverlapReport overlaps = check_overlaps(out.mesh); !overlaps.ok())
    throw InputError(file, 0, 0, "", "tetrahedra overlap: " + overlaps.summary(out.mesh));
  for (const MeshRegion& r : info.regions) {
    if (!r.name.empty()) out.regions[r.name] = r.id;
    out.regions["region_" + std::to_string(r.id)] = r.id;
  }
  return out;
}

Simulation::Simulation(const Scenario& scenario) : scenario_(scenario) {
  ScenarioMesh m = load_scenario_mesh(scenario_);
  mesh_ = std::move(m.mesh);
  regions_ = m.regions;
  initial_volume_ = mesh_.total_rest_volume();
  wound_meter_ = std::make_unique<WoundMeter>(mesh_);
  snapshots_ = std::make_unique<SnapshotBuilder>(mesh_);
  if (const auto& volume = scenario_.volume) {
    const int id = mesh_.field_id(volume->field);
    const std::vector<double>& values = mesh_.field_values(id);
    FrameSnapshot::Field shown{volume->field, 0.0, 1.0, volume->colour_map};
    if (volume->range) {
      shown.lo = (*volume->range)[0];
      shown.hi = (*volume->range)[1];
    } else {
      // The range the mesh's nodes took; a cut only interpolates between them.
      shown.lo = std::numeric_limits<double>::infinity();
      shown.hi = -shown.lo;
      for (const NodeId n : mesh_.nodes()) {
        shown.lo = std::min(shown.lo, values[n.index]);
        shown.hi = std::max(shown.hi, values[n.index]);
      }
      if (!(shown.hi > shown.lo)) shown.hi = shown.lo + 1.0;
    }
    snapshots_->show_field(id, shown);
  }
  snapshots_->show_pieces(scenario_.tissue.rigid);  // rigid pieces can be moved in the window
  CutOptions cut_options;
  cut_options.max_recursion_depth = scenario_.simulation.cut_recursion_depth;
  cutter_ = std::make_unique<CutEngine>(mesh_, cut_options);
  surface_ = std::make_unique<SurfaceProbe>(mesh_);
  update_bounds();
  {
    std::set<int> protected_ids;
    const Task task = scenario_.task.value_or(Task{});
    for (const std::string& name : task.protected_regions) {
      const auto it = m.regions.find(name);
      if (it == m.regions.end()) {
        std::string names;
        for (const auto& [n, id] : m.regions) names += (names.empty() ? "" : ", ") + n;
        const SourceLocation& w = scenario_.task->protected_where;
        throw InputError(
            scenario_.file.string(), w.line, w.column, "task.protected",
            "no region '" + name + "' in the mesh; its regions: " + (names.empty() ? "none" : names));
      }
      protected_ids.insert(it->second);
    }
    scorer_ = std::make_unique<TaskScorer>(task, std::move(protected_ids));
  }

  // Tissue (docs/tissue.md): materials by region id, the scenario's solver, the fixed boundary.
  // Rigid tissue without materials: every region takes the default one, which it never uses.
  std::map<int, Material> by_region;
  if (scenario_.tissue.rigid && scenario_.materials.empty()) {
    for (const TetId t : mesh_.tets()) by_region[mesh_.region(t)] = Material{};
  } else {
    by_region = resolve_materials(scenario_, m.regions, mesh_);
  }
  std::vector<Material> materials(by_region.empty() ? 1 : static_cast<size_t>(by_region.rbegin()->first) + 1);
  for (const auto& [region, material] : by_region) materials[static_cast<size_t>(region)] = material;
  TissueSettings settings;
  settings.kind = scenario_.tissue.model;
  settings.tolerance = scenario_.tissue.cg_tolerance;
  settings.max_iterations = scenario_.tissue.cg_max_iterations;
  settings.local_rings = scenario_.tissue.local_rings;
  settings.threads = scenario_.tissue.threads;
  settings.gravity = scenario_.tissue.gravity;
  settings.volume_springs = scenario_.tissue.volume_springs;
  tissue_ = std::make_unique<TissueModel>(mesh_, std::move(materials), settings);
  for (const NodeId n : select_fixed_nodes(scenario_, mesh_)) {
    tissue_->set_fixed(n);
    anchored_ = true;
  }
  if (scenario_.tool.contact == ToolContactKind::Indent) {
    std::vector<double> puncture;
    for (const Material& material : tissue_->materials()) puncture.push_back(material.puncture_force);
    indentation_ = std::make_unique<Indentation>(std::move(puncture));
    if (body_size().any() && !scenario_.tissue.rigid) body_ = std::make_unique<BodyContact>(body_size());
  }
}

Simulation::~Simulation() = default;

void Simulation::update_bounds() {
  bounds_lo_ = Vec3::Constant(std::numeric_limits<double>::infinity());
  bounds_hi_ = -bounds_lo_;
  for (const NodeId n : mesh_.nodes()) {
    bounds_lo_ = bounds_lo_.cwiseMin(mesh_.position(n));
    bounds_hi_ = bounds_hi_.cwiseMax(mesh_.position(n));
  }
  surface_->fit(mesh_);
}

const SurfaceProbe& Simulation::surface() const {
#ifdef SCALPEL_VALIDATE
  if (surface_->stale(mesh_.positions()))
    throw std::logic_error(
        "Simulation: the surface moved since the probe's boxes were fitted (update_bounds)");
#endif
  return *surface_;
}

std::optional<TaskScore> Simulation::task_score() const {
  if (!scenario_.task || !scenario_.task->scored) return std::nullopt;
  return scorer_->score(*cutter_, mesh_);
}

BladePose Simulation::blade(const ToolSample& s) const {
  const DeviceMapping& map = scenario_.device.mapping;
  const Vec3 position = map.rotation * (map.scale * s.position) + map.offset;
  const Eigen::Quaterniond orientation = map.rotation * s.orientation;
  const Vec3 edge = scenario_.tool.blade_edge ? Vec3(orientation * *scenario_.tool.blade_edge) : Vec3::Zero();
  return {position + orientation * scenario_.tool.blade_back,
          position + orientation * scenario_.tool.blade_tip, edge};
}

bool Simulation::meets_bounds(const Vec3& lo, const Vec3& hi) const {
  return (hi - bounds_lo_).minCoeff() >= 0 && (bounds_hi_ - lo).minCoeff() >= 0;
}

std::optional<SurfaceHit> Simulation::entry(const BladePose& before, const BladePose& now) const {
  const Vec3 lo = now.tip.cwiseMin(now.back).cwiseMin(before.tip).cwiseMin(before.back);
  const Vec3 hi = now.tip.cwiseMax(now.back).cwiseMax(before.tip).cwiseMax(before.back);
  if (!meets_bounds(lo, hi)) return std::nullopt;
  const double length = (now.tip - now.back).norm();
  const int points = std::clamp(static_cast<int>(std::ceil(length / kTouchSpacing)), 1, 64);
  for (int k = 0; k <= points; ++k) {
    const double u = static_cast<double>(k) / points;  // from the tip
    const Vec3 from = before.tip + u * (before.back - before.tip), to = now.tip + u * (now.back - now.tip);
    if (const auto hit = surface().entry(mesh_.positions(), from, to)) return hit;
  }
  return std::nullopt;
}

bool Simulation::on_earlier_cut(const Vec3& point, const Vec3& normal) const {
  const std::vector<Vec3> cut = cutter_->cut_points();
  if (cut.empty()) return false;
  // Just under the surface: in an opened crack there is no tissue to locate.
  const auto at = cutter_->locate(point - kReentryDistance * 0.1 * normal);
  if (!at) return true;
  Vec3 rest = Vec3::Zero();
  for (int i = 0; i < 4; ++i) rest += at->weights[i] * mesh_.rest(at->corners[i]);
  for (const Vec3& c : cut)
    if ((c - rest).norm() < kReentryDistance) return true;
  return false;
}

std::optional<Vec3> Simulation::under_surface(const BladePose& pose) const {
  const Vec3 lo = pose.tip.cwiseMin(pose.back), hi = pose.tip.cwiseMax(pose.back);
  if (!meets_bounds(lo, hi)) return std::nullopt;
  return surface().deepest_in_tissue(mesh_.positions(), pose.tip, pose.back);
}

Simulation::BladeMove Simulation::press_or_cut(const BladePose& pose, double t) {
  Indentation& press = *indentation_;
  switch (press.phase()) {
    case Indentation::Phase::Free: {
      // A blade touches the surface where one of its points crosses it inwards in this sample: the
      // tip, or a point of the edge (a blade laid on the skin). The first such point, from the tip,
      // sets where the skin sticks to it.
      const BladePose before = blade(last_);
      if (samples_ > 0)
        if (const auto hit = entry(before, pose)) {
          // Into an incision already made, or a jump in one sample (a gap in the samples, or samples
          // the haptic loop merged while the simulation fell behind: one long sweep, which a press
          // cannot follow): it cuts on at once, as without contact.
          const bool jump = (pose.tip - before.tip).norm() > kJumpDistance;
          if (jump || on_earlier_cut(hit->point, hit->normal)) {
            press.enter_without_press();
            return BladeMove::Sweep;
          }
          press.touch(hit->face, pose.tip, hit->point, hit->normal, t, mesh_, *tissue_);
          return press.phase() == Indentation::Phase::Cutting ? BladeMove::Sweep : BladeMove::Hold;
        }
      // Out of the tissue the blade is only placed. One under the surface without having crossed it
      // (the skin sprang back over a blade lifted off in its dimple) is in the tissue: drawn out it
      // holds, and the skin it leaves is not caught again; moved any other way it cuts, as in an
      // incision already made. A blade in the tissue never passes through it.
      if (samples_ > 0)
        if (const auto deepest = under_surface(pose)) {
          const Vec3 up = surface().nearest(mesh_.positions(), *deepest, pose.back - pose.tip).normal;
          if ((pose.tip - before.tip).dot(up) > 0.0 || pose.tip == before.tip) return BladeMove::Hold;
          press.enter_without_press();
          return BladeMove::Sweep;
        }
      return BladeMove::Place;
    }
    case Indentation::Phase::Pressing:
      return BladeMove::Hold;
    case Indentation::Phase::Cutting:
      if (!under_surface(pose) && !cutter_->in_contact()) press.left();
      return BladeMove::Sweep;
  }
  return BladeMove::Sweep;
}

void Simulation::on_sample(const ToolSample& s) {
  const auto start = std::chrono::steady_clock::now();
  const BladePose pose = blade(s);
  // With contact, the blade presses the surface in before it cuts (sim/indentation.hpp): the cutter
  // sweeps it only when it cuts, from its last pose before the touch.
  const BladeMove move = indentation_ ? press_or_cut(pose, s.t) : BladeMove::Sweep;
  const bool cuts = move == BladeMove::Sweep;
  if (move == BladeMove::Place) cutter_->place(pose);
  const CutStepStats stats = cuts ? cutter_->step(pose) : CutStepStats{};
  cut_seconds_.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  hand_over_cut();
  if (cuts) {
    // Where the blade cuts deepest in the tissue (a probe of the surface only when the blade is near
    // it) and where that is in the tissue (rest coordinates), for the score: the tip, or where the
    // blade enters the tissue when the tip has gone through its whole thickness. Depth: its
    // distance to the nearest point of the surface facing the blade's back, now and (for its
    // material point) at rest.
    std::optional<SurfaceHit> hit;
    std::optional<Vec3> rest_tip;
    std::optional<double> material_depth;
    const Vec3 up = pose.back - pose.tip;
    const Vec3 lo = pose.tip.cwiseMin(pose.back), hi = pose.tip.cwiseMax(pose.back);
    // A tip outside the tissue's box is never under its surface, whatever the ray test says where
    // rounding lets the line slip between the triangles it enters through.
    if (meets_bounds(lo, hi))
      if (const auto deepest = surface().deepest_in_tissue(mesh_.positions(), pose.tip, pose.back);
          deepest && (*deepest != pose.tip || meets_bounds(pose.tip, pose.tip))) {
        hit = surface().nearest(mesh_.positions(), *deepest, up);
        if (const auto at = cutter_->locate(*deepest, kBladeHalfThickness)) {
          rest_tip = Vec3::Zero();
          for (int i = 0; i < 4; ++i) *rest_tip += at->weights[i] * mesh_.rest(at->corners[i]);
          material_depth = surface().nearest(mesh_.rest_positions(), *rest_tip, up).depth;
        }
      }
    scorer_->on_sample(s.t, pose, stats, hit, rest_tip, material_depth, hand_force(s));
  } else {
    // Pressing: the blade is on the tissue, not in it.
    scorer_->on_sample(s.t, pose, stats, std::nullopt, std::nullopt, std::nullopt, hand_force(s));
  }
  last_ = s;
  ++samples_;
}

// What the hand pushes against at this sample: the force the last frame's model gives where the
// tool is, moving as it moved since the last sample: what a device renders, before its own limits.
double Simulation::hand_force(const ToolSample& s) const {
  if (published_.sequence == 0 || samples_ == 0 || !(s.t > last_.t)) return 0.0;
  const Vec3 v = (s.position - last_.position) / (s.t - last_.t);
  return published_.environment_force(s.position, v).norm();
}

// Topology changes go to the tissue model. Elements around a mid node that slid with the blade
// changed their rest shape: they are handed over as removed and added again.
void Simulation::hand_over_cut() {
  const CutChanges& c = cutter_->changes();
  std::vector<std::uint32_t> removed = c.removed_tets;
  std::vector<TetId> added = c.added_tets;
  for (const NodeId n : c.moved_nodes)
    for (const std::uint32_t t : mesh_.node_tets(n))
      if (std::find(added.begin(), added.end(), mesh_.tet_handle(t)) == added.end()) {
        removed.push_back(t);
        added.push_back(mesh_.tet_handle(t));
      }
  if (!c.added_nodes.empty()) tissue_->on_nodes_added(c.added_nodes, c.added_node_parents);
  if (!removed.empty()) tissue_->on_tets_removed(removed);
  if (!added.empty()) tissue_->on_tets_added(added);
  topology_changed_ = topology_changed_ || !c.added_nodes.empty() || !removed.empty() || !added.empty();
  pieces_changed_ = pieces_changed_ || topology_changed_;
}

void Simulation::push_tissue() {
  tissue_->clear_external_forces();
  contact_ = {};
  // No sample in this frame: last_ is still frame_start_ (sample times increase strictly).
  if (!frame_start_ || !(last_.t > frame_start_->t)) return;
  const BladePose now = blade(last_);
  const BladePose before = blade(*frame_start_);
  const double dt = last_.t - frame_start_->t;
  const double length = (now.tip - now.back).norm();
  const int points = std::clamp(static_cast<int>(std::ceil(length / kEdgeSpacing)), 1, kMaxEdgePoints);
  const double ds = length / points;
  std::map<std::uint32_t, Vec3> loads;  // by node slot, in slot order: the sums are deterministic
  for (int k = 0; k < points; ++k) {
    const double u = (k + 0.5) / points;  // midpoints of equal parts, from the back
    const Vec3 p = now.back + u * (now.tip - now.back);
    const std::optional<TetLocation> at = cutter_->locate(p, kBladeHalfThickness);
    if (!at) continue;
    contact_.length += ds;
    const Vec3 v = (p - (before.back + u * (before.tip - before.back))) / dt;
    const Vec3 f =
        scenario_.tool.cutting_resistance * ds / std::max(v.norm(), ForceRenderer::kCutSpeedFloor) * v;
    contact_.force += f;
    for (int i = 0; i < 4; ++i)
      loads.try_emplace(at->corners[i].index, Vec3::Zero()).first->second += at->weights[i] * f;
  }
  for (const auto& [slot, f] : loads) tissue_->set_external_force(mesh_.node_handle(slot), f);
  contact_.loaded_nodes = loads.size();
}

void Simulation::hold_severed_pieces(double t) {
  if (!pieces_changed_ || !anchored_) return;
  pieces_changed_ = false;
  // Nodes joined by shared tetrahedra, then the pieces without a fixed node.
  const std::vector<std::uint32_t> root = node_pieces(mesh_);
  const auto find = [&](std::uint32_t i) { return root[i]; };
  const std::vector<TetId> tets = mesh_.tets();
  std::vector<std::uint8_t> anchored(root.size(), 0);
  for (const NodeId n : mesh_.nodes())
    if (tissue_->fixed(n)) anchored[find(n.index)] = 1;
  // Pieces by root, in the order of their first tetrahedron: deterministic.
  const std::size_t first = severed_.size();
  std::map<std::uint32_t, std::size_t> piece_of;  // root -> index into severed_
  std::vector<std::map<int, double>> region_volume;
  for (const TetId tet : tets) {
    const std::uint32_t r = find(mesh_.tet_vertex_indices(tet.index)[0]);
    if (anchored[r]) continue;
    const auto [it, fresh] = piece_of.try_emplace(r, severed_.size());
    if (fresh) {
      severed_.push_back({.time = t});
      region_volume.emplace_back();
    }
    SeveredPiece& p = severed_[it->second];
    const double v = mesh_.rest_volume(tet);
    p.rest_volume += v;
    ++p.tets;
    region_volume[it->second - first][mesh_.region(tet)] += v;
  }
  for (std::size_t k = 0; k < region_volume.size(); ++k) {
    double most = -1;
    for (const auto& [region, v] : region_volume[k])
      if (v > most) {
        most = v;
        severed_[first + k].region = region;
      }
  }
  for (const NodeId n : mesh_.nodes())
    if (piece_of.count(find(n.index))) {
      tissue_->set_fixed(n);
      mesh_.velocities()[n.index].setZero();
    }
}

std::vector<std::uint32_t> Simulation::piece_of_node(std::uint32_t node) const {
  const std::vector<std::uint32_t> root = node_pieces(mesh_);
  std::vector<std::uint32_t> nodes;
  for (std::uint32_t n = 0; n < root.size(); ++n)
    if (root[n] == root[node] && mesh_.node_slot_alive(n)) nodes.push_back(n);
  return nodes;
}

void Simulation::tally_piece(const std::vector<std::uint32_t>& nodes, MoveRecord& record,
                             Vec3* centroid) const {
  std::vector<std::uint8_t> in_piece(mesh_.node_capacity(), 0);
  for (const std::uint32_t n : nodes) in_piece[n] = 1;
  PieceTally tally;
  for (std::uint32_t t = 0; t < mesh_.tet_capacity(); ++t)
    if (mesh_.tet_slot_alive(t) && in_piece[mesh_.tet_vertex_indices(t)[0]]) tally.add(mesh_, t);
  record.rest_volume += tally.rest_volume;
  record.tets += tally.tets;
  if (centroid) *centroid = tally.centroid();
}

std::string Simulation::refuse_move(MoveRecord record, std::string why) {
  record.refused = std::move(why);
  moves_.push_back(record);
  return record.refused;
}

std::vector<std::uint32_t> Simulation::piece_at(const Vec3& point) const {
  const auto& x = mesh_.positions();
  for (std::uint32_t t = 0; t < mesh_.tet_capacity(); ++t) {
    if (!mesh_.tet_slot_alive(t)) continue;
    const auto& v = mesh_.tet_vertex_indices(t);
    const double volume = signed_volume(x[v[0]], x[v[1]], x[v[2]], x[v[3]]);
    if (!(volume > 0.0)) continue;
    // Inside when the point lies on the inner side of every face (a point on a face is in either).
    bool inside = true;
    for (int f = 0; f < 4 && inside; ++f) {
      std::array<Vec3, 4> p{x[v[0]], x[v[1]], x[v[2]], x[v[3]]};
      p[static_cast<std::size_t>(f)] = point;
      inside = signed_volume(p[0], p[1], p[2], p[3]) >= -1e-12 * volume;
    }
    if (inside) return piece_of_node(v[0]);
  }
  return {};
}

void Simulation::transform_nodes(const std::vector<std::uint32_t>& nodes, const Vec3& centre,
                                 const Eigen::Matrix3d& rotation, const Vec3& translation) {
  auto& x = mesh_.positions();
  auto& v = mesh_.velocities();
  for (const std::uint32_t n : nodes) {
    x[n] = centre + rotation * (x[n] - centre) + translation;
    v[n] = Vec3::Zero();
  }
  // Not tissue motion under the blade: nothing is cut by it.
  cutter_->refit();
  update_bounds();
}

std::string Simulation::move_piece(const Vec3& point, const Eigen::Quaterniond& rotation,
                                   const Vec3& translation) {
  MoveRecord record;
  record.time = frame_time_;
  if (!scenario_.tissue.rigid) return refuse_move(record, "the tissue is not rigid");
  if (!point.allFinite() || !translation.allFinite() || !rotation.coeffs().allFinite() ||
      !(rotation.norm() > 0.0))
    return refuse_move(record, "not a finite move");
  if (cutter_->in_contact()) return refuse_move(record, "the blade is in the tissue");
  const std::vector<std::uint32_t> nodes = piece_at(point);
  if (nodes.empty()) return refuse_move(record, "no tissue at that point");
  Vec3 centre;  // of the piece's volume, where it turns
  tally_piece(nodes, record, &centre);
  const Eigen::Matrix3d r = rotation.normalized().toRotationMatrix();
  transform_nodes(nodes, centre, r, translation);
  standing_moves_.push_back({mesh_.node_handle(nodes.front()), centre, translation, r});
  moves_.push_back(record);
  return {};
}

std::string Simulation::undo_move() {
  MoveRecord record;
  record.time = frame_time_;
  record.action = PieceAction::Undo;
  if (standing_moves_.empty()) return refuse_move(record, "no move to undo");
  if (cutter_->in_contact()) return refuse_move(record, "the blade is in the tissue");
  const StandingMove m = standing_moves_.back();
  standing_moves_.pop_back();
  if (!mesh_.alive(m.anchor)) return refuse_move(record, "the piece is gone");
  const std::vector<std::uint32_t> nodes = piece_of_node(m.anchor.index);
  // x' = c + R (x - c) + t, so x = c + R^T (x' - t - c): about the centre moved by t.
  transform_nodes(nodes, m.centre + m.translation, m.rotation.transpose(), -m.translation);
  tally_piece(nodes, record, nullptr);
  moves_.push_back(record);
  return {};
}

std::string Simulation::delete_piece(const Vec3& point) {
  MoveRecord record;
  record.time = frame_time_;
  record.action = PieceAction::Delete;
  if (!scenario_.tissue.rigid) return refuse_move(record, "the tissue is not rigid");
  if (cutter_->in_contact()) return refuse_move(record, "the blade is in the tissue");
  const std::vector<std::uint32_t> nodes = piece_at(point);
  if (nodes.empty()) return refuse_move(record, "no tissue at that point");
  MoveRecord done = record;
  tally_piece(nodes, done, nullptr);
  if (done.tets == mesh_.tet_count()) return refuse_move(record, "it is all the tissue left");
  record = done;
  std::vector<std::uint32_t> tets;
  for (const std::uint32_t n : nodes)
    for (const std::uint32_t t : mesh_.node_tets(mesh_.node_handle(n))) tets.push_back(t);
  deleted_volume_ += cutter_->remove_piece(tets);
  surface_->drop_faces_of(nodes);
  // Its moves leave the undo stack with it: an undo takes back the last move of a piece still there.
  std::erase_if(standing_moves_, [&](const StandingMove& m) { return !mesh_.alive(m.anchor); });
  hand_over_cut();
  cutter_->refit();
  update_bounds();
  moves_.push_back(record);
  return {};
}

void Simulation::apply_move(const PieceMove& m) {
  switch (m.action) {
    case PieceAction::Move:
      (void)move_piece(m.point, m.rotation, m.translation);
      break;
    case PieceAction::Undo:
      (void)undo_move();
      break;
    case PieceAction::Delete:
      (void)delete_piece(m.point);
      break;
  }
}

void Simulation::apply_scheduled_moves(double t) {
  for (; next_move_ < scenario_.moves.size() && scenario_.moves[next_move_].at <= t + 1e-12; ++next_move_)
    apply_move(scenario_.moves[next_move_]);
  for (const PieceMove& m : queued_moves_) apply_move(m);
  queued_moves_.clear();
}

void Simulation::end_frame(double t, ForceChannel& forces) {
  frame_time_ = t;
  apply_scheduled_moves(t);
  hold_severed_pieces(t);
  const bool pressing = indentation_ && indentation_->phase() == Indentation::Phase::Pressing;
  if (pressing) {
    tissue_->clear_external_forces();  // the blade is on the tissue: no edge drags it
    contact_ = {};
    indentation_->follow(blade(last_).tip, mesh_);
  } else if (!scenario_.tissue.rigid) {
    push_tissue();
  }
  // The flats and the handle carry the nodes they hold to where the tool is now.
  // (Before the first sample there is no tool.)
  if (body_ && samples_ > 0) body_->follow(blade(last_), mesh_, *tissue_);
  const double dt = 1.0 / scenario_.tissue.rate;
  while (!scenario_.tissue.rigid && tissue_time_ + dt <= t + 1e-12) {
    const auto start = std::chrono::steady_clock::now();
    tissue_stats_.push_back(tissue_->step(dt));
    tissue_seconds_.push_back(
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    tissue_after_cut_.push_back(topology_changed_ ? 1 : 0);
    topology_changed_ = false;
    tissue_time_ += dt;
  }
  if (pressing) settle_press(t);
  if (body_ && samples_ > 0) {
    std::vector<NodeId> copies;
    for (const auto& c : cutter_->cut_node_copies())
      copies.insert(copies.end(), c.copies.begin(), c.copies.end());
    body_->settle(blade(last_), copies, mesh_, *tissue_);
  }
  // What the tissue's motion carried into the blade's edge is cut (CutEngine::follow_tissue); a
  // blade that has not cut in (contact) cuts nothing the tissue brings to it.
  if (!indentation_ || indentation_->phase() == Indentation::Phase::Cutting)
    cutter_->follow_tissue();
  else
    cutter_->refit();
  hand_over_cut();
  update_bounds();
  // The force model the haptic loop renders until the next frame: the resistance of the blade's
  // edge inside the tissue (see simulation.hpp), or the pressed surface. The coupling spring is off
  // (k_c = 0).
  ForceModel model;
  model.sequence = ++force_sequence_;
  model.t = t;
  model.constrained_position = last_.position;
  model.cutting_resistance = scenario_.tool.cutting_resistance * contact_.length;
  if (body_ && samples_ > 0) set_body_model(model);
  if (indentation_ && indentation_->phase() == Indentation::Phase::Pressing) set_contact_model(model);
  forces.publish(model);
  published_ = model;
  const Vec3 body_force = body_ ? body_->force() : Vec3::Zero();  // on the tool
  // On the tissue: the edge's push or the press (the tissue's load on the blade, reversed), and the
  // body's.
  contact_forces_.push_back(((pressing ? Vec3(-indentation_->force()) : contact_.force) - body_force).norm());
  if (samples_ > 0) frame_start_ = last_;
}

// The flats' and the handle's force as the hand feels it until the next frame (ForceModel): the
// solved force along its own direction, growing by a stiffness measured between the last two
// frames in contact: the change of the force over the tool's motion against it, where the tool
// moved more than kBodyStiffnessTravel across the force. published_ is the last frame's model.
void Simulation::set_body_model(ForceModel& m) {
  const DeviceMapping& map = scenario_.device.mapping;
  const Vec3 f = map.rotation.conjugate() * body_->force();  // device axes
  const Vec3& x = last_.position;
  const ForceModel& last = published_;
  const bool had = last.body_force > 0.0;
  // The model the hand felt since the last frame, where the tool is now, against the solve.
  if (had) body_model_errors_.push_back((last.body_force_at(x) - f).norm());
  if (!(f.norm() > 0.0)) return;
  m.body_force = f.norm();
  m.body_normal = f / f.norm();
  m.body_position = x;
  if (had) {
    m.body_stiffness = last.body_stiffness;
    // The tool's motion against the force [device m], and the force's change along it.
    const double into = m.body_normal.dot(last.body_position - x);
    if (std::abs(into) * map.scale > kBodyStiffnessTravel) {
      const double grew = m.body_force - last.body_force * last.body_normal.dot(m.body_normal);
      m.body_stiffness = std::clamp(grew / into, 0.0, kMaxBodyStiffness * map.scale);
    }
  }
}

void Simulation::settle_press(double t) {
  const BladePose pose = blade(last_);
  indentation_->settle(t, pose, *tissue_);
  // The local model published at the last frame, evaluated where the tool is now, against the
  // force the full solve gives here: the error the hand felt between the frames.
  if (published_.contact && indentation_->phase() != Indentation::Phase::Free) {
    const double predicted = published_.contact_force(last_.position);
    press_model_errors_.push_back(std::abs(predicted - indentation_->normal_force()));
  }
}

// The pressed surface as a plane in device space: f(x) = k (d - n.x) n gives the solved normal force
// at the tool's position now and changes by the measured stiffness as the tool moves.
void Simulation::set_contact_model(ForceModel& model) const {
  const DeviceMapping& map = scenario_.device.mapping;
  const Vec3 n = map.rotation.conjugate() * indentation_->normal();
  // A device displacement dx moves the blade by scale R dx: the stiffness per device metre.
  const double k = indentation_->stiffness() * map.scale;
  model.contact = true;
  model.contact_normal = n;
  model.contact_stiffness = k;
  const double f = std::max(0.0, indentation_->normal_force());
  model.contact_offset = n.dot(last_.position) + (k > 0 ? f / k : 0.0);
}

}  // namespace scalpel

namespace scalpel {

WoundGape Simulation::wound_gape(std::span<const Vec3> path, double band, double window) const {
  return wound_meter_->measure(mesh_, cutter_->cut_node_copies(), path, band, window);
}

}  // namespace scalpel
