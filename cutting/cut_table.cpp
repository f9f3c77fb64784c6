#include "cutting/cut_table.hpp"

#include <algorithm>
#include <deque>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "base/input_error.hpp"
#include "mesh/mesh.hpp"

namespace scalpel {

namespace {

constexpr std::uint16_t edge_bit(int e) {
  return static_cast<std::uint16_t>(1u << e);
}
constexpr std::uint16_t mid_bit(int f) {
  return static_cast<std::uint16_t>(1u << (8 + f));
}
constexpr std::uint16_t entry_bit(int f) {
  return static_cast<std::uint16_t>(1u << (12 + f));
}

std::uint16_t condition_bits(const CutTopology& t) {
  return static_cast<std::uint16_t>(t.edges | (t.faces << 8) | (t.entries << 12));
}

struct Token {
  std::string text;
  int column;  // 1-based
};

class Parser {
 public:
  Parser(const std::string& text, std::string file) : file_(std::move(file)) {
    std::istringstream in(text);
    std::string line;
    while (std::getline(in, line)) {
      std::vector<Token> tokens;
      const auto hash = line.find('#');
      if (hash != std::string::npos) line.resize(hash);
      size_t i = 0;
      while (i < line.size()) {
        while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
        if (i >= line.size()) break;
        const size_t start = i;
        while (i < line.size() && line[i] != ' ' && line[i] != '\t' && line[i] != '\r') ++i;
        tokens.push_back({line.substr(start, i - start), static_cast<int>(start) + 1});
      }
      lines_.push_back(std::move(tokens));
    }
  }

  CutTable parse() {
    CutTable table;
    table.source = file_;
    table.class_letter.fill('\0');
    bool version_seen = false;
    for (line_ = 0; line_ < static_cast<int>(lines_.size()); ++line_) {
      const auto& t = lines_[static_cast<size_t>(line_)];
      if (t.empty()) continue;
      const std::string& kw = t[0].text;
      if (kw == "version") {
        expect_count(t, 2, "version N");
        if (t[1].text != "1")
          fail(t[1], "version", "unsupported script version '" + t[1].text + "' (expected 1)");
        version_seen = true;
      } else if (!version_seen) {
        fail(t[0], "version", "the script must begin with 'version 1'");
      } else if (kw == "class") {
        parse_class(t, table);
      } else if (kw == "pattern") {
        if (t.size() < 3) fail(t[0], "pattern", "expected 'pattern NAME EDGE...'");
        std::uint8_t mask = 0;
        for (size_t i = 2; i < t.size(); ++i) mask |= static_cast<std::uint8_t>(1u << parse_edge(t[i]));
        table.patterns.push_back(mask);
      } else if (kw == "subdivide") {
        expect_count(t, 1, "subdivide");
        parse_program(table);
      } else {
        fail(t[0], "keyword", "unknown keyword '" + kw + "' (expected version, class, pattern or subdivide)");
      }
    }
    if (!version_seen) throw InputError(file_, 0, 0, "version", "empty script: expected 'version 1'");
    for (int c = 0; c < 11; ++c)
      if (table.class_letter[static_cast<size_t>(c)] == '\0')
        throw InputError(
            file_, 0, 0, "class",
            std::string("no letter for the edge class '") + edge_class_name(static_cast<EdgeClass>(c)) + "'");
    if (table.patterns.empty()) throw InputError(file_, 0, 0, "pattern", "at least one pattern is required");
    if (table.program.empty()) throw InputError(file_, 0, 0, "subdivide", "no subdivision program");
    return table;
  }

 private:
  [[noreturn]] void fail(const Token& at, const std::string& field, const std::string& message) const {
    throw InputError(file_, line_ + 1, at.column, field, message);
  }

  void expect_count(const std::vector<Token>& t, size_t n, const std::string& form) const {
    if (t.size() != n) fail(t[std::min(t.size() - 1, n)], t[0].text, "expected '" + form + "'");
  }

  int vertex(const Token& tok, char c) const {
    if (c < 'A' || c > 'D')
      fail(tok, "label", "'" + tok.text + "' is not made of the vertex labels A, B, C, D");
    return c - 'A';
  }

  int parse_edge(const Token& tok) const {
    if (tok.text.size() != 2) fail(tok, "edge", "'" + tok.text + "' is not an edge (two of A, B, C, D)");
    const int a = vertex(tok, tok.text[0]), b = vertex(tok, tok.text[1]);
    if (a == b) fail(tok, "edge", "edge '" + tok.text + "' repeats a vertex");
    return edge_index(a, b);
  }

