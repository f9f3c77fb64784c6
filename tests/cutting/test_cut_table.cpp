#include <doctest/doctest.h>

#include <array>
#include <bit>
#include <set>
#include <string>

#include "base/input_error.hpp"
#include "cutting/cut_engine.hpp"
#include "cutting/cut_table.hpp"
#include "cutting/state_graph.hpp"
#include "mesh/generators.hpp"
#include "mesh/topology.hpp"
#include "mesh/validate.hpp"

using namespace scalpel;

TEST_CASE("the bundled state machine script parses and names every class") {
  const CutTable& table = default_cut_table();
  CHECK(table.program.size() == 18);
  CHECK(table.patterns.size() == 2);
  CHECK(table.label({0b000001, 0b1100, 0}, false) == "A0");
  CHECK(table.label({0b000111, 0, 0}, true) == "D3");
  CHECK(table.label({0, 0b0100, 0b0100}, false) == "O1");
  CHECK(table.representable(0b000111));        // around a vertex
  CHECK(table.representable(0b100001));        // two opposite edges: part of a loop
  CHECK_FALSE(table.representable(0b001011));  // AB, AC, BC: three on a face
}

TEST_CASE("S4 acts on cut topologies and canonical forms are invariant") {
  CHECK(Perm4::all().size() == 24);
  int odd = 0;
  for (const Perm4& p : Perm4::all()) {
    odd += p.odd() ? 1 : 0;
    CHECK(p.compose(p.inverse()) == Perm4{});
  }
  CHECK(odd == 12);
  // The 64 edge masks fall into 11 classes.
  std::set<std::uint8_t> classes;
  for (int m = 0; m < 64; ++m)
    classes.insert(canonicalize({static_cast<std::uint8_t>(m), 0, 0}).reference.edges);
  CHECK(classes.size() == 11);
  for (int m = 0; m < 64; ++m) {
    const CutTopology t{static_cast<std::uint8_t>(m), static_cast<std::uint8_t>(m % 16),
                        static_cast<std::uint8_t>((m * 7) % 16)};
    const CanonicalState c = canonicalize(t);
    CHECK(permute(t, c.transform) == c.reference);
    for (const Perm4& p : Perm4::all()) CHECK(canonicalize(permute(t, p)).reference == c.reference);
  }
}

TEST_CASE("script errors name file, line and column") {
  auto error_of = [](const std::string& text) -> std::string {
    try {
      (void)parse_cut_table(text, "bad.cut");
    } catch (const InputError& e) {
      return e.what();
    }
    return "no error";
  };
  const std::string head = "version 1\nclass O -\n";
  CHECK(error_of("class A AB\n") == "bad.cut:1:1: version: the script must begin with 'version 1'");
  CHECK(error_of("version 2\n") == "bad.cut:1:9: version: unsupported script version '2' (expected 1)");
  CHECK(error_of(head + "pattern p AB AX\n") ==
        "bad.cut:3:14: label: 'AX' is not made of the vertex labels A, B, C, D");
  CHECK(error_of(head + "class O AB\n") == "bad.cut:3:7: class: letter 'O' is used twice");
  CHECK(error_of(head + "subdivide\n  split face ABC at mid ABD\nend\n") ==
        "bad.cut:4:25: node: the node must belong to the face that is split");
  CHECK(error_of(head + "subdivide\n  split edge AB at node AB when cut AB or cut AC\nend\n") ==
        "bad.cut:4:40: condition: expected 'and', found 'or'");
  CHECK(error_of(head + "subdivide\n  split edge AB at node AB when cut AB and not cut AB\nend\n") ==
        "bad.cut:4:48: condition: the condition contradicts itself");
  CHECK(error_of(head + "subdivide\n  split edge AB at node AB\n") ==
        "bad.cut:4: subdivide: missing 'end' of the subdivision program");
  CHECK(error_of(head + "frobnicate\n") ==
        "bad.cut:3:1: keyword: unknown keyword 'frobnicate' (expected version, class, pattern or subdivide)");
  CHECK(error_of(head + "pattern p AB\nsubdivide\n  split edge AB at node AB\nend\n") ==
        "bad.cut: class: no letter for the edge class 'one edge'");
}

