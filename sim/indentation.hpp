// The blade presses the tissue surface in before it cuts (docs/contact.md): a scenario with
// `tool.contact: indent`.
//
// Contact is a constraint, not a penalty. When the blade's tip (or a point of its edge) first meets
// the outer surface, the nodes of the surface triangle it crossed are held by it: from then on they
// follow the tip's motion along the surface's normal at the touch, held by the tissue solve as
// prescribed nodes. Sideways the blade slides over them (frictionless): a trembling hand does not
// drag the skin. No stuck node passes through the
// blade at any step, and the implicit step stays as stable as with any fixed node; a penalty
// spring evaluated once per 60 Hz frame would either let the tip sink in or, stiffer than the
// tissue under it, oscillate between frames. The force on the blade is what the stuck nodes press
// on their holder (TissueModel::load_on_holder): their elements' elastic force, their weight.
//
// Puncture: the press ends in a cut when the load on the blade's sharp parts (sharp_load() of the
// force for a push along the inward normal: the normal force, as far as the normal faces the tip or
// the edge) reaches the region's puncture_force (the weakest region around the held nodes).
// Pressed tip first or edge first the whole force meets them; flat first or spine first none does,
// so a blunt approach never cuts. The held nodes are let go and the cutter sweeps the blade in from
// its pose before the touch; the released skin springs back around the blade and is cut as it comes
// (CutEngine::follow_tissue). The press also ends, without a cut, when the tip is drawn back above
// where it touched, or the tissue no longer pushes a blade that has pressed it in (drawn back faster
// than the skin follows).
//
// The blade's flats and the handle push the tissue through sim/tool_body.hpp. What the press
// does not model: the held patch is one triangle of the mesh, so the stiffness the hand feels
// grows with the mesh's cells, and it stays where it was touched (a blade drawn along the skin far
// from it presses nothing new); the skin's pull on an edge drawn along it (slicing) does not count
// towards the puncture; a blade that jumps into the tissue between two samples (a gap, or samples
// merged while the simulation fell behind) cuts in at once, as without contact.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "cutting/blade_sweep.hpp"
#include "fem/tissue.hpp"
#include "mesh/mesh.hpp"

namespace scalpel {

// The load on the blade's sharp parts [N], >= 0, when it has pushed the skin by `push` [m] and the
// skin pushes back with `force` [N]: the resistance along the push, -force . p (p = push / |push|),
// times how much the push faces the tip (along the blade's axis) or the edge (across it), the larger.
// Pressed tip first or edge first the whole resistance meets them; flat first or spine first none
// does, so a blunt approach never cuts; drawn edge first along the skin it holds, the skin's pull
// meets the edge. With no edge direction (the flats are not known) every push meets a sharp part.
[[nodiscard]] double sharp_load(const BladePose& blade, const Vec3& force, const Vec3& push);

struct PunctureEvent {
  double t = 0;               // [s] the frame that punctured
  double touched = 0;         // [s] when the tip met the surface
  double depth = 0;           // [m] how far the tip pushed the surface in, along the normal at the touch
  double force = 0;           // [N] on the blade, along the surface's outward normal
  double sharp = 0;           // [N] of it on the blade's tip or edge (sharp_load())
  double threshold = 0;       // [N] the region's puncture_force
  int region = -1;            // whose puncture_force it was
  Vec3 point = Vec3::Zero();  // [m] where the tip met the surface
};

class Indentation {
 public:
  enum class Phase : std::uint8_t {
    Free,      // the blade is out of the tissue
    Pressing,  // its tip presses the surface in
    Cutting,   // it has cut in; until it is out of the tissue again
  };

  // puncture_force[r]: region r's [N] (Material::puncture_force).
  explicit Indentation(std::vector<double> puncture_force);

  [[nodiscard]] Phase phase() const { return phase_; }

  // Free -> Pressing at time t: the tip met the surface at `point`, outward normal `normal`; the
  // surface nodes `face` (node slots) stick to it from now on (TissueModel::set_held). Fixed nodes
  // and nodes already held stay as they are; with none left to stick, the blade cuts at once
  // (Cutting).
  void touch(std::span<const std::uint32_t> face, const Vec3& tip, const Vec3& point, const Vec3& normal,
             double t, const TetMesh& mesh, TissueModel& tissue);
  // Pressing: before the tissue steps, the stuck nodes follow the tip's translation since the touch
  // along the normal, inwards only.
  void follow(const Vec3& tip, TetMesh& mesh) const;
  // Pressing: after the tissue steps at time t, the force on the blade and the depth; a puncture
  // (-> Cutting) or a lift-off (-> Free) lets the stuck nodes go. Returns the phase after.
  Phase settle(double t, const BladePose& blade, TissueModel& tissue);
  // Free -> Cutting without a press: the blade entered an incision already made, jumped deep into
  // the tissue between two samples, or moved on under a surface that sprang back over it.
  void enter_without_press() {
    phase_ = Phase::Cutting;
    ++unpressed_;
  }
  // Cutting -> Free: the blade is out of the tissue.
  void left() {
    if (phase_ == Phase::Cutting) phase_ = Phase::Free;
  }

  // The press as of the last settle() (zero when not pressing).
  [[nodiscard]] const Vec3& force() const { return force_; }           // [N] on the blade
  [[nodiscard]] double normal_force() const { return normal_force_; }  // [N] along the outward normal
  [[nodiscard]] double depth() const { return depth_; }                // [m]
  [[nodiscard]] const Vec3& normal() const { return normal_; }         // outward, at the touch
  // [N/m] normal force over depth: the local model the hand feels between frames.
  [[nodiscard]] double stiffness() const { return stiffness_; }
  [[nodiscard]] std::span<const NodeId> stuck() const { return stuck_; }
  [[nodiscard]] const std::vector<PunctureEvent>& punctures() const { return punctures_; }
  [[nodiscard]] std::size_t presses() const { return presses_; }              // touches so far
  [[nodiscard]] std::size_t lifted() const { return lifted_; }                // presses ended without a cut
  [[nodiscard]] std::size_t unpressed_entries() const { return unpressed_; }  // enter_without_press()
  [[nodiscard]] double max_normal_force() const { return max_force_; }        // [N] over all presses

 private:
  void let_go(TissueModel& tissue);

  std::vector<double> puncture_force_;
  Phase phase_ = Phase::Free;
  std::vector<NodeId> stuck_;
  std::vector<Vec3> stuck_at_;  // their positions at the touch
  Vec3 tip_at_ = Vec3::Zero();  // the tip at the touch
  Vec3 point_ = Vec3::Zero(), normal_ = Vec3::UnitZ();
  double touched_ = 0, threshold_ = 0;
  int region_ = -1;
  Vec3 force_ = Vec3::Zero();
  double normal_force_ = 0, depth_ = 0, stiffness_ = 0, max_force_ = 0;
  std::vector<PunctureEvent> punctures_;
  std::size_t presses_ = 0, lifted_ = 0, unpressed_ = 0;
};

}  // namespace scalpel
