#include "sim/tool_body.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace scalpel {

namespace {

// The side of the flats a copy of a cut node is on: its lip's. Its crack faces (boundary faces
// whose three nodes are all cut nodes) face the other lip, across the blade. +1 or -1, or 0 when
// they do not clearly face across it (none yet: the crack has not opened there).
double lip_side(const TetMesh& mesh, NodeId n, const std::vector<std::uint8_t>& cut, const Vec3& plane_normal,
                double* crack_area = nullptr) {
  double across = 0.0, area = 0.0;
  const auto& x = mesh.positions();
  for (const std::uint32_t t : mesh.node_tets(n)) {
    const TetId tet = mesh.tet_handle(t);
    const auto& v = mesh.tet_vertex_indices(t);
    for (int f = 0; f < 4; ++f) {
      if (v[static_cast<std::size_t>(f)] == n.index || !mesh.neighbour(tet, f).is_null()) continue;
      const auto face = face_vertex_indices(mesh, t, f);
      if (!cut[face[0]] || !cut[face[1]] || !cut[face[2]]) continue;
      const Vec3 a = (x[face[1]] - x[face[0]]).cross(x[face[2]] - x[face[0]]);
      across += a.dot(plane_normal);
      area += a.norm();
    }
  }
  if (crack_area != nullptr) *crack_area = area;
  // Outward normals face away from the node's own tissue: the node lies on the other side.
  if (!(std::abs(across) >= kLipAcross * area) || !(area > 0.0)) return 0.0;
  return across > 0.0 ? -1.0 : 1.0;
}

}  // namespace

ToolBody::ToolBody(const BladePose& blade, const ToolBodySize& size) : size_(size), back_(blade.back) {
  const Vec3 along = blade.tip - blade.back;
  length_ = along.norm();
  if (length_ > 0.0) axis_ = along / length_;
  Vec3 edge = blade.cutting_direction - blade.cutting_direction.dot(axis_) * axis_;
  flats_ = size.blade_width > 0.0 && length_ > 0.0 && edge.norm() > 1e-9;
  if (flats_) {
    edge.normalize();
    spine_ = -edge;
    n_ = axis_.cross(edge);
  }
}

ToolBody::Local ToolBody::local(const Vec3& x) const {
  const Vec3 r = x - back_;
  return {r.dot(axis_), r.dot(spine_), r.dot(n_)};
}

Vec3 ToolBody::world(const Local& l) const {
  return back_ + l.s * axis_ + l.w * spine_ + l.d * n_;
}

bool ToolBody::over_flats(const Local& l) const {
  // The spine runs from `width` behind the edge at the back point to the tip.
  return flats_ && l.s >= 0.0 && l.s <= length_ && l.w >= 0.0 &&
         l.w <= size_.blade_width * (1.0 - l.s / length_);
}

ToolBody::Exit ToolBody::handle_nearest(const Vec3& x, double& distance) const {
  // The capsule's axis runs away from the tip, from one radius above the back point to one radius
  // short of the handle's length: its rounded ends reach the back point and the length.
  const double r = size_.handle_radius;
  const Vec3 a = back_ - r * axis_, b = back_ - (size_.handle_length - r) * axis_;
  const Vec3 ab = b - a;
  const double u = std::clamp((x - a).dot(ab) / std::max(ab.squaredNorm(), 1e-300), 0.0, 1.0);
  const Vec3 c = a + u * ab;
  const Vec3 off = x - c;
  distance = off.norm();
  // On the axis itself any direction across it is as near: the one across the blade's plane.
  const Vec3 out = distance > 0.0 ? Vec3(off / distance) : n_;
  return Exit{c + r * out, out};
}

std::optional<ToolBody::Exit> ToolBody::handle_exit(const Vec3& x, double slack) const {
  if (!has_handle()) return std::nullopt;
  double distance = 0;
  const Exit e = handle_nearest(x, distance);
  if (!(distance < size_.handle_radius + slack)) return std::nullopt;
  return e;
}

Vec3 ToolBody::handle_normal(const Vec3& x) const {
  double distance = 0;
  return handle_nearest(x, distance).normal;
}

void ToolBody::bounds(Vec3& lo, Vec3& hi) const {
  lo = hi = back_;
  const auto add = [&](const Vec3& p, double pad) {
    lo = lo.cwiseMin(p - Vec3::Constant(pad));
    hi = hi.cwiseMax(p + Vec3::Constant(pad));
  };
  const Vec3 tip = back_ + length_ * axis_;
  add(tip, 0.0);
  if (flats_) add(back_ + size_.blade_width * spine_, 0.0);
  if (has_handle()) add(back_ - (size_.handle_length - size_.handle_radius) * axis_, size_.handle_radius);
}

bool BodyContact::put_back(const ToolBody& body, Held& h, TetMesh& mesh) const {
  Vec3& x = mesh.positions()[h.node.index];
  // A held node lies kFlatClearance off the body; the body has moved away from it only once it
  // is twice that off: a node the body leaves where it put it stays held.
  if (h.handle) {
    const auto exit = body.handle_exit(x, 2.0 * kFlatClearance);
    if (!exit) return false;
    x = exit->point + kFlatClearance * exit->normal;
  } else {
    const ToolBody::Local l = body.local(x);
    // Slid off the flats, or the flats have moved away from it.
    if (!body.over_flats(l) || h.side * l.d > 2.0 * kFlatClearance) return false;
    x = body.world({l.s, l.w, h.side * kFlatClearance});
  }
  mesh.velocities()[h.node.index].setZero();
  return true;
}

