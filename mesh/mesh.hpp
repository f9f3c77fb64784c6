// Dynamic tetrahedral mesh (docs/architecture.md).
//
// Nodes and tetrahedra live in slot arrays with free lists. A handle is (index, generation): a
// slot's generation is bumped when it is freed, so a stale handle is detected, never followed.
//
// Local conventions, fixed for the whole code base:
//   tet vertices v0..v3 are positively oriented: det[v1-v0, v2-v0, v3-v0] > 0 (orient3d > 0);
//   local face f is the face opposite vertex f, its vertices in kFaceVertices[f], ordered so that
//   the face normal (by the right-hand rule) points out of the tetrahedron;
//   neighbour(t, f) is the tetrahedron across local face f, or an invalid handle on the boundary.
#pragma once

#include <array>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace scalpel {

using Vec3 = Eigen::Vector3d;

inline constexpr std::uint32_t kInvalidIndex = std::numeric_limits<std::uint32_t>::max();

// A stable reference to a slot; `generation` tells a reused slot from the one the handle named.
template <class Tag>
struct Handle {
  std::uint32_t index = kInvalidIndex;
  std::uint32_t generation = 0;

  [[nodiscard]] bool is_null() const { return index == kInvalidIndex; }
  friend bool operator==(Handle, Handle) = default;
  friend auto operator<=>(Handle, Handle) = default;
};
struct NodeTag {};
struct TetTag {};
using NodeId = Handle<NodeTag>;
using TetId = Handle<TetTag>;

// Outward-oriented vertex triples of the local faces (face f is opposite vertex f).
inline constexpr std::array<std::array<int, 3>, 4> kFaceVertices = {
    {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}}};
// The six local edges (i < j); edge e joins kEdgeVertices[e][0] and kEdgeVertices[e][1].
inline constexpr std::array<std::array<int, 2>, 6> kEdgeVertices = {
    {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}}};

// Volume of the tetrahedron abcd, positive when it is positively oriented [m^3].
[[nodiscard]] inline double signed_volume(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  return (b - a).dot((c - a).cross(d - a)) / 6.0;
}

// One node created by interpolation: value = sum(weights[i] * parents[i]).
struct NodeParents {
  std::array<NodeId, 3> parents{};
  std::array<double, 3> weights{};
  int count = 0;
};

class TetMesh {
 public:
  TetMesh() = default;

  // ---- nodes -------------------------------------------------------------------------------
  NodeId add_node(const Vec3& rest, const Vec3& current);
  NodeId add_node(const Vec3& rest) { return add_node(rest, rest); }
  // Interpolates rest, current position, velocity and every field from the parents (edge: 2,
  // face: 3 parents with barycentric weights).
  NodeId add_interpolated_node(const NodeParents& p);
  // A node can be removed only when no tetrahedron uses it.
  void remove_node(NodeId n);
  [[nodiscard]] bool alive(NodeId n) const;
  [[nodiscard]] NodeId node_handle(std::uint32_t index) const;  // null if the slot is free

  [[nodiscard]] const Vec3& rest(NodeId n) const { return rest_[check(n)]; }
  [[nodiscard]] const Vec3& position(NodeId n) const { return pos_[check(n)]; }
  [[nodiscard]] const Vec3& velocity(NodeId n) const { return vel_[check(n)]; }
  void set_rest(NodeId n, const Vec3& x) { rest_[check(n)] = x; }
  void set_position(NodeId n, const Vec3& x) { pos_[check(n)] = x; }
  void set_velocity(NodeId n, const Vec3& v) { vel_[check(n)] = v; }
  // Tetrahedra incident to a node (slot indices), unordered.
  [[nodiscard]] const std::vector<std::uint32_t>& node_tets(NodeId n) const { return node_tets_[check(n)]; }

  // Raw slot arrays, indexed by NodeId::index; entries of free slots are meaningless.
  [[nodiscard]] const std::vector<Vec3>& rest_positions() const { return rest_; }
  [[nodiscard]] const std::vector<Vec3>& positions() const { return pos_; }
  [[nodiscard]] std::vector<Vec3>& positions() { return pos_; }
  [[nodiscard]] std::vector<Vec3>& velocities() { return vel_; }
  [[nodiscard]] const std::vector<Vec3>& velocities() const { return vel_; }

  // ---- per-node scalar fields ----------------------------------------------------------------
  // Returns the field's id; an existing field of that name keeps its values.
  int add_field(const std::string& name, double initial = 0.0);
  [[nodiscard]] int field_id(const std::string& name) const;  // -1 if absent
  [[nodiscard]] const std::vector<std::string>& field_names() const { return field_names_; }
  [[nodiscard]] double field(int id, NodeId n) const { return fields_[static_cast<size_t>(id)][check(n)]; }
  // A field's raw slot array, indexed by NodeId::index; entries of free slots are meaningless.
  [[nodiscard]] const std::vector<double>& field_values(int id) const {
    return fields_[static_cast<size_t>(id)];
  }
  void set_field(int id, NodeId n, double v) { fields_[static_cast<size_t>(id)][check(n)] = v; }
  // Sets every field of n to the weighted sum of its parents' values (a node the cutter moves to
  // new weights takes the fields at its new rest position).
  void interpolate_fields(NodeId n, const NodeParents& p);

