#include "sim/snapshot.hpp"

#include <algorithm>
#include <cmath>

#include "mesh/topology.hpp"
#include "sim/simulation.hpp"

namespace scalpel {

namespace {

std::array<float, 3> to_float(const Vec3& v) {
  return {static_cast<float>(v.x()), static_cast<float>(v.y()), static_cast<float>(v.z())};
}

// A rest point this close to a face's plane, relative to the face's size, lies on it: cut nodes on
// an outer face are interpolated from its corners, so they are off its plane by rounding only.
constexpr double kOnFaceTolerance = 1e-9;

}  // namespace

SnapshotBuilder::SnapshotBuilder(const TetMesh& uncut) {
  boundary_index_.assign(uncut.tet_capacity(), kInvalidIndex);
  bool first = true;
  for (std::uint32_t t = 0; t < uncut.tet_capacity(); ++t) {
    if (!uncut.tet_slot_alive(t)) continue;
    Original o;
    const auto& v = uncut.tet_vertex_indices(t);
    for (int i = 0; i < 4; ++i) {
      const Vec3& p = uncut.rest_positions()[v[static_cast<size_t>(i)]];
      o.corners[static_cast<size_t>(i)] = p;
      bounds_min_ = first ? p : Vec3(bounds_min_.cwiseMin(p));
      bounds_max_ = first ? p : Vec3(bounds_max_.cwiseMax(p));
      first = false;
    }
    const TetId h = uncut.tet_handle(t);
    for (int f = 0; f < 4; ++f)
      if (uncut.neighbour(h, f).is_null()) o.boundary_faces |= static_cast<std::uint8_t>(1u << f);
    if (o.boundary_faces == 0) continue;
    boundary_index_[t] = static_cast<std::uint32_t>(boundary_.size());
    boundary_.push_back(o);
  }
}

bool SnapshotBuilder::on_outer_surface(std::uint32_t parent, const Vec3& a, const Vec3& b,
                                       const Vec3& c) const {
  if (parent >= boundary_index_.size() || boundary_index_[parent] == kInvalidIndex) return false;
  const Original& o = boundary_[boundary_index_[parent]];
  for (int f = 0; f < 4; ++f) {
    if (!(o.boundary_faces & (1u << f))) continue;
    const auto& fv = kFaceVertices[static_cast<size_t>(f)];
    const Vec3& p0 = o.corners[static_cast<size_t>(fv[0])];
    const Vec3 n =
        (o.corners[static_cast<size_t>(fv[1])] - p0).cross(o.corners[static_cast<size_t>(fv[2])] - p0);
    const double size = std::sqrt(n.norm());  // about an edge length
    if (size == 0.0) continue;
    const double limit = kOnFaceTolerance * size * n.norm();
    if (std::abs(n.dot(a - p0)) <= limit && std::abs(n.dot(b - p0)) <= limit &&
        std::abs(n.dot(c - p0)) <= limit)
      return true;
  }
  return false;
}

void SnapshotBuilder::fill_surface(const TetMesh& mesh, bool with_edges, FrameSnapshot& out) const {
  out.surface.clear();
  out.edges.clear();
  std::vector<SurfaceVertex>& s = out.surface;
  out.triangle_piece.clear();
  out.edge_piece.clear();
  out.pieces.clear();
  // Pieces: node_pieces() labels, numbered in the slot order of their first tetrahedron.
  // Tallied as Simulation::move_piece tallies the piece it turns, so both turn about one point.
  std::vector<std::uint32_t> label, index;
  if (pieces_) {
    label = node_pieces(mesh);
    index.assign(label.size(), kInvalidIndex);
    std::vector<PieceTally> tallies;
    for (std::uint32_t t = 0; t < mesh.tet_capacity(); ++t) {
      if (!mesh.tet_slot_alive(t)) continue;
      std::uint32_t& i = index[label[mesh.tet_vertex_indices(t)[0]]];
      if (i == kInvalidIndex) {
        i = static_cast<std::uint32_t>(tallies.size());
        tallies.emplace_back();
      }
      tallies[i].add(mesh, t);
    }
    for (const PieceTally& p : tallies) out.pieces.push_back({p.centroid(), p.volume, p.tets});
  }
  const auto piece_of = [&](std::uint32_t node) { return index[label[node]]; };
  const std::vector<double>* field = field_id_ >= 0 ? &mesh.field_values(field_id_) : nullptr;
  out.field = field_;
  // Two passes over the boundary faces, wound first, so a renderer can draw the kinds apart.
  const auto& x = mesh.positions();
  const auto& rest = mesh.rest_positions();
  for (int pass = 0; pass < 2; ++pass) {
    for (std::uint32_t t = 0; t < mesh.tet_capacity(); ++t) {
      if (!mesh.tet_slot_alive(t)) continue;
      const TetId h = mesh.tet_handle(t);
      for (int f = 0; f < 4; ++f) {
        if (!mesh.neighbour(h, f).is_null()) continue;
        const auto v = face_vertex_indices(mesh, t, f);
        const bool skin = on_outer_surface(mesh.parent(h), rest[v[0]], rest[v[1]], rest[v[2]]);
        if (skin != (pass == 1)) continue;
        const Vec3 n = (x[v[1]] - x[v[0]]).cross(x[v[2]] - x[v[0]]).normalized();
        const float region = skin ? static_cast<float>(mesh.region(h)) : SurfaceVertex::kWoundRegion;
        for (const std::uint32_t i : v) {
          const float value = field ? static_cast<float>((*field)[i]) : 0.0f;
          s.push_back({to_float(x[i]), to_float(n), region, value});
        }
        if (pieces_) out.triangle_piece.push_back(piece_of(v[0]));
      }
    }
    if (pass == 0) out.wound_vertices = s.size();
  }
  if (with_edges) {
    // An edge is listed by the tetrahedron with the lowest slot among those holding it.
    for (std::uint32_t t = 0; t < mesh.tet_capacity(); ++t) {
      if (!mesh.tet_slot_alive(t)) continue;
      const auto& v = mesh.tet_vertex_indices(t);
      for (const auto& e : kEdgeVertices) {
        const std::uint32_t a = v[static_cast<size_t>(e[0])], b = v[static_cast<size_t>(e[1])];
        const NodeId ha = mesh.node_handle(a);
        bool first = true;
        for (const std::uint32_t u : mesh.node_tets(ha)) {
          if (u >= t) continue;
          const auto& w = mesh.tet_vertex_indices(u);
          if (std::find(w.begin(), w.end(), b) != w.end()) {
            first = false;
            break;
          }
        }
        if (!first) continue;
        out.edges.push_back(to_float(x[a]));
        out.edges.push_back(to_float(x[b]));
        if (pieces_) out.edge_piece.push_back(piece_of(a));
      }
    }
  }
  out.nodes = mesh.node_count();
  out.tetrahedra = mesh.tet_count();
  out.bounds_min = bounds_min_;
  out.bounds_max = bounds_max_;
}

void SnapshotBuilder::fill(const Simulation& sim, bool with_edges, FrameSnapshot& out) const {
  fill_surface(sim.mesh(), with_edges, out);
  out.time = sim.time();
  out.has_blade = sim.samples() > 0;
  if (out.has_blade) {
    const BladePose b = sim.blade(sim.last_sample());
    out.blade_back = b.back;
    out.blade_tip = b.tip;
    const ToolBodySize size = sim.body_size();
    const ToolBody body(b, size);
    out.blade_spine =
        body.has_flats() ? Vec3(body.world({0.0, size.blade_width, 0.0}) - b.back) : Vec3::Zero();
    out.handle_radius = size.handle_radius;
    out.handle_length = size.handle_length;
  }
  out.targets.clear();
  if (const auto& task = sim.scenario().task)
    for (const Incision& in : task->incisions) out.targets.push_back({in.path, in.tolerance});
}

}  // namespace scalpel