namespace {

// Edges and faces of the reference tetrahedron by name, written out by hand (edges in
// kEdgeVertices order, face f opposite vertex f), so the expectations below do not come from the
// code under test.
constexpr std::uint8_t AB = 1, AC = 2, AD = 4, BC = 8, BD = 16, CD = 32;
constexpr std::uint8_t BCD = 1, ACD = 2, ABD = 4, ABC = 8;
constexpr std::array<std::uint8_t, 6> kFacesOfEdge = {ABC | ABD, ABC | ACD, ABD | ACD,
                                                      ABC | BCD, ABD | BCD, ACD | BCD};

// The edge masks one planar pass can cut (the script's patterns): the three edges around a vertex,
// a loop of four (all but two opposite edges), and their subsets.
bool planar_edges(std::uint8_t edges) {
  for (const std::uint8_t pattern : {AB | AC | AD, AB | BC | BD, AC | BC | CD, AD | BD | CD,  //
                                     AC | AD | BC | BD, AB | AD | BC | CD, AB | AC | BD | CD})
    if ((edges & ~pattern) == 0) return true;
  return false;
}

std::uint32_t state_key(const MachineState& s) {
  return s.key();
}

MachineState state_of(const CutTopology& local, bool complete) {
  return {canonicalize(local).reference, complete};
}

CutEvent cut(std::uint8_t edge) {
  return {CutEvent::Kind::CutEdge, static_cast<std::uint8_t>(std::countr_zero(edge))};
}
CutEvent pierce(std::uint8_t face) {
  return {CutEvent::Kind::Pierce, static_cast<std::uint8_t>(std::countr_zero(face))};
}
CutEvent cross(std::uint8_t face) {
  return {CutEvent::Kind::Cross, static_cast<std::uint8_t>(std::countr_zero(face))};
}
CutEvent withdraw(std::uint8_t face) {
  return {CutEvent::Kind::Withdraw, static_cast<std::uint8_t>(std::countr_zero(face))};
}
constexpr CutEvent kLeave{CutEvent::Kind::Leave, 0};

// Applies `event`, named in the labels of `local`, to the state of a tetrahedron whose topology is
// `local`: the event is relabelled into the reference labels of the canonical state first.
Transition apply_local(const CutTopology& local, bool complete, CutEvent event) {
  const CanonicalState c = canonicalize(local);
  const Perm4 to_reference = c.transform.inverse();  // local vertex v is reference vertex p[v]
  if (event.kind == CutEvent::Kind::CutEdge) {
    const auto& ev = kEdgeVertices[event.index];
    event.index = static_cast<std::uint8_t>(
        edge_index(to_reference.p[static_cast<size_t>(ev[0])], to_reference.p[static_cast<size_t>(ev[1])]));
  } else if (event.kind != CutEvent::Kind::Leave) {
    event.index = to_reference.p[event.index];
  }
  return apply_event(default_cut_table(), {c.reference, complete}, event);
}

// `event` on `from` gives `to` (both in local labels), with the label `label`, and the relative
// transformation maps the successor, in the source's reference labels, onto its reference labels.
void check_transition(const CutTopology& from, bool complete, CutEvent event, const CutTopology& to,
                      bool to_complete, const std::string& label) {
  CAPTURE(default_cut_table().label(from, complete));
  CAPTURE(event_name(event));
  const Transition tr = apply_local(from, complete, event);
  REQUIRE(tr.valid);
  CHECK(tr.next == state_of(to, to_complete));
  CHECK(default_cut_table().label(tr.next.topology, tr.next.complete) == label);
  CHECK(permute(permute(to, canonicalize(from).transform), tr.relative) == tr.next.topology);
}

void check_invalid(const CutTopology& from, bool complete, CutEvent event) {
  CAPTURE(default_cut_table().label(from, complete));
  CAPTURE(event_name(event));
  CHECK_FALSE(apply_local(from, complete, event).valid);
}

}  // namespace