  int parse_face(const Token& tok) const {
    if (tok.text.size() != 3) fail(tok, "face", "'" + tok.text + "' is not a face (three of A, B, C, D)");
    int seen = 0;
    for (const char c : tok.text) {
      const int v = vertex(tok, c);
      if (seen & (1 << v)) fail(tok, "face", "face '" + tok.text + "' repeats a vertex");
      seen |= 1 << v;
    }
    for (int f = 0; f < 4; ++f)
      if (!(seen & (1 << f))) return f;  // the face is named by the vertex it lacks
    fail(tok, "face", "bad face");
  }

  void parse_class(const std::vector<Token>& t, CutTable& table) const {
    if (t.size() < 2 || t[1].text.size() != 1 || t[1].text[0] < 'A' || t[1].text[0] > 'Z')
      fail(t.size() < 2 ? t[0] : t[1], "class", "expected 'class LETTER EDGE...' with an upper-case letter");
    std::uint8_t mask = 0;
    for (size_t i = 2; i < t.size(); ++i) {
      if (t[i].text == "-" && t.size() == 3) break;
      mask |= static_cast<std::uint8_t>(1u << parse_edge(t[i]));
    }
    const auto c = static_cast<size_t>(edge_class(mask));
    if (table.class_letter[c] != '\0')
      fail(
          t[1], "class",
          std::string("the class '") + edge_class_name(static_cast<EdgeClass>(c)) + "' already has a letter");
    for (const char other : table.class_letter)
      if (other == t[1].text[0]) fail(t[1], "class", "letter '" + t[1].text + "' is used twice");
    table.class_letter[c] = t[1].text[0];
    table.letters += t[1].text[0];
  }

  // instruction := "split" ("face"|"part") FACE "at" ("entry"|"mid") FACE ["when" cond]
  //              | "split" "edge" EDGE "at" "node" EDGE ["when" cond]
  void parse_program(CutTable& table) {
    for (++line_; line_ < static_cast<int>(lines_.size()); ++line_) {
      const auto& t = lines_[static_cast<size_t>(line_)];
      if (t.empty()) continue;
      if (t[0].text == "end") {
        expect_count(t, 1, "end");
        return;
      }
      if (t[0].text != "split")
        fail(t[0], "instruction", "unknown instruction '" + t[0].text + "' (expected split or end)");
      if (t.size() < 6)
        fail(t.back(), "instruction", "incomplete instruction: 'split WHAT X at NODE X [when ...]'");
      CutInstruction ins;
      ins.line = line_ + 1;
      const std::string& what = t[1].text;
      if (t[3].text != "at") fail(t[3], "instruction", "expected 'at', found '" + t[3].text + "'");
      if (what == "face" || what == "part") {
        ins.op = what == "face" ? CutInstruction::Op::SplitFace : CutInstruction::Op::SplitPart;
        ins.face = static_cast<std::uint8_t>(parse_face(t[2]));
        if (t[4].text == "entry")
          ins.node = CutInstruction::Node::Entry;
        else if (t[4].text == "mid")
          ins.node = CutInstruction::Node::Mid;
        else
          fail(t[4], "node", "a face splits at 'entry' or 'mid', not '" + t[4].text + "'");
        if (ins.op == CutInstruction::Op::SplitPart && ins.node != CutInstruction::Node::Mid)
          fail(t[4], "node", "a part splits at its face's mid node");
        if (parse_face(t[5]) != ins.face)
          fail(t[5], "node", "the node must belong to the face that is split");
        // A split needs its node; an entry part split needs both nodes of the face.
        ins.require |= ins.node == CutInstruction::Node::Entry ? entry_bit(ins.face) : mid_bit(ins.face);
        if (ins.op == CutInstruction::Op::SplitPart) ins.require |= entry_bit(ins.face);
      } else if (what == "edge") {
        ins.op = CutInstruction::Op::SplitEdge;
        ins.node = CutInstruction::Node::Edge;
        ins.edge = static_cast<std::uint8_t>(parse_edge(t[2]));
        if (t[4].text != "node") fail(t[4], "node", "an edge splits at 'node', not '" + t[4].text + "'");
        if (parse_edge(t[5]) != ins.edge)
          fail(t[5], "node", "the node must belong to the edge that is split");
        ins.require |= edge_bit(ins.edge);
      } else {
        fail(t[1], "instruction", "split 'face', 'part' or 'edge', not '" + what + "'");
      }
      if (t.size() > 6) {
        if (t[6].text != "when") fail(t[6], "instruction", "expected 'when', found '" + t[6].text + "'");
        parse_condition(t, 7, ins);
      }
      table.program.push_back(ins);
    }
    throw InputError(file_, static_cast<int>(lines_.size()), 0, "subdivide",
                     "missing 'end' of the subdivision program");
  }

