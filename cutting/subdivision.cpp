// Subdivision (paper sections 4.2 and 4.4): the state of a cut tetrahedron from its cut nodes, and
// its sub-tetrahedra from the table's program run through the absolute transformation.
#include "cutting/subdivision.hpp"

#include "cutting/cut_engine_internal.hpp"

namespace scalpel {

using namespace cut_internal;

CutTopology Subdivision::topology(std::uint32_t t) const {
  CutTopology topo;
  const auto& v = units_.tet_vertex_indices(t);
  for (int e = 0; e < 6; ++e) {
    const auto& ev = kEdgeVertices[static_cast<size_t>(e)];
    if (nodes_.edge(v[static_cast<size_t>(ev[0])], v[static_cast<size_t>(ev[1])]) != kInvalidIndex)
      topo.edges |= static_cast<std::uint8_t>(1u << e);
  }
  for (int f = 0; f < 4; ++f) {
    const auto fv = face_vertex_indices(units_, t, f);
    const Key3 k = sorted_key(fv[0], fv[1], fv[2]);
    if (nodes_.mid(k) != kInvalidIndex) topo.faces |= static_cast<std::uint8_t>(1u << f);
    if (nodes_.entry(k) != kInvalidIndex) topo.entries |= static_cast<std::uint8_t>(1u << f);
  }
  return topo;
}

// The subdivision of one coarse tetrahedron: the table's program, run in the reference labels of the
// canonical state (§4.2) through the absolute transformation, so symmetric states share one entry.
void Subdivision::subdivide(std::uint32_t t, const CanonicalState& state,
                            std::vector<std::array<GNode, 4>>& out) const {
  const auto& v = units_.tet_vertex_indices(t);
  out.assign(1, {v[0], v[1], v[2], v[3]});
  const auto& p = state.transform.p;  // reference vertex i is local vertex p[i]
  for (const CutInstruction& ins : table_.program) {
    if (!ins.applies(state.reference)) continue;
    if (ins.op == CutInstruction::Op::SplitEdge) {
      const auto& ev = kEdgeVertices[ins.edge];
      const std::uint32_t a = v[p[static_cast<size_t>(ev[0])]], b = v[p[static_cast<size_t>(ev[1])]];
      split_edge(out, a, b, kCutBit | nodes_.edge(a, b));
      continue;
    }
    const auto fv = face_vertex_indices(units_, t, p[ins.face]);
    const Key3 k = sorted_key(fv[0], fv[1], fv[2]);
    const std::uint32_t entry = nodes_.entry(k), mid = nodes_.mid(k);
    if (ins.op == CutInstruction::Op::SplitPart) {
      std::array<GNode, 3> part{k[0], k[1], k[2]};
      part[static_cast<size_t>(nodes_[mid].entry_subtriangle)] = kCutBit | entry;
      split_face(out, part[0], part[1], part[2], kCutBit | mid);
    } else {
      split_face(out, k[0], k[1], k[2], kCutBit | (ins.node == CutInstruction::Node::Entry ? entry : mid));
    }
  }
}

}  // namespace scalpel
