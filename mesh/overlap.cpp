#include "mesh/overlap.hpp"

#include <algorithm>
#include <sstream>

#include "mesh/bvh.hpp"
#include "mesh/predicates.hpp"

namespace scalpel {

namespace {

constexpr int kEdges[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};

// Whether the plane of a face of `t` has all of `other` on its outer side or on it.
bool face_separates(const std::array<Vec3, 4>& t, const std::array<Vec3, 4>& other) {
  for (int apex = 0; apex < 4; ++apex) {
    const Vec3& a = t[static_cast<std::size_t>((apex + 1) % 4)];
    const Vec3& b = t[static_cast<std::size_t>((apex + 2) % 4)];
    const Vec3& c = t[static_cast<std::size_t>((apex + 3) % 4)];
    const int inner = orient3d(a, b, c, t[static_cast<std::size_t>(apex)]);
    bool apart = true;
    for (const Vec3& q : other)
      if (orient3d(a, b, c, q) * inner > 0) {
        apart = false;
        break;
      }
    if (apart) return true;
  }
  return false;
}

// Whether the edges (p0, p1) and (q0, q1) are parallel: their cross product is zero, each of its
// components decided exactly.
bool parallel(const Vec3& p0, const Vec3& p1, const Vec3& q0, const Vec3& q1) {
  const Vec3 origin = Vec3::Zero();
  for (int axis = 0; axis < 3; ++axis)
    if (orient_directions(p0, p1, q0, q1, origin, Vec3::Unit(axis)) != 0) return false;
  return true;
}

// Whether the direction across edge (p0, p1) of `a` and edge (q0, q1) of `b` separates them: every
// vertex of `b` lies on the same side of every vertex of `a` along it, or on it. Parallel edges
// (checked only when every sign is zero, as all are for them) span no direction.
bool edges_separate(const std::array<Vec3, 4>& a, const std::array<Vec3, 4>& b, const Vec3& p0,
                    const Vec3& p1, const Vec3& q0, const Vec3& q1) {
  int seen = 0;
  for (const Vec3& x : a)
    for (const Vec3& y : b) {
      const int s = orient_directions(p0, p1, q0, q1, x, y);
      if (s == 0) continue;
      if (seen == 0) seen = s;
      if (s != seen) return false;
    }
  // Every vertex on one plane: either parallel edges, which span no direction at all, or (for
  // tetrahedra that are not flat) never.
  return seen != 0 || !parallel(p0, p1, q0, q1);
}

std::array<Vec3, 4> rest_vertices(const TetMesh& mesh, std::uint32_t t) {
  std::array<Vec3, 4> v;
  const auto& ids = mesh.tet_vertex_indices(t);
  for (std::size_t k = 0; k < 4; ++k) v[k] = mesh.rest_positions()[ids[k]];
  return v;
}

// Whether two boxes share an interior point: tetrahedra in boxes that only touch cannot overlap.
bool interiors_meet(const Aabb& a, const Aabb& b) {
  return (a.lo.array() < b.hi.array()).all() && (b.lo.array() < a.hi.array()).all();
}

// For two tetrahedra sharing a face (slot indices), whether their other vertices lie on the same
// side of it: the face's plane separates them otherwise.
bool fold_across_face(const TetMesh& mesh, std::uint32_t s, std::uint32_t t) {
  const auto& u = mesh.tet_vertex_indices(s);
  const auto& v = mesh.tet_vertex_indices(t);
  std::array<std::uint32_t, 3> face{};
  std::uint32_t apex_s = 0, apex_t = 0;
  std::size_t shared = 0;
  for (const std::uint32_t x : u) {
    if (std::find(v.begin(), v.end(), x) != v.end()) {
      if (shared < 3) face[shared] = x;
      ++shared;
    } else {
      apex_s = x;
    }
  }
  for (const std::uint32_t x : v)
    if (std::find(u.begin(), u.end(), x) == u.end()) apex_t = x;
  const auto& r = mesh.rest_positions();
  return orient3d(r[face[0]], r[face[1]], r[face[2]], r[apex_s]) *
             orient3d(r[face[0]], r[face[1]], r[face[2]], r[apex_t]) >
         0;
}

std::size_t shared_vertices(const TetMesh& mesh, std::uint32_t s, std::uint32_t t) {
  const auto& u = mesh.tet_vertex_indices(s);
  const auto& v = mesh.tet_vertex_indices(t);
  std::size_t n = 0;
  for (const std::uint32_t x : u) n += std::find(v.begin(), v.end(), x) != v.end() ? 1 : 0;
  return n;
}

}  // namespace

bool tetrahedra_overlap(const std::array<Vec3, 4>& a, const std::array<Vec3, 4>& b) {
  if (face_separates(a, b) || face_separates(b, a)) return false;
  for (const auto& ea : kEdges)
    for (const auto& eb : kEdges) {
      const Vec3& p0 = a[static_cast<std::size_t>(ea[0])];
      const Vec3& p1 = a[static_cast<std::size_t>(ea[1])];
      const Vec3& q0 = b[static_cast<std::size_t>(eb[0])];
      const Vec3& q1 = b[static_cast<std::size_t>(eb[1])];
      if (edges_separate(a, b, p0, p1, q0, q1)) return false;
    }
  return true;
}

OverlapReport check_overlaps(const TetMesh& mesh, std::size_t keep) {
  OverlapReport out;
  std::vector<AabbTree::LeafInput> leaves;
  leaves.reserve(mesh.tet_count());
  std::vector<Aabb> leaves_box(mesh.tet_capacity());
  for (std::uint32_t t = 0; t < mesh.tet_capacity(); ++t) {
    if (!mesh.tet_slot_alive(t)) continue;
    Aabb box;
    for (const Vec3& p : rest_vertices(mesh, t)) box.extend(p);
    leaves.push_back({box, t});
    leaves_box[t] = box;
  }
  AabbTree tree;
  std::vector<std::int32_t> leaf_ids;
  tree.build(leaves, leaf_ids);
  std::vector<std::int32_t> stack;
  for (const AabbTree::LeafInput& leaf : leaves) {
    const std::array<Vec3, 4> a = rest_vertices(mesh, leaf.payload);
    tree.query([&](const Aabb& box) { return box.overlaps(leaf.box); },
               [&](std::uint32_t other) {
                 if (other <= leaf.payload || !interiors_meet(leaf.box, leaves_box[other])) return;
                 // Tetrahedra sharing a face overlap only folded across it; the same four vertices
                 // twice always do.
                 const std::size_t shared = shared_vertices(mesh, leaf.payload, other);
                 const bool overlap = shared == 4   ? true
                                      : shared == 3 ? fold_across_face(mesh, leaf.payload, other)
                                                    : tetrahedra_overlap(a, rest_vertices(mesh, other));
                 if (!overlap) return;
                 ++out.pairs;
                 if (out.first.size() < keep) out.first.push_back({leaf.payload, other});
               },
               stack);
  }
  return out;
}

std::string OverlapReport::summary(const TetMesh& mesh) const {
  std::ostringstream s;
  s.precision(6);
  s << pairs << (pairs == 1 ? " pair" : " pairs") << " of overlapping tetrahedra";
  if (!first.empty()) {
    const auto centre = [&](std::uint32_t t) {
      Vec3 c = Vec3::Zero();
      for (const Vec3& p : rest_vertices(mesh, t)) c += p / 4.0;
      std::ostringstream q;
      q.precision(6);
      q << "tetrahedron " << t << " (centre " << c.x() << ", " << c.y() << ", " << c.z() << ")";
      return q.str();
    };
    s << "; first: " << centre(first.front()[0]) << " and " << centre(first.front()[1]);
  }
  return s.str();
}

}  // namespace scalpel