  // ---- tetrahedra ----------------------------------------------------------------------------
  // Adds a tetrahedron and links it to the neighbours that share its faces. The vertex order must
  // be positively oriented in the rest configuration (checked by validate(), not here).
  TetId add_tet(const std::array<NodeId, 4>& nodes, int region = 0);
  // Room for this many node and tetrahedron slots without reallocating (a later add then costs
  // O(1), not a copy of every array).
  void reserve(std::size_t nodes, std::size_t tets);
  void remove_tet(TetId t);
  [[nodiscard]] bool alive(TetId t) const;
  [[nodiscard]] TetId tet_handle(std::uint32_t index) const;  // null if the slot is free

  [[nodiscard]] std::array<NodeId, 4> tet_nodes(TetId t) const;
  [[nodiscard]] NodeId tet_node(TetId t, int local) const;
  [[nodiscard]] int region(TetId t) const { return region_[check(t)]; }
  void set_region(TetId t, int r) { region_[check(t)] = r; }
  // The tetrahedron of the original mesh this one descends from (itself for original ones).
  [[nodiscard]] std::uint32_t parent(TetId t) const { return parent_[check(t)]; }
  void set_parent(TetId t, std::uint32_t p) { parent_[check(t)] = p; }
  [[nodiscard]] TetId neighbour(TetId t, int face) const;
  // The local face of `neighbour(t, face)` that is shared with t.
  [[nodiscard]] int neighbour_face(TetId t, int face) const;

  // ---- counts and iteration ------------------------------------------------------------------
  [[nodiscard]] std::size_t node_count() const { return node_count_; }
  [[nodiscard]] std::size_t tet_count() const { return tet_count_; }
  [[nodiscard]] std::size_t node_capacity() const { return rest_.size(); }
  [[nodiscard]] std::size_t tet_capacity() const { return tet_nodes_.size(); }
  // Live handles, in slot order (deterministic).
  [[nodiscard]] std::vector<NodeId> nodes() const;
  [[nodiscard]] std::vector<TetId> tets() const;
  // Vertex slot indices of slot t (no liveness check), for tight loops.
  [[nodiscard]] const std::array<std::uint32_t, 4>& tet_vertex_indices(std::uint32_t t) const {
    return tet_nodes_[t];
  }
  [[nodiscard]] bool tet_slot_alive(std::uint32_t t) const { return t < tet_alive_.size() && tet_alive_[t]; }
  [[nodiscard]] bool node_slot_alive(std::uint32_t n) const {
    return n < node_alive_.size() && node_alive_[n];
  }

  // ---- geometry ------------------------------------------------------------------------------
  [[nodiscard]] double rest_volume(TetId t) const;
  [[nodiscard]] double current_volume(TetId t) const;
  [[nodiscard]] double total_rest_volume() const;
  // Bytes held by the mesh's arrays (capacity, not size), for the memory benchmark.
  [[nodiscard]] std::size_t memory_bytes() const;

 private:
  [[nodiscard]] std::uint32_t check(NodeId n) const;
  [[nodiscard]] std::uint32_t check(TetId t) const;
  void link_faces(std::uint32_t t);

  // Node slots. Each node's incident tets drive adjacency: faces are matched through them.
  std::vector<Vec3> rest_, pos_, vel_;
  std::vector<std::uint32_t> node_gen_;
  std::vector<std::uint8_t> node_alive_;
  std::vector<std::vector<std::uint32_t>> node_tets_;
  std::vector<std::uint32_t> free_nodes_;
  std::size_t node_count_ = 0;
  std::vector<std::string> field_names_;
  std::vector<std::vector<double>> fields_;

  // Tet slots: #T by 4 vertex indices; #T by 4 neighbour slot (kInvalidIndex on the boundary).
  std::vector<std::array<std::uint32_t, 4>> tet_nodes_;
  std::vector<std::array<std::uint32_t, 4>> tet_adj_;
  std::vector<std::uint32_t> tet_gen_;
  std::vector<std::uint8_t> tet_alive_;
  std::vector<int> region_;
  std::vector<std::uint32_t> parent_;
  std::vector<std::uint32_t> free_tets_;
  std::size_t tet_count_ = 0;
};

// The three vertex slot indices of local face f of tet slot t, outward-oriented.
[[nodiscard]] std::array<std::uint32_t, 3> face_vertex_indices(const TetMesh& m, std::uint32_t t, int f);

}  // namespace scalpel
