// The simulation of one scenario (docs/architecture.md): the sim thread's side of the spine. It takes
// tool samples drained from the haptic queue, sweeps the blade through the cutter at every sample
// (docs/state_machine.md: every 1 kHz sample is a sweep step), and at the end of each visual frame steps
// the tissue and publishes the force model for the haptic loop.
//
// Tool contact: the blade cuts whatever it meets, and the part of its edge inside the tissue meets a
// resistance of `tool.cutting_resistance` per length, against its motion. The hand feels the total
// (ForceModel::cutting_resistance, rendered at 1 kHz); the tissue takes the reaction: at points
// kEdgeSpacing apart along the edge, each point in the tissue (or within kBladeHalfThickness of it
// on its own cut) pushes it along the point's own velocity over the frame, R ds v / max(|v|, v_eps)
// (v_eps as the haptic renderer's). The push goes to the corners of the original tetrahedron the
// point lies in (CutEngine::locate), by its barycentric weights: the consistent nodal load of a
// point force on the uncut mesh. Cut nodes take none: some carry almost no mass, and a share of the
// push would fling them. The loads hold for the tissue steps of that frame; a blade at rest or
// outside the tissue pushes nothing.
#pragma once

#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "cutting/cut_engine.hpp"
#include "devices/tool_sample.hpp"
#include "fem/tissue.hpp"
#include "haptics/force_model.hpp"
#include "mesh/io/mesh_io.hpp"
#include "mesh/mesh.hpp"
#include "sim/indentation.hpp"
#include "sim/scenario.hpp"
#include "sim/snapshot.hpp"
#include "sim/surface_probe.hpp"
#include "sim/task_score.hpp"
#include "sim/tool_body.hpp"
#include "sim/wound.hpp"

namespace scalpel {

// The scenario's mesh: generated, or read from its file (region names from the file's tags).
struct ScenarioMesh {
  TetMesh mesh;
  RegionIds regions;       // region name -> id
  MeshFileInfo file_info;  // a mesh file's: re-oriented tetrahedra, elements left out
};
// With the scenario's volume sampled onto its nodes (mesh/volume.hpp). InputError for a volume that
// cannot be read or does not cover the mesh.
[[nodiscard]] ScenarioMesh load_scenario_mesh(const Scenario& scenario);
// The mesh alone, without the volume.
[[nodiscard]] ScenarioMesh read_scenario_mesh(const Scenario& scenario);

class Simulation {
 public:
  explicit Simulation(const Scenario& scenario);
  ~Simulation();
  Simulation(const Simulation&) = delete;
  Simulation& operator=(const Simulation&) = delete;

  // The blade in world space for a sample in device space (the scenario's mapping, then the tool
  // frame's blade points).
  [[nodiscard]] BladePose blade(const ToolSample& device_sample) const;

  // One tool sample from the queue: a sweep step of the cutter.
  void on_sample(const ToolSample& device_sample);
  // The end of a visual frame at time t [s]: steps the tissue up to t at the scenario's tissue
  // rate, refits the collision structure to the moved nodes and publishes the force model.
  void end_frame(double t, ForceChannel& forces);

  // What a picture of the tissue needs now (sim/snapshot.hpp), into `out`, with the tetrahedra's
  // edges when asked. Sets everything but `frame`.
  void snapshot(FrameSnapshot& out, bool with_edges = false) const {
    snapshots_->fill(*this, with_edges, out);
  }
  // [s] the time of the last frame's end.
  [[nodiscard]] double time() const { return frame_time_; }

