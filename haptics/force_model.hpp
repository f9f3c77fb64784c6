// The force model the simulation publishes at its visual rate and the haptic loop renders at 1 kHz
// (docs/threads.md): a local model of the contact, valid between two simulation frames, in the
// manner of the intermediate representation of Adachi et al. 1995, so the 1 kHz force follows the
// device even though the simulation answers at 60 Hz.
//
// Rendered force on the tool [N], x the tool position, v its velocity:
//   coupling (virtual coupling, Colgate et al. 1995):  k_c (x_c - x) + b_c (v_c - v)
//   contact (a penalty plane, n the outward tissue normal, the tissue where n.x < d):
//                                                      k_s max(0, d - n.x) n
//   cutting resistance (against the blade's motion):   -R v / max(|v|, v_eps)
//   the tool's body (flats, handle) on the tissue:      max(0, F_b + k_b n_b.(x_b - x)) n_b
// The simulation sets k_c to zero while the tool is free. The sum is clamped to the device's force
// limit and rate-limited; it is zero on a device fault, before any model, and while the
// simulation stalls.
//
// Passivity (Hannaford & Ryu 2002, "Time-domain passivity control of haptic interfaces", IEEE
// Trans. Robot. Autom. 18(1)): a wall of stiffness k sampled at period T with a zero-order hold is
// passive only on a device whose own damping b exceeds k T / 2 (Colgate & Schenkel 1997), and the
// local model changes at every frame. Neither is known to hold, so the renderer observes the energy
// that has flowed from the hand into the rendered environment,
//   E_k = - sum_{j<k} f_j . (x_{j+1} - x_j),
// exact for forces held over each cycle, and when E_k < 0 (the environment has given back more than
// it received) adds a damper along the velocity that dissipates -E_k over the next cycle. The
// observer sees the force actually sent, after the limits, so whatever the limits change is
// accounted for too.
#pragma once

#include <algorithm>
#include <cstdint>
#include <type_traits>

#include <Eigen/Core>

#include "base/triple_buffer.hpp"

namespace scalpel {

// Plain data (fixed-size Eigen vectors, no pointers): copied whole through the channel.
struct ForceModel {
  // v_eps [m/s]: below it the cutting resistance fades with the speed instead of flipping with the
  // velocity's noise.
  static constexpr double kCutSpeedFloor = 0.01;

  std::uint64_t sequence = 0;  // increases with every publication; 0 before the first
  double t = 0.0;              // [s] simulation time it was computed for

  double coupling_stiffness = 0.0;                                 // k_c [N/m]
  double coupling_damping = 0.0;                                   // b_c [N s/m]
  Eigen::Vector3d constrained_position = Eigen::Vector3d::Zero();  // x_c [m]
  Eigen::Vector3d constrained_velocity = Eigen::Vector3d::Zero();  // v_c [m/s]

  bool contact = false;
  Eigen::Vector3d contact_normal = Eigen::Vector3d::UnitY();  // n, unit, out of the tissue
  double contact_offset = 0.0;                                // d [m]: the plane n.x = d
  double contact_stiffness = 0.0;                             // k_s [N/m]

  double cutting_resistance = 0.0;  // R [N], 0 while not cutting

  // The tissue's push on the blade's flats and the handle (sim/tool_body.hpp): F_b [N] along the
  // unit n_b as the last full solve gave it with the tool at x_b [m], growing by k_b [N/m] as the
  // tool moves against n_b. F_b = 0: none.
  double body_force = 0.0;
  Eigen::Vector3d body_normal = Eigen::Vector3d::UnitZ();
  double body_stiffness = 0.0;
  Eigen::Vector3d body_position = Eigen::Vector3d::Zero();

  // [N] The model's force at tool position x moving at v, before the device's limits and the
  // passivity controller: the sum above.
  [[nodiscard]] Eigen::Vector3d environment_force(const Eigen::Vector3d& x, const Eigen::Vector3d& v) const {
    Eigen::Vector3d f =
        coupling_stiffness * (constrained_position - x) + coupling_damping * (constrained_velocity - v);
    if (contact) f += contact_force(x) * contact_normal;
    f += body_force_at(x);
    if (cutting_resistance > 0.0) f -= cutting_resistance * v / std::max(v.norm(), kCutSpeedFloor);
    return f;
  }

  // [N] The body's force at tool position x: max(0, F_b + k_b n_b.(x_b - x)) n_b.
  [[nodiscard]] Eigen::Vector3d body_force_at(const Eigen::Vector3d& x) const {
    if (!(body_force > 0.0)) return Eigen::Vector3d::Zero();
    return std::max(0.0, body_force + body_stiffness * body_normal.dot(body_position - x)) * body_normal;
  }

  // [N] The contact's force along contact_normal at tool position x: k_s max(0, d - n.x); 0 without
  // contact.
  [[nodiscard]] double contact_force(const Eigen::Vector3d& x) const {
    if (!contact) return 0.0;
    const double depth = contact_offset - contact_normal.dot(x);  // [m]
    return depth > 0.0 ? contact_stiffness * depth : 0.0;
  }
};

// Simulation thread publishes, haptic thread reads; wait-free both ways.
using ForceChannel = TripleBuffer<ForceModel>;

struct ForceLimits {
  double max_force = 0.0;         // [N] magnitude
  double max_force_rate = 0.0;    // [N/s] magnitude of the change
  bool passivity_control = true;  // the observer and its damper (see above); off only in tests
};

// The force rendering of one haptic cycle. Deterministic; one instance per haptic thread.
class ForceRenderer {
 public:
  ForceRenderer(ForceLimits limits, double rate);

  // Tool position x [m] of this cycle; `model` null when there is none, `enabled` false on a device
  // fault or a stalled simulation (the force drops to zero at once, and ramps up again afterwards).
  Eigen::Vector3d render(const Eigen::Vector3d& x, const ForceModel* model, bool enabled) noexcept;
  // Forget the velocity estimate (after a gap in the tool's motion).
  void reset_motion() noexcept { has_x_ = false; }

  [[nodiscard]] const Eigen::Vector3d& velocity() const { return v_; }  // [m/s] filtered estimate
  // E_k [J] of the passivity observer: the energy the hand has put into the rendered environment.
  [[nodiscard]] double observed_energy() const { return energy_; }
  // Cycles in which the passivity controller's damper acted.
  [[nodiscard]] std::uint64_t damped_cycles() const { return damped_cycles_; }

  static constexpr double kVelocityCutoff = 50.0;  // [Hz] first-order low-pass on the velocity
  static constexpr double kCutSpeedFloor = ForceModel::kCutSpeedFloor;  // v_eps [m/s]
  // [N s/m] The passivity controller's damper at most: 2 m / T for the lightest styli (m about
  // 0.02-0.05 kg at the tip, T = 1 ms) is 40-100 N s/m, and a held damper must stay below it.
  static constexpr double kMaxPassivityDamping = 20.0;

 private:
  ForceLimits limits_;
  double dt_;     // [s]
  double alpha_;  // low-pass gain per cycle
  Eigen::Vector3d x_prev_ = Eigen::Vector3d::Zero();
  bool has_x_ = false;
  Eigen::Vector3d v_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d f_ = Eigen::Vector3d::Zero();  // last force sent [N]
  double energy_ = 0.0;                          // E_k [J]
  std::uint64_t damped_cycles_ = 0;
};

}  // namespace scalpel