  // cond := atom {"and" atom};  atom := ["not"] ("cut" EDGE | "mid" FACE | "entry" FACE)
  void parse_condition(const std::vector<Token>& t, size_t i, CutInstruction& ins) const {
    if (i >= t.size()) fail(t.back(), "condition", "empty condition after 'when'");
    while (i < t.size()) {
      bool negate = false;
      if (t[i].text == "not") {
        negate = true;
        ++i;
      }
      if (i + 1 >= t.size()) fail(t[i < t.size() ? i : t.size() - 1], "condition", "incomplete condition");
      std::uint16_t bit = 0;
      if (t[i].text == "cut")
        bit = edge_bit(parse_edge(t[i + 1]));
      else if (t[i].text == "mid")
        bit = mid_bit(parse_face(t[i + 1]));
      else if (t[i].text == "entry")
        bit = entry_bit(parse_face(t[i + 1]));
      else
        fail(t[i], "condition", "expected cut, mid or entry, found '" + t[i].text + "'");
      (negate ? ins.forbid : ins.require) |= bit;
      if (ins.forbid & ins.require) fail(t[i], "condition", "the condition contradicts itself");
      i += 2;
      if (i < t.size()) {
        if (t[i].text != "and") fail(t[i], "condition", "expected 'and', found '" + t[i].text + "'");
        ++i;
        if (i >= t.size()) fail(t[i - 1], "condition", "dangling 'and'");
      }
    }
  }

  std::string file_;
  std::vector<std::vector<Token>> lines_;
  int line_ = 0;
};

}  // namespace

bool CutInstruction::applies(const CutTopology& reference) const {
  const std::uint16_t bits = condition_bits(reference);
  return (bits & require) == require && (bits & forbid) == 0;
}

bool CutTable::representable(std::uint8_t edge_mask) const {
  for (const Perm4& p : Perm4::all()) {
    const std::uint8_t image = permute({edge_mask, 0, 0}, p).edges;
    for (const std::uint8_t pattern : patterns)
      if ((image & pattern) == image) return true;
  }
  return false;
}

std::string CutTable::label(const CutTopology& t, bool complete) const {
  std::string s(1, class_letter[static_cast<size_t>(edge_class(t.edges))]);
  s += complete ? '3' : static_cast<char>('0' + std::min(2, __builtin_popcount(t.entries)));
  return s;
}

int CutTable::label_code(const CutTopology& t, bool complete) const {
  const std::string s = label(t, complete);
  return static_cast<int>(letters.find(s[0])) * 10 + (s[1] - '0');
}

CutTable parse_cut_table(const std::string& text, const std::string& file_name) {
  return Parser(text, file_name).parse();
}

CutTable load_cut_table(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path, 0, 0, "", "cannot open the state machine script");
  std::stringstream buffer;
  buffer << in.rdbuf();
  return parse_cut_table(buffer.str(), path);
}

const std::vector<CutEvent>& all_cut_events() {
  static const std::vector<CutEvent> events = [] {
    std::vector<CutEvent> v;
    for (std::uint8_t e = 0; e < 6; ++e) v.push_back({CutEvent::Kind::CutEdge, e});
    for (std::uint8_t f = 0; f < 4; ++f) v.push_back({CutEvent::Kind::Pierce, f});
    for (std::uint8_t f = 0; f < 4; ++f) v.push_back({CutEvent::Kind::Cross, f});
    v.push_back({CutEvent::Kind::Leave, 0});
    for (std::uint8_t f = 0; f < 4; ++f) v.push_back({CutEvent::Kind::Withdraw, f});
    return v;
  }();
  return events;
}

std::string event_name(const CutEvent& e) {
  auto face = [](int f) {
    std::string s;
    for (int v = 0; v < 4; ++v)
      if (v != f) s += static_cast<char>('A' + v);
    return s;
  };
  switch (e.kind) {
    case CutEvent::Kind::CutEdge: {
      const auto& ev = kEdgeVertices[e.index];
      return std::string("cut ") + static_cast<char>('A' + ev[0]) + static_cast<char>('A' + ev[1]);
    }
    case CutEvent::Kind::Pierce:
      return "pierce " + face(e.index);
    case CutEvent::Kind::Cross:
      return "cross " + face(e.index);
    case CutEvent::Kind::Leave:
      return "leave";
    case CutEvent::Kind::Withdraw:
      return "withdraw " + face(e.index);
  }
  return "?";
}