TEST_CASE("reachable states: the search finds exactly the states the event rules allow, 321") {
  // From the rules (docs/state_machine.md, "Events"): a topology is reachable iff its mid faces
  // include the two faces of every cut edge (other faces gain one by a crossing, before any cut
  // reaches them); any edges may be cut while the blade is in the tetrahedron (beyond the planar
  // patterns, a fold), and any faces may hold an entry node (a tumbling tip); crossings, then cuts,
  // then pierces reach it. Each is reachable incomplete, and complete after a leave, except the
  // empty topology. Up to S4 that is 161 topologies, so 2 * 161 - 1 states.
  std::set<std::uint32_t> expected;
  for (unsigned edges = 0; edges < 64; ++edges) {
    std::uint8_t required_faces = 0;
    for (int e = 0; e < 6; ++e)
      if (edges & (1u << e)) required_faces |= kFacesOfEdge[static_cast<size_t>(e)];
    for (unsigned faces = 0; faces < 16; ++faces) {
      if ((faces & required_faces) != required_faces) continue;
      for (unsigned entries = 0; entries < 16; ++entries) {
        const CutTopology t{static_cast<std::uint8_t>(edges), static_cast<std::uint8_t>(faces),
                            static_cast<std::uint8_t>(entries)};
        expected.insert(state_key(state_of(t, false)));
        if (edges != 0 || faces != 0 || entries != 0) expected.insert(state_key(state_of(t, true)));
      }
    }
  }
  CHECK(expected.size() == 321);

  const CutTable& table = default_cut_table();
  const auto states = reachable_states(table);
  std::set<std::uint32_t> found;
  std::set<std::string> labels;
  for (const auto& s : states) {
    CAPTURE(table.label(s.topology, s.complete));
    CHECK(found.insert(state_key(s)).second);  // each state once
    CHECK(expected.count(state_key(s)) == 1);  // nothing the rules forbid
    labels.insert(table.label(s.topology, s.complete));
  }
  CHECK(states.size() == expected.size());  // and, with the two above, everything they allow
  // The letters of every class, each with 0, 1 or 2 entry nodes and complete (3): 44 labels.
  std::set<std::string> expected_labels;
  for (const char letter : std::string("OABCDEGHIJK"))
    for (const char digit : std::string("0123")) expected_labels.insert(std::string{letter, digit});
  CHECK(labels == expected_labels);
}