  [[nodiscard]] const Scenario& scenario() const { return scenario_; }
  // The mesh's region names (a file's names and the region_<id> form, or a generated mesh's).
  [[nodiscard]] const RegionIds& regions() const { return regions_; }
  [[nodiscard]] TetMesh& mesh() { return mesh_; }
  [[nodiscard]] const TetMesh& mesh() const { return mesh_; }
  [[nodiscard]] const CutEngine& cutter() const { return *cutter_; }
  [[nodiscard]] double initial_volume() const { return initial_volume_; }
  [[nodiscard]] std::size_t samples() const { return samples_; }
  [[nodiscard]] const std::vector<double>& cut_step_seconds() const { return cut_seconds_; }
  [[nodiscard]] const ToolSample& last_sample() const { return last_; }
  [[nodiscard]] const TissueModel& tissue() const { return *tissue_; }
  [[nodiscard]] const std::vector<StepStats>& tissue_steps() const { return tissue_stats_; }
  [[nodiscard]] const std::vector<double>& tissue_step_seconds() const { return tissue_seconds_; }
  // Per tissue step: whether the mesh changed (a cut) since the step before it.
  [[nodiscard]] const std::vector<std::uint8_t>& tissue_step_after_cut() const { return tissue_after_cut_; }
  // How far the wound's lips stand apart at the tissue surface (sim/wound.hpp), across `path` when
  // one is given (the task's), measuring the cut nodes within `band` [m] of it.
  [[nodiscard]] WoundGape wound_gape(std::span<const Vec3> path, double band, double window) const;

  // Severed pieces: a part of the tissue that a cut has freed from every fixed node would fall
  // under gravity without bound (or be flung by the solve). At the end of a frame whose cuts
  // changed the mesh, each such piece (nodes joined by shared tetrahedra) is found and held where
  // it lies: its nodes become fixed, as if it rested on the instrument tray. A scenario with no
  // fixed node at all is free-floating tissue and is left alone.
  struct SeveredPiece {
    double time = 0;         // [s] the frame that held it
    double rest_volume = 0;  // [m^3]
    std::size_t tets = 0;    // live tetrahedra
    int region = -1;         // the region holding most of its volume
  };
  [[nodiscard]] const std::vector<SeveredPiece>& severed_pieces() const { return severed_; }

  // Rigid moves of pieces (volume data, paper section 7.1; scenario `moves`, sim/scenario.hpp): the
  // piece holding `point` now (its tetrahedra and all joined to them by a node), turned by
  // `rotation` about its centroid and shifted by `translation`. Undoable, last first. Each returns
  // why it did nothing, or an empty string when it was done. Refused while the blade is in the
  // tissue, and without rigid tissue.
  std::string move_piece(const Vec3& point, const Eigen::Quaterniond& rotation, const Vec3& translation);
  std::string undo_move();
  // The piece holding `point`: the node slots of the live tetrahedra joined to the one there by
  // shared nodes, sorted; empty when no tetrahedron holds it.
  [[nodiscard]] std::vector<std::uint32_t> piece_at(const Vec3& point) const;
  // Sculpting (paper section 7.3): deletes the piece holding `point` from the mesh
  // (CutEngine::remove_piece). Not undoable; its moves leave the undo stack.
  // Refused as a move is, and for the last piece of tissue left.
  std::string delete_piece(const Vec3& point);
  // A move, undo or deletion asked for during the session (the trainee's window, or a recording's
  // piece events, sim/piece_events.hpp): applied at the end of the current frame, after the
  // scenario's moves due then, in the order queued. Its `at` is not used.
  void queue_move(const PieceMove& move) { queued_moves_.push_back(move); }
  // [m^3] The rest volume of the pieces deleted.
  [[nodiscard]] double deleted_volume() const { return deleted_volume_; }
  struct MoveRecord {
    double time = 0;  // [s] the frame that applied it
    PieceAction action = PieceAction::Move;
    std::string refused;     // why it did nothing; empty when done
    std::size_t tets = 0;    // of the piece moved
    double rest_volume = 0;  // [m^3] of the piece moved
  };
  // Every move, undo and deletion asked for, in order.
  [[nodiscard]] const std::vector<MoveRecord>& moves() const { return moves_; }

  // The score of the scenario's task so far (docs/scoring.md); none without a task.
  [[nodiscard]] std::optional<TaskScore> task_score() const;
  // The task scorer (with no incisions without a task): its view of the last tool sample.
  [[nodiscard]] const TaskScorer& scorer() const { return *scorer_; }

