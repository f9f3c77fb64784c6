#include <doctest/doctest.h>

#include <map>
#include <set>

#include "base/input_error.hpp"
#include "cutting/cut_engine.hpp"
#include "cutting/cut_table.hpp"
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

TEST_CASE("reachable states: a search over events from O0, every pair resolved") {
  const CutTable& table = default_cut_table();
  const auto states = reachable_states(table);
  MESSAGE("reachable states: " << states.size());
  std::set<std::string> labels;
  std::size_t valid = 0, invalid = 0;
  for (const auto& s : states) {
    labels.insert(table.label(s.topology, s.complete));
    CHECK(table.representable(s.topology.edges));
    for (const CutEvent& e : all_cut_events()) {
      const Transition tr = apply_event(table, s, e);
      if (!tr.valid) {
        ++invalid;
        continue;
      }
      ++valid;
      // The successor is itself reachable, and the relative transformation maps it correctly.
      CHECK(std::find(states.begin(), states.end(), tr.next) != states.end());
    }
  }
  MESSAGE("transitions: " << valid << " valid, " << invalid << " invalid (recursive continuation)");
  for (const char* l : {"O0", "O1", "A0", "A1", "B0", "C0", "D3", "E3", "G0"}) CHECK(labels.count(l) == 1);
  CHECK(labels.count("H0") == 0);  // three cut edges on one face are not planar
  CHECK(valid + invalid == states.size() * all_cut_events().size());
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
    if (!through) CHECK(parts == 1u);
    if (through && s.topology.entries == 0) CHECK(parts == 2u);
  }
}

}  // namespace

TEST_CASE("exhaustive table check: every reachable state under all 24 permutations, alone and embedded") {
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
  CHECK(checked == states.size() * 48);
}