TEST_CASE("transitions derived by hand from the script and the event rules") {
  const CutTopology O0{};
  const CutTopology A0{AB, ABC | ABD, 0};
  const CutTopology B0{AB | AC, ABC | ABD | ACD, 0};
  const CutTopology D0{AB | AC | AD, ABC | ABD | ACD, 0};
  const CutTopology C0{AB | AC | CD, ABC | ABD | ACD | BCD, 0};
  const CutTopology E0{AB | AC | BD | CD, ABC | ABD | ACD | BCD, 0};
  const CutTopology O1{0, 0, BCD};
  const CutTopology O2{0, 0, BCD | ACD};

  // A first cut edge brings mid nodes to its two faces.
  check_transition(O0, false, cut(AB), A0, false, "A0");
  check_transition(O0, false, cut(CD), {CD, ACD | BCD, 0}, false, "A0");
  // The opposite edge: entry and exit through two faces (G); an adjacent one (B), then the third
  // around the vertex (D), which the blade completes by leaving (D3, the 1|3 split).
  check_transition(A0, false, cut(CD), {AB | CD, ABC | ABD | ACD | BCD, 0}, false, "G0");
  check_transition(A0, false, cut(AC), B0, false, "B0");
  check_transition(B0, false, cut(AD), D0, false, "D0");
  check_transition(D0, false, kLeave, D0, true, "D3");
  // A path of three (C) closes into the loop of four (E): the 2|2 split.
  check_transition(B0, false, cut(CD), C0, false, "C0");
  check_transition(C0, false, cut(BD), E0, false, "E0");
  check_transition(E0, false, kLeave, E0, true, "E3");
  // Crossings and pierces.
  check_transition(A0, false, cross(ACD), {AB, ABC | ABD | ACD, 0}, false, "A0");
  check_transition(O0, false, cross(ABC), {0, ABC, 0}, false, "O0");
  check_transition(O0, false, pierce(BCD), O1, false, "O1");
  check_transition(O1, false, pierce(ACD), O2, false, "O2");
  check_transition(O1, false, cut(AB), {AB, ABC | ABD, BCD}, false, "A1");
  check_transition(O1, false, kLeave, O1, true, "O3");

  // Three edges on one face (H), four not a loop (I), five (J): beyond the planar patterns. The
  // blade folding back through its own cut while it is in the tetrahedron (a fold, held as it is);
  // in an end state a second surface, the recursive continuation's case.
  for (std::uint8_t m = 0; m < 64; ++m) CHECK(default_cut_table().representable(m) == planar_edges(m));
  check_transition(B0, false, cut(BC), {AB | AC | BC, ABC | ABD | ACD | BCD, 0}, false, "H0");
  check_transition(C0, false, cut(BC), {AB | AC | BC | CD, ABC | ABD | ACD | BCD, 0}, false, "I0");
  check_transition(E0, false, cut(AD), {AB | AC | AD | BD | CD, ABC | ABD | ACD | BCD, 0}, false, "J0");
  check_invalid(B0, true, cut(BC));
  check_invalid(C0, true, cut(BC));
  check_invalid(D0, true, cut(BC));
  check_invalid(E0, true, cut(AD));
  // An edge cut twice, a face crossed twice, a face pierced twice. A third pierce is a tumbling tip
  // (the label counts two).
  check_invalid(A0, false, cut(AB));
  check_invalid(A0, false, cross(ABC));
  check_invalid(O1, false, pierce(BCD));
  check_transition(O2, false, pierce(ABD), {0, 0, BCD | ACD | ABD}, false, "O2");
  // Leaving an untouched tetrahedron, or a finished one.
  check_invalid(O0, false, kLeave);
  check_invalid(D0, true, kLeave);
  // The blade back in a finished tetrahedron re-opens it: crossing a face again, or extending the
  // cut by a pierce; a cut that leaves the planar patterns is the continuation's (invalid).
  check_transition(D0, true, cross(ABC), D0, false, "D0");
  check_transition(D0, true, pierce(BCD), {AB | AC | AD, ABC | ABD | ACD, BCD}, false, "D1");
  check_transition(A0, true, cut(AC), B0, false, "B0");
  check_invalid(D0, true, cut(BC));
  // Tremble (§5.1): the tip withdraws by the face it entered, before any edge of it is cut; its
  // entry and mid nodes go.
  check_transition(O1, false, withdraw(BCD), O0, false, "O0");
  check_transition({AB, ABC | ABD | BCD, BCD}, false, withdraw(BCD), A0, false, "A0");
  check_invalid({AB, ABC | ABD, ABC}, false, withdraw(ABC));  // AB, an edge of ABC, is cut
  check_invalid(O1, false, withdraw(ACD));                    // never entered

  // From O0 every event but leave is valid, and by symmetry they lead to three states: one cut
  // edge, one entry node, one mid node.
  std::set<std::uint32_t> successors;
  std::size_t valid = 0;
  for (const CutEvent& e : all_cut_events()) {
    const Transition tr = apply_event(default_cut_table(), MachineState{}, e);
    if (!tr.valid) continue;
    ++valid;
    successors.insert(state_key(tr.next));
  }
  CHECK(valid == 14);
  CHECK(successors == std::set<std::uint32_t>{state_key(state_of(A0, false)), state_key(state_of(O1, false)),
                                              state_key(state_of({0, ABC, 0}, false))});
}

