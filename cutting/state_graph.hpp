// The reachable state machine as text: a listing of its states and a Graphviz drawing (our
// reconstruction of the paper's Fig. 3; docs/state_machine.md, "Events").
#pragma once

#include <string>

#include "cutting/cut_table.hpp"

namespace scalpel {

// One line per reachable state, in the search's order: the label, then the cut edges, the faces with
// a mid node and the faces with an entry node, in the reference labels of the canonical state.
[[nodiscard]] std::string state_listing(const CutTable& table);

// A Graphviz digraph with one node per label (the reachable states that share it) and one arrow per
// pair of labels an event joins, named by the kinds of events that do. End states are drawn double,
// arrows out of them (re-opening) grey, withdrawals (tremble, §5.1) dotted.
[[nodiscard]] std::string state_dot(const CutTable& table);

}  // namespace scalpel
