// The units of the state machine and their promotion one level deeper (paper section 6).
#include "cutting/units.hpp"

#include <algorithm>
#include <numeric>

namespace scalpel {

Units::Units(const TetMesh& original) : mesh_(original) {
  // The units grow when a cut is continued recursively (§6): room for an eighth more, so that the
  // first continuations of a session do not copy the whole unit mesh.
  mesh_.reserve(mesh_.node_capacity() + mesh_.node_capacity() / 8,
                mesh_.tet_capacity() + mesh_.tet_capacity() / 8);
  live_.resize(original.tet_capacity());
  std::iota(live_.begin(), live_.end(), 0u);
  level_.assign(original.tet_capacity(), 0);
  last_touch_.assign(original.tet_capacity(), 0);
  live_.reserve(mesh_.tet_capacity() + mesh_.tet_capacity() / 8);
  level_.reserve(live_.capacity());
  last_touch_.reserve(live_.capacity());
}

void Units::follow(const TetMesh& live) {
  auto& x = mesh_.positions();
  const auto& from = live.positions();
  std::copy(from.begin(), from.begin() + static_cast<std::ptrdiff_t>(x.size()), x.begin());
}

void Units::remove(std::uint32_t unit) {
  mesh_.remove_tet(mesh_.tet_handle(unit));
}

void Units::remove_node(std::uint32_t live) {
  if (mesh_.node_slot_alive(live)) mesh_.remove_node(mesh_.node_handle(live));
}

NodeId Units::node_of(const TetMesh& live_mesh, NodeId live) {
  while (!mesh_.node_slot_alive(live.index)) (void)mesh_.add_node(Vec3::Zero());
  const NodeId u = mesh_.node_handle(live.index);
  mesh_.set_rest(u, live_mesh.rest(live));
  mesh_.set_position(u, live_mesh.position(live));
  return u;
}

std::uint32_t Units::add(const TetMesh& live_mesh, const std::array<NodeId, 4>& nodes, std::uint32_t live,
                         int region, int level) {
  std::array<NodeId, 4> corners{};
  for (std::size_t i = 0; i < 4; ++i) corners[i] = node_of(live_mesh, nodes[i]);
  const std::uint32_t unit = mesh_.add_tet(corners, region).index;
  if (live_.size() <= unit) {
    live_.resize(unit + 1, kInvalidIndex);
    level_.resize(unit + 1, 0);
    last_touch_.resize(unit + 1, 0);
  }
  live_[unit] = live;
  level_[unit] = static_cast<std::uint8_t>(level);
  last_touch_[unit] = 0;
  return unit;
}

}  // namespace scalpel