namespace {

// Coarse faces and edges, to check that every created node lies on one (invariant 5).
bool on_coarse_simplex(const TetMesh& coarse, const Vec3& p) {
  for (const TetId t : coarse.tets()) {
    const auto n = coarse.tet_nodes(t);
    for (int f = 0; f < 4; ++f) {
      const auto& fv = kFaceVertices[static_cast<size_t>(f)];
      const Vec3 a = coarse.rest(n[fv[0]]), b = coarse.rest(n[fv[1]]), c = coarse.rest(n[fv[2]]);
      const Vec3 normal = (b - a).cross(c - a);
      if (std::abs(normal.normalized().dot(p - a)) > 1e-12) continue;
      const double area = normal.norm();
      const double s =
          (b - p).cross(c - p).norm() + (c - p).cross(a - p).norm() + (a - p).cross(b - p).norm();
      if (s <= area * (1 + 1e-12)) return true;
    }
  }
  return false;
}

void check_state(const CutTable& table, const MachineState& s, const Perm4& perm, bool embedded) {
  // The state seen through `perm`: local element i is reference element perm^-1(i).
  const CutTopology local = permute(s.topology, perm.inverse());
  TetMesh mesh = embedded ? make_box({.cells = {3, 3, 3}}) : TetMesh{};
  if (!embedded) {
    const NodeId a = mesh.add_node(Vec3(0, 0, 0)), b = mesh.add_node(Vec3(1, 0, 0)),
                 c = mesh.add_node(Vec3(0.2, 1, 0)), d = mesh.add_node(Vec3(0.3, 0.2, 1));
    mesh.add_tet({a, b, c, d});
  }
  std::uint32_t target = 0;
  if (embedded) {
    // A tetrahedron of the central cube.
    for (const TetId t : mesh.tets()) {
      Vec3 c = Vec3::Zero();
      for (const NodeId n : mesh.tet_nodes(t)) c += mesh.rest(n) / 4;
      if ((c - Vec3::Constant(0.5)).cwiseAbs().maxCoeff() < 1.0 / 6) {
        target = t.index;
        break;
      }
    }
  }
  const double volume = mesh.total_rest_volume();
  const std::size_t n0 = mesh.node_capacity();
  CutEngine cutter(mesh, {.table = &table});
  cutter.impose(target, local, s.complete);
  const auto r = validate(mesh, {.reference_volume = volume, .check_current = true});
  REQUIRE_MESSAGE(r.ok(), table.label(s.topology, s.complete) << ": " << r.summary());
  // The cut topology the state claims, and the stored state and transformation map back to it.
  CHECK(cutter.topology(target) == local);
  const CanonicalState stored = cutter.state(target);
  CHECK(stored.reference == s.topology);
  CHECK(permute(local, stored.transform) == s.topology);
  for (std::uint32_t n = static_cast<std::uint32_t>(n0); n < mesh.node_capacity(); ++n)
    if (mesh.node_slot_alive(n)) REQUIRE(on_coarse_simplex(cutter.coarse(), mesh.rest(mesh.node_handle(n))));
  if (!embedded && s.complete) {
    // A lone tetrahedron cut completely around a vertex (1|3) or along a loop (2|2) falls apart,
    // unless the tip pierced one of its faces: then the tip's path bounds the cut inside it.
    const EdgeClass c = edge_class(s.topology.edges);
    const bool through = c == EdgeClass::ThreeAroundVertex || c == EdgeClass::FourLoop;
    const std::size_t parts = connected_components(mesh).count();
    if (planar_edges(s.topology.edges)) {
      if (!through) CHECK(parts == 1u);
      if (through && s.topology.entries == 0) CHECK(parts == 2u);
    } else {
      // A fold (classes H-K): every vertex its cut edges surround comes free, as if cut alone, so
      // the pieces are the vertices joined by uncut edges; the tip's path does not hold them.
      std::array<int, 4> root{0, 1, 2, 3};
      const auto find = [&](int v) {
        while (root[static_cast<size_t>(v)] != v) v = root[static_cast<size_t>(v)];
        return v;
      };
      for (int e = 0; e < 6; ++e)
        if (!(s.topology.edges & (1u << e)))
          root[static_cast<size_t>(find(kEdgeVertices[static_cast<size_t>(e)][0]))] =
              find(kEdgeVertices[static_cast<size_t>(e)][1]);
      std::size_t joined = 0;
      for (int v = 0; v < 4; ++v) joined += find(v) == v ? 1 : 0;
      CHECK(parts == joined);
    }
  }
}

}  // namespace