void BodyContact::let_go(std::size_t i, const TetMesh& mesh, TissueModel& tissue) {
  if (mesh.alive(held_nodes_[i].node)) tissue.set_held(held_nodes_[i].node, false);
  held_nodes_.erase(held_nodes_.begin() + static_cast<std::ptrdiff_t>(i));
}

void BodyContact::follow(const BladePose& blade, TetMesh& mesh, TissueModel& tissue) {
  const ToolBody body(blade, size_);
  for (std::size_t i = held_nodes_.size(); i-- > 0;) {
    Held& h = held_nodes_[i];
    if (!mesh.alive(h.node) || !put_back(body, h, mesh)) {
      let_go(i, mesh, tissue);
      continue;
    }
    // The edge's drag on the tissue (Simulation::push_tissue) does not move a held node: it is
    // not part of what the node presses on the body.
    tissue.set_external_force(h.node, Vec3::Zero());
  }
}

Vec3 BodyContact::settle(const BladePose& blade, std::span<const NodeId> cut_copies, TetMesh& mesh,
                         TissueModel& tissue) {
  const ToolBody body(blade, size_);
  for (std::size_t i = held_nodes_.size(); i-- > 0;)
    if (!mesh.alive(held_nodes_[i].node)) let_go(i, mesh, tissue);
  // Nodes that passed through the flats or are inside the handle: put back and held.
  Vec3 lo, hi;
  body.bounds(lo, hi);
  const auto& x = mesh.positions();
  if (side_.size() < x.size()) {
    side_.resize(x.size(), std::numeric_limits<double>::quiet_NaN());
    side_generation_.resize(x.size(), 0);
  }
  // A slot a new node has taken since (a cut node's copy, say) has no side yet.
  const auto side_of = [&](std::uint32_t i) {
    return side_generation_[i] == mesh.node_handle(i).generation ? side_[i]
                                                                 : std::numeric_limits<double>::quiet_NaN();
  };
  cut_.assign(x.size(), 0);
  for (const NodeId c : cut_copies)
    if (mesh.alive(c)) cut_[c.index] = 1;
  for (std::uint32_t i = 0; i < x.size(); ++i) {
    if (!mesh.node_slot_alive(i)) continue;
    const NodeId n = mesh.node_handle(i);
    if (tissue.prescribed(n)) continue;  // fixed, held by the press, or held already
    Held h{n, false, 0.0};
    if (body.has_flats()) {
      const ToolBody::Local l = body.local(x[i]);
      if (body.over_flats(l)) {
        // A lip's node is on its lip's side (none while the crack is closed there: the tissue
        // may have carried it across the plane before it opened); any other on the side it was on.
        double side = 0.0;
        if (cut_[i]) {
          side = lip_side(mesh, n, cut_, body.normal());
        } else {
          const double before = side_of(i);
          side = before > 0.0 ? 1.0 : before < 0.0 ? -1.0 : 0.0;
        }
        if (side * l.d < 0.0) h.side = side;
      }
    }
    if (h.side == 0.0) {
      // A node that crossed the flats has passed them by however far the frame moved it; the
      // handle only holds what lies in its box.
      const bool near = (x[i] - lo).minCoeff() >= 0.0 && (hi - x[i]).minCoeff() >= 0.0;
      if (!near || !body.handle_exit(x[i])) continue;
      // A cut node whose crack has not opened is in tissue the blade is still cutting: the
      // cutter places it, on the blade, whose back point the handle's end touches.
      double crack_area = 0.0;
      if (cut_[i] && (lip_side(mesh, n, cut_, body.normal(), &crack_area), !(crack_area > 0.0))) continue;
      h.handle = true;
    }
    if (!put_back(body, h, mesh)) continue;
    tissue.set_held(n);
    tissue.set_external_force(n, Vec3::Zero());
    held_nodes_.push_back(h);
    ++stats_.pushes;
  }
  // The force on the body: what each held node presses on it, those just put back included. One
  // the tissue pulls away (its load points out of the body) is let go and carries none.
  force_.setZero();
  for (std::size_t i = held_nodes_.size(); i-- > 0;) {
    const Held& h = held_nodes_[i];
    const NodeId one[1] = {h.node};
    const Vec3 load = tissue.load_on_holder(one);
    const Vec3& at = mesh.position(h.node);
    const Vec3 out = h.handle ? body.handle_normal(at) : Vec3(h.side * body.normal());
    if (!(load.dot(out) < 0.0)) {
      let_go(i, mesh, tissue);
      continue;
    }
    force_ += load;
  }
  // Each node's side for the next frame. Nearer the plane than kSideBand, a node over the flats
  // keeps the side it had (the flats hold it there); elsewhere it has none.
  if (body.has_flats())
    for (std::uint32_t i = 0; i < x.size(); ++i) {
      if (!mesh.node_slot_alive(i)) continue;
      const ToolBody::Local l = body.local(x[i]);
      if (std::abs(l.d) >= kSideBand || !body.over_flats(l) || std::isnan(side_of(i))) {
        side_[i] = std::abs(l.d) >= kSideBand ? l.d : 0.0;
        side_generation_[i] = mesh.node_handle(i).generation;
      }
    }
  stats_.max_held = std::max(stats_.max_held, held_nodes_.size());
  stats_.max_force = std::max(stats_.max_force, force_.norm());
  stats_.frames_in_contact += held_nodes_.empty() ? 0 : 1;
  return force_;
}

}  // namespace scalpel
