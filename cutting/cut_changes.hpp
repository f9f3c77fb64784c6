// What one cut step changed in the live mesh, for the tissue model (docs/tissue.md).
#pragma once

#include <cstdint>
#include <vector>

#include "mesh/mesh.hpp"

namespace scalpel {

struct CutChanges {
  std::vector<std::uint32_t> removed_tets;  // live tet slots removed (before the new ones were added)
  std::vector<TetId> added_tets;
  std::vector<NodeId> added_nodes;
  std::vector<NodeParents> added_node_parents;  // weights over existing nodes, one per added node
  std::vector<NodeId> moved_nodes;              // rest and current position changed (sliding mid nodes)
  std::vector<std::uint32_t> touched_nodes;     // node slots of removed, added and moved elements
  void clear() {
    touched_nodes.clear();
    removed_tets.clear();
    added_tets.clear();
    added_nodes.clear();
    added_node_parents.clear();
    moved_nodes.clear();
  }
};

}  // namespace scalpel