TEST_CASE("exhaustive table check: every reachable state under all 24 permutations, alone and embedded" *
          doctest::test_suite("slow")) {
  const CutTable& table = default_cut_table();
  const auto states = reachable_states(table);
  std::size_t checked = 0;
  for (const auto& s : states)
    for (const Perm4& perm : Perm4::all())
      for (const bool embedded : {false, true}) {
        CAPTURE(table.label(s.topology, s.complete));
        CAPTURE(embedded);
        check_state(table, s, perm, embedded);
        ++checked;
      }
  MESSAGE("checked " << checked << " (state, permutation, neighbourhood) cases");
}

TEST_CASE("the state listing and the Graphviz drawing hold the reachable machine") {
  const CutTable& table = default_cut_table();
  const std::string listing = state_listing(table);
  std::size_t lines = 0;
  for (std::size_t at = 0; (at = listing.find('\n', at)) != std::string::npos; ++at) ++lines;
  CHECK(lines == 2 + reachable_states(table).size());  // two comment lines, then one per state
  CHECK(listing.find("\nD3  AB AC AD | ") != std::string::npos);

  const std::string dot = state_dot(table);
  CHECK(dot.rfind("// The cut state machine", 0) == 0);
  for (const char letter : std::string("OABCDEGHIJK"))
    for (const char digit : std::string("0123"))
      CHECK(dot.find(std::string{letter, digit}) != std::string::npos);
  CHECK(dot.find("B0 -> H0 [label=\"cut\"]") != std::string::npos);  // a fold
  CHECK(dot.find("B3 -> H") == std::string::npos);  // a second surface in an end state: continuation
  CHECK(dot.find("D0 -> D3 [label=\"leave\"]") != std::string::npos);
  CHECK(dot.find("B0 -> D0 [label=\"cut\"]") != std::string::npos);
  CHECK(dot.find("O1 -> O0 [label=\"withdraw\", style=dotted]") != std::string::npos);
  CHECK(dot.find("D3 -> D0 [label=\"cross, withdraw\", color=grey50, fontcolor=grey50]") !=
        std::string::npos);
  CHECK(dot.find("D0 -> B0") == std::string::npos);  // a cut is never undone
}

TEST_CASE("changes of state no events make are named, the others pass") {
  const CutTable& table = default_cut_table();
  const std::uint32_t o0 = MachineState{}.key();
  const std::uint32_t a0 = state_of({AB, ABC | ABD, 0}, false).key();
  CHECK(unreached_transitions(table, {{{o0, a0}, 3}}).empty());
  const std::string undone = unreached_transitions(table, {{{o0, a0}, 3}, {{a0, o0}, 2}});
  CHECK(undone == "A0 -> O0 (" + std::to_string(a0) + " -> " + std::to_string(o0) + ", 2 times)\n");
}