Transition apply_event(const CutTable& table, const MachineState& s, const CutEvent& e) {
  Transition tr;
  // A valid event other than leave on an end state re-opens it: the blade has come back to the
  // tetrahedron's cut (a reversal, a stroke resumed along it). Whether it is the same surface is
  // geometry, decided by the engine (docs/state_machine.md); a different one goes to the recursive
  // continuation (§6).
  CutTopology t = s.topology;
  bool complete = false;
  switch (e.kind) {
    case CutEvent::Kind::CutEdge: {
      if (t.edges & (1u << e.index)) return tr;  // edge cut twice
      t.edges |= static_cast<std::uint8_t>(1u << e.index);
      // Beyond the planar patterns: in an end state, a second surface (the continuation's case);
      // in an open one, the blade folding back through its own cut (a turning blade, tremor
      // across its plane), which the subdivision holds as it is (docs/state_machine.md).
      if (s.complete && !table.representable(t.edges)) return tr;
      const auto& ev = kEdgeVertices[e.index];
      for (int f = 0; f < 4; ++f)  // faces holding the edge: those opposite the other two vertices
        if (f != ev[0] && f != ev[1]) t.faces |= static_cast<std::uint8_t>(1u << f);
      break;
    }
    case CutEvent::Kind::Pierce:
      // A tumbling tip may enter and leave by any number of faces; the label counts two at most.
      if (t.entries & (1u << e.index)) return tr;
      t.entries |= static_cast<std::uint8_t>(1u << e.index);
      break;
    case CutEvent::Kind::Cross:
      // A face holding a mid node already: crossed again, which re-opens an end state and changes
      // nothing in an open one.
      if ((t.faces & (1u << e.index)) && !s.complete) return tr;
      t.faces |= static_cast<std::uint8_t>(1u << e.index);
      break;
    case CutEvent::Kind::Leave:
      if (s.complete || (t.edges == 0 && t.faces == 0 && t.entries == 0)) return tr;
      complete = true;
      break;
    case CutEvent::Kind::Withdraw: {
      if (!(t.entries & (1u << e.index))) return tr;
      for (int edge = 0; edge < 6; ++edge)  // the face's edges: those without its opposite vertex
        if ((t.edges & (1u << edge)) && kEdgeVertices[static_cast<size_t>(edge)][0] != e.index &&
            kEdgeVertices[static_cast<size_t>(edge)][1] != e.index)
          return tr;
      t.entries &= static_cast<std::uint8_t>(~(1u << e.index));
      t.faces &= static_cast<std::uint8_t>(~(1u << e.index));
      break;
    }
  }
  const CanonicalState c = canonicalize(t);
  tr.valid = true;
  tr.next = {c.reference, complete};
  tr.relative = c.transform;
  return tr;
}

std::vector<MachineState> reachable_states(const CutTable& table, const MachineState& from) {
  std::vector<MachineState> out{from};
  std::deque<size_t> queue{0};
  std::set<std::uint32_t> seen{from.key()};
  while (!queue.empty()) {
    const MachineState s = out[queue.front()];
    queue.pop_front();
    for (const CutEvent& e : all_cut_events()) {
      const Transition tr = apply_event(table, s, e);
      if (!tr.valid || !seen.insert(tr.next.key()).second) continue;
      queue.push_back(out.size());
      out.push_back(tr.next);
    }
  }
  return out;
}

bool reaches(const CutTable& table, const MachineState& from, const MachineState& to) {
  const auto all = reachable_states(table, from);
  return std::find(all.begin(), all.end(), to) != all.end();
}

std::string unreached_transitions(
    const CutTable& table, const std::map<std::pair<std::uint32_t, std::uint32_t>, std::size_t>& changes) {
  std::ostringstream out;
  for (const auto& [keys, count] : changes) {
    const MachineState from = MachineState::from_key(keys.first), to = MachineState::from_key(keys.second);
    if (reaches(table, from, to)) continue;
    out << table.label(from.topology, from.complete) << " -> " << table.label(to.topology, to.complete)
        << " (" << keys.first << " -> " << keys.second << ", " << count << " times)\n";
  }
  return out.str();
}

}  // namespace scalpel
