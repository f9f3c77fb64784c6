// The scalpel's body pushes the tissue it meets (docs/contact.md): a scenario with
// `tool.contact: indent` and a blade `width` or a `handle`.
//
// The cutter's blade is its edge: the segment from the back point to the tip, whose sweep is the
// cut (§3). The body adds what lies behind the edge and above the blade:
//   - the flats: a triangle in the blade's plane between the edge and the spine, which runs from
//     `width` behind the edge at the back point (against the direction the edge faces) to the tip,
//     where a scalpel blade's edge and spine meet. Narrowing to the tip, it stays above the tip's
//     path, in tissue the edge has cut. It has no thickness, as the cut it trails in has none: a
//     node may lie on it (the cutter puts the cut nodes there) but never passes through it;
//   - the handle: a capsule of `radius` along the blade's axis, from the back point away from the
//     tip over `length`, its rounded end at the back point. No node lies inside it.
//
// Contact is a constraint, as the press's (sim/indentation.hpp, and why not a penalty there): a
// node the body meets is put back on the body's surface, on the side it came from, and held there
// by the tissue solve as a prescribed node (TissueModel::set_held: not a boundary condition, which
// the cutter's nodes would inherit and severed pieces would count as an anchor). Held nodes slide
// with the body (frictionless): before each frame's tissue steps, each is put back on the body
// where the body has moved through it, and let go where the body has moved away from it. After
// the steps, the nodes the body has met are put back and held, a held node the tissue pulls away
// from the body is let go, and the others' load on their holder is the force on the body
// (TissueModel::load_on_holder; the edge's drag on a held node is left out).
//
// Which side of the flats a node belongs to: a copy of a cut node, its lip's (its crack faces face
// the other lip, across the blade); any other, the side it was on at the end of the last frame once
// it was kSideBand from the plane. The cutter makes the lips' nodes on the blade's path, which the
// blade has since left by a rounding or a tremor, and the tissue may carry a closed crack sideways
// before it opens: where a lip's node is against the plane does not say which lip it is of, its
// faces do. A node over the flats on the other side of its own passed through them. The
// handle needs no side: a node inside is put on the nearest point of its surface.
//
// Threads: belongs to the simulation thread, like the mesh.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "cutting/blade_sweep.hpp"
#include "fem/tissue.hpp"
#include "mesh/mesh.hpp"

namespace scalpel {

struct ToolBodySize {
  double blade_width = 0.0;    // [m] edge to spine at the back point; 0: no flats
  double handle_radius = 0.0;  // [m] 0: no handle
  double handle_length = 0.0;  // [m] from the blade's back point, at least twice the radius
  [[nodiscard]] bool any() const { return blade_width > 0.0 || handle_radius > 0.0; }
};

// The body at one blade pose.
class ToolBody {
 public:
  // Coordinates of a point in the blade's frame: s along the edge from the back point [m], w behind
  // the edge towards the spine [m], d off the blade's plane [m] (along axis x edge).
  struct Local {
    double s = 0, w = 0, d = 0;
  };

  // Without a cutting direction (blade.edge) there are no flats: the spine is not known.
  ToolBody(const BladePose& blade, const ToolBodySize& size);

  [[nodiscard]] bool has_flats() const { return flats_; }
  [[nodiscard]] bool has_handle() const { return size_.handle_radius > 0.0; }
  [[nodiscard]] Local local(const Vec3& x) const;
  [[nodiscard]] Vec3 world(const Local& l) const;
  // Within the flats' outline (s in [0, length], w in [0, width (1 - s / length)]), at any
  // distance from the plane.
  [[nodiscard]] bool over_flats(const Local& l) const;
  // Unit normal of the blade's plane.
  [[nodiscard]] const Vec3& normal() const { return n_; }
  // The handle's surface point nearest x and its outward normal, when x is inside the handle (or
  // within `slack` [m] of it).
  struct Exit {
    Vec3 point = Vec3::Zero();
    Vec3 normal = Vec3::Zero();
  };
  [[nodiscard]] std::optional<Exit> handle_exit(const Vec3& x, double slack = 0.0) const;
  // The handle's outward normal at the surface point nearest x.
  [[nodiscard]] Vec3 handle_normal(const Vec3& x) const;
  // A box holding the handle and the flats [m].
  void bounds(Vec3& lo, Vec3& hi) const;

 private:
  Exit handle_nearest(const Vec3& x, double& distance) const;

  ToolBodySize size_;
  bool flats_ = false;
  Vec3 back_ = Vec3::Zero(), axis_ = Vec3::UnitZ(), spine_ = Vec3::UnitX(), n_ = Vec3::UnitY();
  double length_ = 0;
};

// How far a held node is put off the plane on its side [m]: the plane itself belongs to neither.
inline constexpr double kFlatClearance = 1e-7;
// A node off the crack takes the side of the flats it is on once it is this far from the blade's
// plane [m].
inline constexpr double kSideBand = 50e-6;
// A copy of a cut node is on a lip when its crack faces face across the blade this much (their
// normals' mean component along the blade's normal).
inline constexpr double kLipAcross = 0.5;

struct BodyContactStats {
  std::size_t pushes = 0;    // nodes put back on the body
  std::size_t max_held = 0;  // the most nodes held at once
  double max_force = 0;      // [N] on the body, the largest
  std::size_t frames_in_contact = 0;
};

class BodyContact {
 public:
  explicit BodyContact(ToolBodySize size) : size_(size) {}

  // Before the frame's tissue steps: the held nodes follow the body to `blade`; those it has moved
  // away from are let go.
  void follow(const BladePose& blade, TetMesh& mesh, TissueModel& tissue);
  // After the steps: the force on the body, the nodes the tissue pulls away let go, and the nodes
  // that passed through the flats or into the handle put back and held. Returns the force on the
  // body [N].
  // `cut_copies`: the copies of the cutter's cut nodes, whose side is their lip's.
  Vec3 settle(const BladePose& blade, std::span<const NodeId> cut_copies, TetMesh& mesh, TissueModel& tissue);

  [[nodiscard]] const Vec3& force() const { return force_; }  // [N] as of the last settle()
  // How many nodes the body holds, as of the last follow() or settle().
  [[nodiscard]] std::size_t held_count() const { return held_nodes_.size(); }
  [[nodiscard]] const BodyContactStats& stats() const { return stats_; }

 private:
  struct Held {
    NodeId node;
    bool handle = false;  // held by the handle, else by the flats
    double side = 0;      // the flats' side it is on (+1 or -1)
  };
  // Puts a node held or met by the body back on it; false when the body no longer meets it.
  bool put_back(const ToolBody& body, Held& h, TetMesh& mesh) const;
  void let_go(std::size_t i, const TetMesh& mesh, TissueModel& tissue);

  ToolBodySize size_;
  std::vector<Held> held_nodes_;
  // Each node slot's signed distance from the blade's plane at the end of the last frame; NaN for
  // a slot not seen yet.
  std::vector<double> side_;
  std::vector<std::uint32_t> side_generation_;  // the generation of the node each side is of
  std::vector<std::uint8_t> cut_;               // by node slot: a copy of a cut node (scratch)
  Vec3 force_ = Vec3::Zero();
  BodyContactStats stats_;
};

}  // namespace scalpel
