#include "cutting/state_graph.hpp"

#include <map>
#include <set>
#include <sstream>
#include <utility>
#include <vector>

#include "mesh/mesh.hpp"

namespace scalpel {

namespace {

std::string edge_names(std::uint8_t mask) {
  std::string s;
  for (int e = 0; e < 6; ++e)
    if (mask & (1u << e)) {
      const auto& ev = kEdgeVertices[static_cast<size_t>(e)];
      if (!s.empty()) s += ' ';
      s += static_cast<char>('A' + ev[0]);
      s += static_cast<char>('A' + ev[1]);
    }
  return s.empty() ? "-" : s;
}

// Faces by their three vertices (face f is opposite vertex f).
std::string face_names(std::uint8_t mask) {
  std::string s;
  for (int f = 0; f < 4; ++f)
    if (mask & (1u << f)) {
      if (!s.empty()) s += ' ';
      for (int v = 0; v < 4; ++v)
        if (v != f) s += static_cast<char>('A' + v);
    }
  return s.empty() ? "-" : s;
}

const char* kind_name(CutEvent::Kind k) {
  switch (k) {
    case CutEvent::Kind::CutEdge:
      return "cut";
    case CutEvent::Kind::Pierce:
      return "pierce";
    case CutEvent::Kind::Cross:
      return "cross";
    case CutEvent::Kind::Leave:
      return "leave";
    case CutEvent::Kind::Withdraw:
      return "withdraw";
  }
  return "?";
}

}  // namespace

std::string state_listing(const CutTable& table) {
  std::ostringstream out;
  out << "# " << table.source << ": the states reachable from O0 (docs/state_machine.md, \"Events\")\n"
      << "# label  cut edges | mid faces | entry faces   (reference labels; label digit 3: complete)\n";
  for (const MachineState& s : reachable_states(table))
    out << table.label(s.topology, s.complete) << "  " << edge_names(s.topology.edges) << " | "
        << face_names(s.topology.faces) << " | " << face_names(s.topology.entries) << '\n';
  return out.str();
}

std::string state_dot(const CutTable& table) {
  // Arrows between labels, with the kinds of events that make them; changes within a label (a new
  // mid node beside a cut, a third entry node) are left out.
  std::map<std::pair<std::string, std::string>, std::set<std::string>> arrows;
  std::map<char, std::set<std::string>> by_letter;
  for (const MachineState& s : reachable_states(table)) {
    const std::string from = table.label(s.topology, s.complete);
    by_letter[from[0]].insert(from);
    for (const CutEvent& e : all_cut_events()) {
      const Transition tr = apply_event(table, s, e);
      if (!tr.valid) continue;
      const std::string to = table.label(tr.next.topology, tr.next.complete);
      if (to != from) arrows[{from, to}].insert(kind_name(e.kind));
    }
  }
  std::ostringstream out;
  out << "// The cut state machine reachable from O0 (" << table.source << "), by label.\n"
      << "// Render: scalpelsim states --dot | dot -Tsvg > state_machine.svg\n"
      << "digraph cut_states {\n"
      << "  rankdir=LR;\n"
      << "  node [shape=circle, fontname=\"Helvetica\", fontsize=12, width=0.5, fixedsize=true];\n"
      << "  edge [fontname=\"Helvetica\", fontsize=8, arrowsize=0.6];\n";
  // One column per class letter, in the script's order.
  for (const char letter : table.letters) {
    const auto it = by_letter.find(letter);
    if (it == by_letter.end()) continue;
    out << "  { rank=same;";
    for (const std::string& label : it->second)
      out << ' ' << label << (label[1] == '3' ? " [shape=doublecircle]" : "") << ';';
    out << " }\n";
  }
  for (const auto& [pair, kinds] : arrows) {
    std::string name;
    for (const std::string& k : kinds) name += (name.empty() ? "" : ", ") + k;
    out << "  " << pair.first << " -> " << pair.second << " [label=\"" << name << "\"";
    if (pair.first[1] == '3') out << ", color=grey50, fontcolor=grey50";
    if (kinds.size() == 1 && *kinds.begin() == "withdraw") out << ", style=dotted";
    out << "];\n";
  }
  out << "}\n";
  return out.str();
}

}  // namespace scalpel
