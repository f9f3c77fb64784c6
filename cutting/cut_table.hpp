// The lookup table of the state machine, written as a script (paper §4.4, docs/state_machine.md).
//
// The script (config/cutting/state_machine.cut, grammar in config/cutting/README.md) holds
//   - the names of the edge-topology classes (the letters of the state labels),
//   - the planar edge patterns the basic machine represents: an edge mask that is no subset of
//     one of them is, in an end state, a second surface for the recursive continuation (§6), and
//     while the blade is in the tetrahedron a fold the subdivision holds as it is,
//   - the subdivision program: instructions in the labels of the reference tetrahedron (A, B, C,
//     D; edges AB..CD; faces by their three vertices), each guarded by a condition on the state.
// It is parsed once at start-up into a CutTable: a compact instruction array that the engine runs
// for every cut tetrahedron through the tetrahedron's absolute transformation (a permutation), so
// symmetric states share one entry.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "cutting/cut_state.hpp"

namespace scalpel {

struct CutInstruction {
  enum class Op : std::uint8_t {
    SplitFace,  // stellar split of reference face `face` at its entry or mid node
    SplitPart,  // split the part of entry-split face `face` that holds its mid node, at the mid node
    SplitEdge,  // stellar split of reference edge `edge` at its edge node
  };
  enum class Node : std::uint8_t { Entry, Mid, Edge };
  Op op = Op::SplitFace;
  Node node = Node::Mid;
  std::uint8_t face = 0;  // reference face index (opposite reference vertex)
  std::uint8_t edge = 0;  // reference edge index (kEdgeVertices)
  // Condition over the reference topology: bits 0-5 cut edges, 8-11 mid faces, 12-15 entry faces.
  std::uint16_t require = 0;
  std::uint16_t forbid = 0;
  int line = 0;  // script line, for messages

  [[nodiscard]] bool applies(const CutTopology& reference) const;
};

struct CutTable {
  std::string source;                   // script path
  std::array<char, 11> class_letter{};  // per EdgeClass
  std::string letters;                  // the class letters in the script's order
  std::vector<std::uint8_t> patterns;   // representable maximal edge masks (reference labels)
  std::vector<CutInstruction> program;  // the subdivision program

  // Representable by the basic machine: the mask, under some permutation, is a subset of a pattern.
  [[nodiscard]] bool representable(std::uint8_t edge_mask) const;
  // "A0", "D3", ...: class letter, then the number of entry nodes (or 3 when complete).
  [[nodiscard]] std::string label(const CutTopology& t, bool complete) const;
  // The label as a number (for VTK cell data): 10 x the letter's place in the script + the digit.
  [[nodiscard]] int label_code(const CutTopology& t, bool complete) const;
};

// Parses a script; errors are InputError naming file, line, column and the offending word.
[[nodiscard]] CutTable parse_cut_table(const std::string& text, const std::string& file_name);
[[nodiscard]] CutTable load_cut_table(const std::string& path);
// The table bundled with the program (config/cutting/state_machine.cut, compiled in).
[[nodiscard]] const CutTable& default_cut_table();

// The events that drive the machine (§4.3, §5.1), in reference labels: the blade cuts an edge, its
// tip pierces a face (an entry node), the blade crosses a face (a mid node), it leaves the
// tetrahedron (an end state), or the tip withdraws by a face it entered before any edge of that
// face was cut (tremble: the face's entry and mid nodes go).
struct CutEvent {
  enum class Kind : std::uint8_t { CutEdge, Pierce, Cross, Leave, Withdraw };
  Kind kind = Kind::CutEdge;
  std::uint8_t index = 0;  // edge index for CutEdge; face index for Pierce, Cross and Withdraw
  friend bool operator==(const CutEvent&, const CutEvent&) = default;
};
[[nodiscard]] std::string event_name(const CutEvent& e);
// All 19 events: 6 edge cuts, 4 pierces, 4 crossings, leave, 4 withdrawals.
[[nodiscard]] const std::vector<CutEvent>& all_cut_events();

struct MachineState {
  CutTopology topology;  // canonical representative
  bool complete = false;
  friend bool operator==(const MachineState&, const MachineState&) = default;
  // A number per state (15 bits), for sets and maps.
  [[nodiscard]] std::uint32_t key() const {
    return (std::uint32_t{topology.edges} << 9) | (std::uint32_t{topology.faces} << 5) |
           (std::uint32_t{topology.entries} << 1) | (complete ? 1u : 0u);
  }
  [[nodiscard]] static MachineState from_key(std::uint32_t key) {
    return {{static_cast<std::uint8_t>(key >> 9), static_cast<std::uint8_t>((key >> 5) & 15u),
             static_cast<std::uint8_t>((key >> 1) & 15u)},
            (key & 1u) != 0};
  }
};

// The result of one (state, event) pair: the next state, or invalid (the recursive continuation's
// case: an edge cut twice, a face pierced twice, a face crossed twice in an open state, a pattern
// beyond the planar ones in an end state; or an event that cannot happen: leaving an end state or
// the empty one, withdrawing by a face never entered or whose edges are cut).
struct Transition {
  bool valid = false;
  MachineState next;
  Perm4 relative;  // reference labels of `next` in terms of the reference labels of the source
};

// Applies an event to a state (faces around a cut edge gain mid nodes, as the engine does). An
// event on an end state re-opens it.
[[nodiscard]] Transition apply_event(const CutTable& table, const MachineState& s, const CutEvent& e);

// The states reachable from `from` (O0 by default) by valid events, breadth first, in a
// deterministic order; `from` first.
[[nodiscard]] std::vector<MachineState> reachable_states(const CutTable& table,
                                                         const MachineState& from = {});
// Whether events of the table lead from `from` to `to` (one tool sample may bring several: the
// engine's transitions are these).
[[nodiscard]] bool reaches(const CutTable& table, const MachineState& from, const MachineState& to);
// The changes of state in `changes` (MachineState::key() before and after, with a count, as in
// CutTotals::state_transitions) that no sequence of the table's events makes, one line each
// ("A3 -> B0 (897 -> 1984, 2 times)"); empty if there is none.
[[nodiscard]] std::string unreached_transitions(
    const CutTable& table, const std::map<std::pair<std::uint32_t, std::uint32_t>, std::size_t>& changes);

}  // namespace scalpel