  // The tool's push on the tissue in the last frame (see above).
  struct ToolContact {
    Vec3 force = Vec3::Zero();     // [N] total on the tissue
    double length = 0.0;           // [m] of blade edge inside the tissue
    std::size_t loaded_nodes = 0;  // nodes that carry part of it
  };
  // Points along the blade's edge where contact is sought: this far apart, at most this many.
  static constexpr double kEdgeSpacing = 0.1e-3;  // [m]
  static constexpr int kMaxEdgePoints = 1000;
  // A scalpel blade is about 0.4 mm thick: on its own cut it touches faces that far apart.
  static constexpr double kBladeHalfThickness = 0.2e-3;  // [m]
  [[nodiscard]] const ToolContact& tool_contact() const { return contact_; }
  // With contact, the points of the blade tested for a touch of the surface: this far apart.
  static constexpr double kTouchSpacing = 1e-3;  // [m]
  // With contact, a blade that enters the surface this near an earlier cut enters that incision and
  // cuts on without a press (about half the edge of a cell of the bundled meshes).
  static constexpr double kReentryDistance = 1e-3;  // [m]
  // With contact, a tip that moves this far in one sample (1 m/s at 1 kHz, far beyond a hand's
  // speed) has jumped (a gap, or merged samples): entering the tissue so, it cuts in without a press.
  static constexpr double kJumpDistance = 1e-3;  // [m]
  // Per frame: the magnitude of the force on the tissue [N].
  [[nodiscard]] const std::vector<double>& contact_forces() const { return contact_forces_; }
  // The blade's press on the surface before it cuts (sim/indentation.hpp); null without
  // `tool.contact: indent`.
  [[nodiscard]] const Indentation* indentation() const { return indentation_.get(); }
  // Per frame of a press after its first: |the normal force the last frame's local model gives at
  // the tool's position now - the force the solve gives now| [N].
  [[nodiscard]] const std::vector<double>& press_model_errors() const { return press_model_errors_; }
  // The blade's flats and the handle pushing the tissue (sim/tool_body.hpp); null without contact
  // or without either.
  [[nodiscard]] const BodyContact* body_contact() const { return body_.get(); }
  // Per frame after one in which the body pressed on the tissue: |the force the last frame's model
  // gives at the tool's position now - the force the solve gives now| [N]
  // (ForceModel::body_force_at()).
  [[nodiscard]] const std::vector<double>& body_model_errors() const { return body_model_errors_; }
  // The tool's body as it is after the last sample.
  [[nodiscard]] ToolBody tool_body() const { return {blade(last_), body_size()}; }
  [[nodiscard]] ToolBodySize body_size() const {
    return {scenario_.tool.blade_width, scenario_.tool.handle_radius, scenario_.tool.handle_length};
  }

