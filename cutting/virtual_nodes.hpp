// The virtual nodes (paper section 4.1). Around each cut node the sub-tetrahedra that hold it are
// grouped by face adjacency that does not cross a crack face, and each group uses its own real copy
// of the node. While the cut surface does not yet surround the node its sub-tetrahedra form one
// group and the crack stays closed there; once the blade has passed, the groups separate. This
// re-points exactly the elements on one side, as the paper's virtual nodes do, without a search
// outside the node's star.
#pragma once

#include <array>
#include <cstdint>
#include <unordered_map>
#include <utility>
#include <vector>

#include "cutting/cut_nodes.hpp"
#include "cutting/seals.hpp"
#include "cutting/subdivision.hpp"
#include "mesh/mesh.hpp"

namespace scalpel {

class VirtualNodes {
 public:
  using CutUnits = std::unordered_map<std::uint32_t, CutUnit>;  // the cut units by slot

  // `mesh`: the live mesh; `units`: the mesh of units; `nodes`: the cut nodes, whose copies and
  // groups regroup() sets; `seals`: where promoted units hold a pinned node's copy (§6).
  VirtualNodes(const TetMesh& mesh, const TetMesh& units, CutNodes& nodes, const Seals& seals)
      : mesh_(mesh), units_(units), nodes_(nodes), seals_(seals) {}

  // Groups the sub-tetrahedra of `cut_units` around cut node `id` and gives each group a copy of
  // the node (CutNode::group_of, CutNode::copies); appends the units whose sub-tetrahedra changed
  // group to `changed`.
  void regroup(std::uint32_t id, const CutUnits& cut_units, std::vector<std::uint32_t>& changed);

 private:
  // regroup()'s stages, over scratch_: the groups of sub-tetrahedra around the node (returns how
  // many), the old copies each group's corners vote for, and the copy each group takes.
  std::uint32_t group_around(std::uint32_t id, const CutUnits& cut_units);
  void vote_copies(std::uint32_t id, const CutUnits& cut_units);
  void choose_copies(std::uint32_t id, std::uint32_t groups);

  const TetMesh& mesh_;
  const TetMesh& units_;
  CutNodes& nodes_;
  const Seals& seals_;
  // Scratch, kept to avoid allocating on every step.
  struct Item {
    std::uint32_t coarse, sub;
    const std::array<GNode, 4>* tet;
  };
  struct {
    std::vector<Item> items;
    std::vector<std::uint32_t> parent, group_of_root;
    std::vector<std::pair<std::array<GNode, 3>, std::uint32_t>> faces;
    std::vector<GNode> smallest;
    std::vector<std::pair<GNode, std::uint32_t>> order;
    std::vector<CutNodeGroup> group_of;
    std::vector<std::array<std::uint32_t, 3>> votes;  // (group, copy, count)
    std::vector<std::pair<std::uint32_t, std::uint32_t>> shared;
    std::vector<std::uint32_t> copy_of;
    std::vector<std::uint8_t> taken;
    std::vector<std::uint32_t> item_group;  // the group of each item
    std::vector<std::uint32_t> around;      // the units around the node
  } scratch_;
};

}  // namespace scalpel
