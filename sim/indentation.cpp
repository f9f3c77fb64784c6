#include "sim/indentation.hpp"

#include <algorithm>
#include <limits>

namespace scalpel {

namespace {

// Below this depth the force over depth is noise: the stiffness keeps its last value.
constexpr double kMinStiffnessDepth = 1e-5;  // [m]

}  // namespace

double sharp_load(const BladePose& blade, const Vec3& force, const Vec3& push) {
  const Vec3 axis = blade.tip - blade.back;
  if (!(axis.norm() > 0.0) || !(push.norm() > 0.0)) return 0.0;
  const Vec3 p = push.normalized();
  const double resistance = -force.dot(p);
  const double faces = blade.cutting_direction.isZero()
                           ? 1.0
                           : std::max(p.dot(axis.normalized()), p.dot(blade.cutting_direction.normalized()));
  return std::max(0.0, resistance) * std::clamp(faces, 0.0, 1.0);
}

Indentation::Indentation(std::vector<double> puncture_force) : puncture_force_(std::move(puncture_force)) {}

void Indentation::touch(std::span<const std::uint32_t> face, const Vec3& tip, const Vec3& point,
                        const Vec3& normal, double t, const TetMesh& mesh, TissueModel& tissue) {
  ++presses_;
  stuck_.clear();
  stuck_at_.clear();
  threshold_ = std::numeric_limits<double>::infinity();
  region_ = -1;
  for (const std::uint32_t slot : face) {
    const NodeId n = mesh.node_handle(slot);
    if (tissue.prescribed(n)) continue;
    stuck_.push_back(n);
    stuck_at_.push_back(mesh.position(n));
    tissue.set_held(n);
    // The weakest region around the stuck nodes gives way first.
    for (const std::uint32_t tet : mesh.node_tets(n)) {
      const int r = mesh.region(mesh.tet_handle(tet));
      const double f = r >= 0 && static_cast<std::size_t>(r) < puncture_force_.size()
                           ? puncture_force_[static_cast<std::size_t>(r)]
                           : std::numeric_limits<double>::infinity();
      if (f < threshold_) {
        threshold_ = f;
        region_ = r;
      }
    }
  }
  tip_at_ = tip;
  point_ = point;
  normal_ = normal.normalized();
  touched_ = t;
  force_.setZero();
  normal_force_ = depth_ = stiffness_ = 0;
  phase_ = stuck_.empty() ? Phase::Cutting : Phase::Pressing;
}

void Indentation::follow(const Vec3& tip, TetMesh& mesh) const {
  if (phase_ != Phase::Pressing) return;
  // Along the normal only: the skin does not stick to the blade sideways (frictionless), and inwards
  // only: a blade drawn back above where it touched does not pull the skin out after it.
  const Vec3 moved = std::min(0.0, (tip - tip_at_).dot(normal_)) * normal_;
  for (std::size_t i = 0; i < stuck_.size(); ++i) {
    mesh.positions()[stuck_[i].index] = stuck_at_[i] + moved;
    mesh.velocities()[stuck_[i].index].setZero();
  }
}

Indentation::Phase Indentation::settle(double t, const BladePose& blade, TissueModel& tissue) {
  if (phase_ != Phase::Pressing) return phase_;
  force_ = tissue.load_on_holder(stuck_);
  normal_force_ = force_.dot(normal_);
  depth_ = (tip_at_ - blade.tip).dot(normal_);
  if (depth_ > kMinStiffnessDepth && normal_force_ > 0) stiffness_ = normal_force_ / depth_;
  max_force_ = std::max(max_force_, normal_force_);
  // Lifted off: the tip drawn back above where it touched, or the tissue no longer pushing a blade
  // that has pressed it in (drawn back faster than the skin follows). A tip still where it touched
  // rests on the skin whatever the sign of the load at rest (prestress, the solve's tolerance).
  const bool withdrawn = depth_ < 0.0;
  const bool separated = !(normal_force_ > 0.0) && depth_ > kMinStiffnessDepth;
  if (withdrawn || separated) {
    ++lifted_;
    let_go(tissue);
    phase_ = Phase::Free;
    return phase_;
  }
  const double sharp = sharp_load(blade, force_, -normal_);  // the push is along the normal
  if (sharp >= threshold_) {
    punctures_.push_back({.t = t,
                          .touched = touched_,
                          .depth = depth_,
                          .force = normal_force_,
                          .sharp = sharp,
                          .threshold = threshold_,
                          .region = region_,
                          .point = point_});
    let_go(tissue);
    phase_ = Phase::Cutting;
  }
  return phase_;
}

void Indentation::let_go(TissueModel& tissue) {
  for (const NodeId n : stuck_) tissue.set_held(n, false);
  stuck_.clear();
  stuck_at_.clear();
}

}  // namespace scalpel