 private:
  // Sets the tissue's external forces from the blade's motion over the frame (see above).
  void push_tissue();
  // The box of the current positions (bounds_lo_, bounds_hi_), and the surface probe's boxes: called
  // whenever positions move.
  void update_bounds();
  // The surface probe (checked against the positions in SCALPEL_VALIDATE builds).
  [[nodiscard]] const SurfaceProbe& surface() const;
  // Hands the cutter's last changes to the tissue model.
  void hand_over_cut();
  // Holds the pieces cuts have severed from every fixed node (see SeveredPiece).
  void hold_severed_pieces(double t);
  [[nodiscard]] std::vector<std::uint32_t> piece_of_node(std::uint32_t node) const;
  // The piece's tetrahedra and rest volume into `record`; with `centroid`, the centroid of its
  // volume where it lies now.
  void tally_piece(const std::vector<std::uint32_t>& nodes, MoveRecord& record, Vec3* centroid) const;
  // Records a move that did nothing, and why; returns why.
  std::string refuse_move(MoveRecord record, std::string why);
  // x -> centre + rotation (x - centre) + translation for the nodes; refits the cutter.
  void transform_nodes(const std::vector<std::uint32_t>& nodes, const Vec3& centre,
                       const Eigen::Matrix3d& rotation, const Vec3& translation);
  // Applies one move, undo or deletion.
  void apply_move(const PieceMove& move);
  // Applies the scenario's moves due at time t, then the queued ones.
  void apply_scheduled_moves(double t);
  // Where a point of the blade (the tip, and points of the edge kTouchSpacing apart) first crosses
  // the outer surface inwards between two poses, if one does.
  [[nodiscard]] std::optional<SurfaceHit> entry(const BladePose& before, const BladePose& now) const;
  // Whether a blade entering the surface at `point` (outward normal `normal`) enters an incision
  // already made: the point just under the surface lies in an opened crack, or within
  // kReentryDistance (at rest) of a point the cutter has cut.
  [[nodiscard]] bool on_earlier_cut(const Vec3& point, const Vec3& normal) const;
  // Whether the box [lo, hi] meets the box of the current positions.
  [[nodiscard]] bool meets_bounds(const Vec3& lo, const Vec3& hi) const;
  // The deepest point of the blade under the tissue's outer surface (SurfaceProbe), if any.
  [[nodiscard]] std::optional<Vec3> under_surface(const BladePose& pose) const;
  // With contact: the press's phase for this sample, and what the cutter does with the blade.
  enum class BladeMove : std::uint8_t {
    Sweep,  // sweeps it from its last pose (it cuts)
    Place,  // places it without a sweep (it is out of the tissue)
    Hold,   // keeps its last pose (the blade presses the surface, or is in the dimple it left)
  };
  BladeMove press_or_cut(const BladePose& pose, double t);
  // With contact, at the end of a frame spent pressing: the press's force, puncture or lift-off.
  void settle_press(double t);
  void set_contact_model(ForceModel& model) const;
  void set_body_model(ForceModel& model);
  [[nodiscard]] double hand_force(const ToolSample& s) const;
  // The body's stiffness is measured over at least this much of the tool's motion across its force
  // [m], and at most this stiff [N/m] (a sharp contact on skin; the device's force limit bounds
  // what the hand gets).
  static constexpr double kBodyStiffnessTravel = 20e-6;
  static constexpr double kMaxBodyStiffness = 1e4;

  Scenario scenario_;
  TetMesh mesh_;
  double initial_volume_ = 0.0;
  std::unique_ptr<WoundMeter> wound_meter_;  // the outer surface of the uncut mesh
  std::unique_ptr<SnapshotBuilder> snapshots_;
  std::unique_ptr<CutEngine> cutter_;
  std::unique_ptr<SurfaceProbe> surface_;
  Vec3 bounds_lo_ = Vec3::Zero(), bounds_hi_ = Vec3::Zero();  // current positions, as of the last frame
  std::unique_ptr<TaskScorer> scorer_;
  std::unique_ptr<TissueModel> tissue_;
  double tissue_time_ = 0.0;  // [s] simulated tissue time
  double frame_time_ = 0.0;   // [s] the end of the last frame
  std::vector<StepStats> tissue_stats_;
  std::vector<double> tissue_seconds_;
  std::vector<std::uint8_t> tissue_after_cut_;
  bool topology_changed_ = false;  // since the last tissue step
  bool pieces_changed_ = false;    // since the last search for severed pieces
  bool anchored_ = false;          // the scenario fixes some node
  RegionIds regions_;
  std::vector<SeveredPiece> severed_;
  struct StandingMove {  // what undo_move() needs
    NodeId anchor;       // a node of the piece
    Vec3 centre, translation;
    Eigen::Matrix3d rotation;
  };
  std::vector<StandingMove> standing_moves_;
  std::vector<MoveRecord> moves_;
  std::size_t next_move_ = 0;  // the scenario's next move
  double deleted_volume_ = 0.0;
  std::vector<PieceMove> queued_moves_;
  std::size_t samples_ = 0;
  ToolSample last_;
  std::optional<ToolSample> frame_start_;  // the last sample before this frame
  ToolContact contact_;
  std::vector<double> contact_forces_;
  std::vector<double> cut_seconds_;
  std::uint64_t force_sequence_ = 0;
  std::unique_ptr<Indentation> indentation_;
  std::unique_ptr<BodyContact> body_;
  ForceModel published_;  // at the last frame (the press's and the body's models among it)
  std::vector<double> body_model_errors_;
  std::vector<double> press_model_errors_;
};

}  // namespace scalpel
