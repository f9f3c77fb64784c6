#include "mesh/validate.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>
#include <unordered_map>

#include "mesh/bvh.hpp"
#include "mesh/predicates.hpp"
#include "mesh/topology.hpp"

namespace scalpel {

namespace {

struct Collector {
  ValidationReport& report;
  const ValidationOptions& options;
  void add(Invariant inv, std::uint32_t element, std::string what) {
    report.passed[static_cast<size_t>(inv)] = false;
    if (report.violations.size() < options.max_violations)
      report.violations.push_back({inv, element, std::move(what)});
  }
};

std::string tet_text(const TetMesh& m, std::uint32_t t) {
  const auto& v = m.tet_vertex_indices(t);
  std::ostringstream s;
  s << "tet " << t << " (nodes " << v[0] << ' ' << v[1] << ' ' << v[2] << ' ' << v[3] << ")";
  return s.str();
}

std::uint64_t edge_key(std::uint32_t a, std::uint32_t b) {
  return (std::uint64_t{a} << 32) | b;
}

// Invariant 2, geometric part: a node strictly inside a boundary face or on the interior of one of
// its edges, without being a vertex of it, is a hanging node (a T-junction). Interior faces of a
// conforming mesh are matched, so every hanging node shows up on an unmatched (boundary) face.
// Only a node joined to the face by an edge to one of its vertices counts, and a node on an edge of
// the face only if joined to both ends of that edge: the two sides of an opened crack coincide in
// the rest configuration but share no node there but the crack's front, and may be triangulated
// differently (a later cut may split one side of an earlier crack, §6). A T-junction always has
// such a node: the split side's triangles at a corner of the face join the corner to a node inside
// the face or on its edges, and a split edge's piece ends join its node to both ends.
void check_hanging_nodes(const TetMesh& m, const std::vector<BoundaryFace>& faces, Collector& c) {
  // The boundary's nodes in a tree of their positions: a face's box finds the nodes near it at a
  // cost that depends neither on the spread of the face sizes nor on the coordinates' magnitude.
  if (faces.empty()) return;
  const auto& r = m.rest_positions();
  std::vector<AabbTree::LeafInput> points;
  std::vector<std::uint8_t> seen(m.node_capacity(), 0);
  for (const auto& f : faces)
    for (const std::uint32_t n : f.nodes)
      if (!seen[n]) {
        seen[n] = 1;
        points.push_back({Aabb{r[n], r[n]}, n});
      }
  AabbTree tree;
  std::vector<std::int32_t> leaf_ids, stack;
  tree.build(points, leaf_ids);
  for (const auto& f : faces) {
    const Vec3 &a = r[f.nodes[0]], &b = r[f.nodes[1]], &d = r[f.nodes[2]];
    const Vec3 lo = a.cwiseMin(b).cwiseMin(d), hi = a.cwiseMax(b).cwiseMax(d);
    const Vec3 normal = (b - a).cross(d - a);
    const double same = 1e-10 * std::max({(b - a).norm(), (d - b).norm(), (a - d).norm()});
    int drop = 0;
    normal.cwiseAbs().maxCoeff(&drop);
    const Aabb box{lo, hi};
    tree.query([&](const Aabb& node_box) { return node_box.overlaps(box); },
               [&](const std::uint32_t n) {
                 if (n == f.nodes[0] || n == f.nodes[1] || n == f.nodes[2]) return;
                 const Vec3& p = r[n];
                 // Coincident copies across a cut; the two sides of a crack may compute one point in a
                 // different order, and cut nodes keep far more than this from any vertex (CutOptions).
                 if ((p - a).norm() <= same || (p - b).norm() <= same || (p - d).norm() <= same) return;
                 if ((p.array() < lo.array()).any() || (p.array() > hi.array()).any()) return;
                 if (orient3d(a, b, d, p) != 0) return;
                 const int s0 = orient2d_projected(a, b, p, drop), s1 = orient2d_projected(b, d, p, drop),
                           s2 = orient2d_projected(d, a, p, drop);
                 const bool inside = (s0 >= 0 && s1 >= 0 && s2 >= 0) || (s0 <= 0 && s1 <= 0 && s2 <= 0);
                 if (!inside) return;
                 // Which of the face's vertices the node is joined to; on an edge of the face, the split
                 // side of a T-junction joins it to both ends of that edge.
                 std::array<bool, 3> to{};
                 for (const std::uint32_t t : m.node_tets(m.node_handle(n)))
                   for (const std::uint32_t v : m.tet_vertex_indices(t))
                     for (size_t q = 0; q < 3; ++q) to[q] = to[q] || v == f.nodes[q];
                 bool joined = to[0] || to[1] || to[2];
                 auto on_edge = [&](const Vec3& u, const Vec3& w) {
                   return (w - u).cross(p - u).norm() <= same * (w - u).norm();
                 };
                 if (on_edge(a, b)) joined = to[0] && to[1];
                 if (on_edge(b, d)) joined = to[1] && to[2];
                 if (on_edge(d, a)) joined = to[2] && to[0];
                 if (joined) {
                   std::ostringstream s;
                   s << "node " << n << " lies on boundary face (" << f.nodes[0] << ' ' << f.nodes[1] << ' '
                     << f.nodes[2] << ") of " << tet_text(m, f.tet)
                     << " without being its vertex (hanging node)";
                   c.add(Invariant::Conforming, f.tet, s.str());
                 }
               },
               stack);
  }
}

// Two faces with the same vertices, the second's cyclic order the reverse of the first's.
bool opposite(const std::array<std::uint32_t, 3>& p, const std::array<std::uint32_t, 3>& q) {
  for (int s = 0; s < 3; ++s)
    if (q[0] == p[static_cast<size_t>(s)] && q[1] == p[static_cast<size_t>((s + 2) % 3)] &&
        q[2] == p[static_cast<size_t>((s + 1) % 3)])
      return true;
  return false;
}

// Invariant 4: the total rest volume equals the reference (relative 1e-12 per tetrahedron).
void check_volume(const TetMesh& m, const ValidationOptions& options, Collector& c) {
  if (!options.reference_volume) return;
  const double v0 = *options.reference_volume, v = m.total_rest_volume();
  const double tol = 1e-12 * std::max<double>(1.0, static_cast<double>(m.tet_count())) * std::abs(v0);
  if (std::abs(v - v0) <= tol) return;
  std::ostringstream s;
  s.precision(17);
  s << "total rest volume " << v << " differs from the original " << v0 << " by " << std::abs(v - v0)
    << " (tolerance " << tol << ")";
  c.add(Invariant::Volume, kInvalidIndex, s.str());
}

}  // namespace

const char* invariant_name(Invariant i) {
  switch (i) {
    case Invariant::Oriented:
      return "oriented";
    case Invariant::Conforming:
      return "conforming";
    case Invariant::Watertight:
      return "watertight";
    case Invariant::Volume:
      return "volume";
  }
  return "?";
}

std::string ValidationReport::summary() const {
  std::ostringstream s;
  for (const auto& v : violations)
    s << "invariant " << static_cast<int>(v.invariant) << " (" << invariant_name(v.invariant)
      << "): " << v.what << '\n';
  return s.str();
}

ValidationReport validate(const TetMesh& m, const ValidationOptions& options) {
  ValidationReport report;
  Collector c{report, options};
  const auto& r = m.rest_positions();
  const auto& x = m.positions();

  // 1. Oriented.
  for (std::uint32_t t = 0; t < m.tet_capacity(); ++t) {
    if (!m.tet_slot_alive(t)) continue;
    const auto& v = m.tet_vertex_indices(t);
    if (orient3d(r[v[0]], r[v[1]], r[v[2]], r[v[3]]) <= 0)
      c.add(Invariant::Oriented, t, tet_text(m, t) + " has non-positive rest volume");
    if (options.check_current && orient3d(x[v[0]], x[v[1]], x[v[2]], x[v[3]]) <= 0)
      c.add(Invariant::Oriented, t, tet_text(m, t) + " has non-positive current volume");
  }

  // 2. Conforming, combinatorial part: every face in at most two tets, with opposite orientations,
  // and the adjacency links agree with the face matching.
  struct FaceUse {
    std::uint32_t tet;
    int face;
    std::array<std::uint32_t, 3> oriented;
  };
  std::map<std::array<std::uint32_t, 3>, std::vector<FaceUse>> faces;
  for (std::uint32_t t = 0; t < m.tet_capacity(); ++t) {
    if (!m.tet_slot_alive(t)) continue;
    for (int f = 0; f < 4; ++f) {
      auto fv = face_vertex_indices(m, t, f);
      auto key = fv;
      std::sort(key.begin(), key.end());
      faces[key].push_back({t, f, fv});
    }
  }
  for (const auto& [key, uses] : faces) {
    if (uses.size() > 2) {
      c.add(Invariant::Conforming, uses[0].tet,
            "face (" + std::to_string(key[0]) + ' ' + std::to_string(key[1]) + ' ' + std::to_string(key[2]) +
                ") is shared by " + std::to_string(uses.size()) + " tetrahedra");
      continue;
    }
    if (uses.size() == 2) {
      // Opposite orientation: the second's cyclic order is the reverse of the first's.
      const auto& p = uses[0].oriented;
      const auto& q = uses[1].oriented;
      if (!opposite(p, q))
        c.add(Invariant::Conforming, uses[0].tet,
              tet_text(m, uses[0].tet) + " and " + tet_text(m, uses[1].tet) +
                  " share a face with the same orientation");
      const TetId a = m.tet_handle(uses[0].tet);
      if (m.neighbour(a, uses[0].face).index != uses[1].tet)
        c.add(Invariant::Conforming, uses[0].tet,
              tet_text(m, uses[0].tet) + " is not linked to its face neighbour " + tet_text(m, uses[1].tet));
    } else {
      const TetId a = m.tet_handle(uses[0].tet);
      if (!m.neighbour(a, uses[0].face).is_null())
        c.add(Invariant::Conforming, uses[0].tet,
              tet_text(m, uses[0].tet) + " is linked across a face no other tetrahedron has");
    }
  }
  const auto boundary = boundary_faces(m);
  check_hanging_nodes(m, boundary, c);

  // 3. Watertight: every directed boundary edge u->v is matched by as many v->u.
  std::unordered_map<std::uint64_t, int> directed;
  directed.reserve(boundary.size() * 3);
  for (const auto& f : boundary)
    for (int e = 0; e < 3; ++e)
      ++directed[edge_key(f.nodes[static_cast<size_t>(e)], f.nodes[static_cast<size_t>((e + 1) % 3)])];
  for (const auto& [key, count] : directed) {
    const auto u = static_cast<std::uint32_t>(key >> 32), v = static_cast<std::uint32_t>(key & 0xffffffffu);
    const auto it = directed.find(edge_key(v, u));
    const int back = it == directed.end() ? 0 : it->second;
    if (back != count)
      c.add(Invariant::Watertight, u,
            "boundary edge " + std::to_string(u) + "->" + std::to_string(v) + " appears " +
                std::to_string(count) + " times but " + std::to_string(v) + "->" + std::to_string(u) + " " +
                std::to_string(back) + " times");
  }

  check_volume(m, options, c);
  return report;
}

ValidationReport validate_local(const TetMesh& m, std::span<const std::uint32_t> nodes,
                                const ValidationOptions& options) {
  ValidationReport report;
  Collector c{report, options};
  const auto& r = m.rest_positions();
  const auto& x = m.positions();
  // Two rings of tetrahedra around the nodes: a node of the change may hang on a face of an element
  // that only shares the face's vertices with the change.
  auto star = [&](const std::vector<std::uint32_t>& around) {
    std::vector<std::uint32_t> out;
    for (const std::uint32_t n : around)
      if (m.node_slot_alive(n))
        for (const std::uint32_t t : m.node_tets(m.node_handle(n))) out.push_back(t);
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
    return out;
  };
  auto sorted_unique = [](std::vector<std::uint32_t> v) {
    std::sort(v.begin(), v.end());
    v.erase(std::unique(v.begin(), v.end()), v.end());
    return v;
  };
  std::vector<std::uint32_t> ring_nodes;
  for (const std::uint32_t t : star(sorted_unique({nodes.begin(), nodes.end()})))
    for (const std::uint32_t n : m.tet_vertex_indices(t)) ring_nodes.push_back(n);
  ring_nodes = sorted_unique(std::move(ring_nodes));
  const std::vector<std::uint32_t> tets = star(ring_nodes);

  auto holds = [&](std::uint32_t t, std::uint32_t n) {
    const auto& v = m.tet_vertex_indices(t);
    return std::find(v.begin(), v.end(), n) != v.end();
  };
  // The local faces of tets around node a that have no neighbour: (tet, face).
  auto boundary_edge_count = [&](std::uint32_t u, std::uint32_t v) {
    int count = 0;
    for (const std::uint32_t t : m.node_tets(m.node_handle(u)))
      for (int f = 0; f < 4; ++f) {
        if (!m.neighbour(m.tet_handle(t), f).is_null()) continue;
        const auto fv = face_vertex_indices(m, t, f);
        for (int e = 0; e < 3; ++e)
          count += fv[static_cast<size_t>(e)] == u && fv[static_cast<size_t>((e + 1) % 3)] == v ? 1 : 0;
      }
    return count;
  };

  std::vector<BoundaryFace> boundary;
  for (const std::uint32_t t : tets) {
    const auto& v = m.tet_vertex_indices(t);
    // 1. Oriented.
    if (orient3d(r[v[0]], r[v[1]], r[v[2]], r[v[3]]) <= 0)
      c.add(Invariant::Oriented, t, tet_text(m, t) + " has non-positive rest volume");
    if (options.check_current && orient3d(x[v[0]], x[v[1]], x[v[2]], x[v[3]]) <= 0)
      c.add(Invariant::Oriented, t, tet_text(m, t) + " has non-positive current volume");
    const TetId th = m.tet_handle(t);
    for (int f = 0; f < 4; ++f) {
      // 2. Conforming: the other tetrahedra on this face.
      const auto fv = face_vertex_indices(m, t, f);
      std::vector<std::uint32_t> others;
      for (const std::uint32_t u : m.node_tets(m.node_handle(fv[0])))
        if (u != t && holds(u, fv[1]) && holds(u, fv[2])) others.push_back(u);
      const TetId linked = m.neighbour(th, f);
      if (others.size() > 1) {
        c.add(Invariant::Conforming, t,
              tet_text(m, t) + " shares a face with " + std::to_string(others.size()) + " others");
      } else if (others.size() == 1) {
        if (linked.index != others[0])
          c.add(Invariant::Conforming, t,
                tet_text(m, t) + " is not linked to its face neighbour " + tet_text(m, others[0]));
        const int g = m.neighbour_face(th, f);
        if (g >= 0) {
          const auto q = face_vertex_indices(m, others[0], g);
          if (!opposite(fv, q))
            c.add(Invariant::Conforming, t,
                  tet_text(m, t) + " and " + tet_text(m, others[0]) +
                      " share a face with the same orientation");
        }
      } else {
        if (!linked.is_null())
          c.add(Invariant::Conforming, t,
                tet_text(m, t) + " is linked across a face no other tetrahedron has");
        boundary.push_back({t, f, fv});
        // 3. Watertight: every directed edge of this boundary face is matched around its nodes.
        for (int e = 0; e < 3; ++e) {
          const std::uint32_t u = fv[static_cast<size_t>(e)], w = fv[static_cast<size_t>((e + 1) % 3)];
          const int forward = boundary_edge_count(u, w), backward = boundary_edge_count(w, u);
          if (forward != backward)
            c.add(Invariant::Watertight, u,
                  "boundary edge " + std::to_string(u) + "->" + std::to_string(w) + " appears " +
                      std::to_string(forward) + " times but " + std::to_string(w) + "->" + std::to_string(u) +
                      " " + std::to_string(backward) + " times");
        }
      }
    }
  }
  check_hanging_nodes(m, boundary, c);

  check_volume(m, options, c);
  return report;
}

}  // namespace scalpel
