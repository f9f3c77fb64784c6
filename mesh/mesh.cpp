#include "mesh/mesh.hpp"

#include <algorithm>
#include <stdexcept>

#include <Eigen/Geometry>

namespace scalpel {

namespace {

template <class T>
std::uint32_t take_slot(std::vector<std::uint32_t>& free_list, std::vector<T>& any_array) {
  if (!free_list.empty()) {
    const std::uint32_t s = free_list.back();
    free_list.pop_back();
    return s;
  }
  return static_cast<std::uint32_t>(any_array.size());
}

// Local face of tet `u` whose vertices are {a, b, c} (any order), or -1.
int find_face(const std::array<std::uint32_t, 4>& v, std::uint32_t a, std::uint32_t b, std::uint32_t c) {
  for (int f = 0; f < 4; ++f) {
    const std::uint32_t opposite = v[static_cast<size_t>(f)];
    if (opposite != a && opposite != b && opposite != c) {
      int hits = 0;
      for (int i = 0; i < 4; ++i) {
        if (i == f) continue;
        const std::uint32_t w = v[static_cast<size_t>(i)];
        hits += (w == a || w == b || w == c) ? 1 : 0;
      }
      if (hits == 3) return f;
    }
  }
  return -1;
}

}  // namespace

std::uint32_t TetMesh::check(NodeId n) const {
  if (!alive(n)) throw std::logic_error("TetMesh: stale or invalid node handle");
  return n.index;
}

std::uint32_t TetMesh::check(TetId t) const {
  if (!alive(t)) throw std::logic_error("TetMesh: stale or invalid tetrahedron handle");
  return t.index;
}

bool TetMesh::alive(NodeId n) const {
  return n.index < node_alive_.size() && node_alive_[n.index] && node_gen_[n.index] == n.generation;
}

bool TetMesh::alive(TetId t) const {
  return t.index < tet_alive_.size() && tet_alive_[t.index] && tet_gen_[t.index] == t.generation;
}

NodeId TetMesh::node_handle(std::uint32_t index) const {
  if (!node_slot_alive(index)) return {};
  return {index, node_gen_[index]};
}

TetId TetMesh::tet_handle(std::uint32_t index) const {
  if (!tet_slot_alive(index)) return {};
  return {index, tet_gen_[index]};
}

void TetMesh::reserve(std::size_t nodes, std::size_t tets) {
  for (auto* v : {&rest_, &pos_, &vel_}) v->reserve(nodes);
  node_gen_.reserve(nodes);
  node_alive_.reserve(nodes);
  node_tets_.reserve(nodes);
  for (auto& f : fields_) f.reserve(nodes);
  tet_nodes_.reserve(tets);
  tet_adj_.reserve(tets);
  tet_gen_.reserve(tets);
  tet_alive_.reserve(tets);
  region_.reserve(tets);
  parent_.reserve(tets);
}

NodeId TetMesh::add_node(const Vec3& rest, const Vec3& current) {
  const std::uint32_t s = take_slot(free_nodes_, rest_);
  if (s == rest_.size()) {
    rest_.push_back(rest);
    pos_.push_back(current);
    vel_.push_back(Vec3::Zero());
    node_gen_.push_back(0);
    node_alive_.push_back(1);
    node_tets_.emplace_back();
    for (auto& f : fields_) f.push_back(0.0);
  } else {
    rest_[s] = rest;
    pos_[s] = current;
    vel_[s] = Vec3::Zero();
    node_alive_[s] = 1;
    node_tets_[s].clear();
    for (auto& f : fields_) f[s] = 0.0;
  }
  ++node_count_;
  return {s, node_gen_[s]};
}

NodeId TetMesh::add_interpolated_node(const NodeParents& p) {
  if (p.count < 1 || p.count > 3) throw std::logic_error("TetMesh: interpolated node needs 1 to 3 parents");
  Vec3 r = Vec3::Zero(), x = Vec3::Zero(), v = Vec3::Zero();
  for (int i = 0; i < p.count; ++i) {
    const std::uint32_t s = check(p.parents[static_cast<size_t>(i)]);
    const double w = p.weights[static_cast<size_t>(i)];
    r += w * rest_[s];
    x += w * pos_[s];
    v += w * vel_[s];
  }
  const NodeId n = add_node(r, x);
  vel_[n.index] = v;
  interpolate_fields(n, p);
  return n;
}

void TetMesh::interpolate_fields(NodeId n, const NodeParents& p) {
  const std::uint32_t s = check(n);
  for (auto& f : fields_) {
    double value = 0.0;
    for (int i = 0; i < p.count; ++i)
      value += p.weights[static_cast<size_t>(i)] * f[check(p.parents[static_cast<size_t>(i)])];
    f[s] = value;
  }
}

void TetMesh::remove_node(NodeId n) {
  const std::uint32_t s = check(n);
  if (!node_tets_[s].empty()) throw std::logic_error("TetMesh: removing a node still used by a tetrahedron");
  node_alive_[s] = 0;
  ++node_gen_[s];
  free_nodes_.push_back(s);
  --node_count_;
}

int TetMesh::add_field(const std::string& name, double initial) {
  const int existing = field_id(name);
  if (existing >= 0) return existing;
  field_names_.push_back(name);
  fields_.emplace_back(rest_.size(), initial);
  return static_cast<int>(fields_.size()) - 1;
}

int TetMesh::field_id(const std::string& name) const {
  const auto it = std::find(field_names_.begin(), field_names_.end(), name);
  return it == field_names_.end() ? -1 : static_cast<int>(it - field_names_.begin());
}

TetId TetMesh::add_tet(const std::array<NodeId, 4>& nodes, int region) {
  std::array<std::uint32_t, 4> v{};
  for (int i = 0; i < 4; ++i) v[static_cast<size_t>(i)] = check(nodes[static_cast<size_t>(i)]);
  for (int i = 0; i < 4; ++i)
    for (int j = i + 1; j < 4; ++j)
      if (v[static_cast<size_t>(i)] == v[static_cast<size_t>(j)])
        throw std::logic_error("TetMesh: tetrahedron with a repeated vertex");

  const std::uint32_t s = take_slot(free_tets_, tet_nodes_);
  if (s == tet_nodes_.size()) {
    tet_nodes_.push_back(v);
    tet_adj_.push_back({kInvalidIndex, kInvalidIndex, kInvalidIndex, kInvalidIndex});
    tet_gen_.push_back(0);
    tet_alive_.push_back(1);
    region_.push_back(region);
    parent_.push_back(s);
  } else {
    tet_nodes_[s] = v;
    tet_adj_[s] = {kInvalidIndex, kInvalidIndex, kInvalidIndex, kInvalidIndex};
    tet_alive_[s] = 1;
    region_[s] = region;
    parent_[s] = s;
  }
  for (const std::uint32_t n : v) node_tets_[n].push_back(s);
  ++tet_count_;
  link_faces(s);
  return {s, tet_gen_[s]};
}

void TetMesh::link_faces(std::uint32_t t) {
  const auto& v = tet_nodes_[t];
  for (int f = 0; f < 4; ++f) {
    const auto& fv = kFaceVertices[static_cast<size_t>(f)];
    const std::uint32_t a = v[static_cast<size_t>(fv[0])], b = v[static_cast<size_t>(fv[1])],
                        c = v[static_cast<size_t>(fv[2])];
    for (const std::uint32_t u : node_tets_[a]) {
      if (u == t) continue;
      const int g = find_face(tet_nodes_[u], a, b, c);
      if (g < 0) continue;
      // A third tetrahedron on a face is non-conforming; validate() reports it. Keep the first link.
      if (tet_adj_[u][static_cast<size_t>(g)] != kInvalidIndex) continue;
      tet_adj_[u][static_cast<size_t>(g)] = t;
      tet_adj_[t][static_cast<size_t>(f)] = u;
      break;
    }
  }
}

void TetMesh::remove_tet(TetId t) {
  const std::uint32_t s = check(t);
  for (int f = 0; f < 4; ++f) {
    const std::uint32_t u = tet_adj_[s][static_cast<size_t>(f)];
    if (u == kInvalidIndex) continue;
    for (auto& back : tet_adj_[u])
      if (back == s) back = kInvalidIndex;
  }
  for (const std::uint32_t n : tet_nodes_[s]) {
    auto& list = node_tets_[n];
    const auto it = std::find(list.begin(), list.end(), s);
    if (it != list.end()) {
      *it = list.back();
      list.pop_back();
    }
  }
  tet_alive_[s] = 0;
  ++tet_gen_[s];
  free_tets_.push_back(s);
  --tet_count_;
}

std::array<NodeId, 4> TetMesh::tet_nodes(TetId t) const {
  const auto& v = tet_nodes_[check(t)];
  return {NodeId{v[0], node_gen_[v[0]]}, NodeId{v[1], node_gen_[v[1]]}, NodeId{v[2], node_gen_[v[2]]},
          NodeId{v[3], node_gen_[v[3]]}};
}

NodeId TetMesh::tet_node(TetId t, int local) const {
  const std::uint32_t n = tet_nodes_[check(t)][static_cast<size_t>(local)];
  return {n, node_gen_[n]};
}

TetId TetMesh::neighbour(TetId t, int face) const {
  const std::uint32_t u = tet_adj_[check(t)][static_cast<size_t>(face)];
  if (u == kInvalidIndex) return {};
  return {u, tet_gen_[u]};
}

int TetMesh::neighbour_face(TetId t, int face) const {
  const std::uint32_t s = check(t);
  const std::uint32_t u = tet_adj_[s][static_cast<size_t>(face)];
  if (u == kInvalidIndex) return -1;
  const auto fv = face_vertex_indices(*this, s, face);
  return find_face(tet_nodes_[u], fv[0], fv[1], fv[2]);
}

std::vector<NodeId> TetMesh::nodes() const {
  std::vector<NodeId> out;
  out.reserve(node_count_);
  for (std::uint32_t i = 0; i < node_alive_.size(); ++i)
    if (node_alive_[i]) out.push_back({i, node_gen_[i]});
  return out;
}

std::vector<TetId> TetMesh::tets() const {
  std::vector<TetId> out;
  out.reserve(tet_count_);
  for (std::uint32_t i = 0; i < tet_alive_.size(); ++i)
    if (tet_alive_[i]) out.push_back({i, tet_gen_[i]});
  return out;
}

double TetMesh::rest_volume(TetId t) const {
  const auto& v = tet_nodes_[check(t)];
  return signed_volume(rest_[v[0]], rest_[v[1]], rest_[v[2]], rest_[v[3]]);
}

double TetMesh::current_volume(TetId t) const {
  const auto& v = tet_nodes_[check(t)];
  return signed_volume(pos_[v[0]], pos_[v[1]], pos_[v[2]], pos_[v[3]]);
}

double TetMesh::total_rest_volume() const {
  double sum = 0.0;
  for (std::uint32_t i = 0; i < tet_alive_.size(); ++i) {
    if (!tet_alive_[i]) continue;
    const auto& v = tet_nodes_[i];
    sum += signed_volume(rest_[v[0]], rest_[v[1]], rest_[v[2]], rest_[v[3]]);
  }
  return sum;
}

std::size_t TetMesh::memory_bytes() const {
  std::size_t b = 0;
  b += (rest_.capacity() + pos_.capacity() + vel_.capacity()) * sizeof(Vec3);
  b += node_gen_.capacity() * 4 + node_alive_.capacity() + free_nodes_.capacity() * 4;
  b += node_tets_.capacity() * sizeof(std::vector<std::uint32_t>);
  for (const auto& l : node_tets_) b += l.capacity() * 4;
  for (const auto& f : fields_) b += f.capacity() * sizeof(double);
  b += (tet_nodes_.capacity() + tet_adj_.capacity()) * 16;
  b += tet_gen_.capacity() * 4 + tet_alive_.capacity() + region_.capacity() * sizeof(int);
  b += parent_.capacity() * 4 + free_tets_.capacity() * 4;
  return b;
}

std::array<std::uint32_t, 3> face_vertex_indices(const TetMesh& m, std::uint32_t t, int f) {
  const auto& v = m.tet_vertex_indices(t);
  const auto& fv = kFaceVertices[static_cast<size_t>(f)];
  return {v[static_cast<size_t>(fv[0])], v[static_cast<size_t>(fv[1])], v[static_cast<size_t>(fv[2])]};
}

}  // namespace scalpel
