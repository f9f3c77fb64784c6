// Collision step of progressive cutting (docs/state_machine.md; Bielser et al. 2003, sections 3-5).
//
// Between two tool samples k and k+1 the blade (back point P, tip T, world space [m]) sweeps the
// bilinear quad (P_k, T_k, T_k+1, P_k+1), split along the diagonal P_k-T_k+1 into the triangles
//   tri 0 = (P_k, T_k, T_k+1)    and    tri 1 = (P_k, T_k+1, P_k+1).
// Against the current (deformed) node positions the sweep reports
//   - edge cuts: mesh edges crossing the swept surface, with the direction of Eq. 1 (section 5);
//   - face pierces: the tip path T_k -> T_k+1 (and the back path P_k -> P_k+1) through a face;
//   - face crossings: faces crossed by the current blade segment P_k+1 -> T_k+1 (the ENP, 4.1);
//   - the tetrahedra touched by the swept surface or holding the current blade.
//
// Surface coordinates. A point of the quad has (s, u): s in [0,1] along the blade (0 back, 1 tip),
// u in [0,1] along the sweep (0 sample k, 1 sample k+1). Each triangle maps linearly to the
// parameter square: tri 0 to the corners (0,0), (1,0), (1,1); tri 1 to (0,0), (1,1), (0,1).
//
// Exactness and the degeneracy rule. Every crossing is decided by signs of orient3d (exact,
// mesh/predicates.hpp), evaluated as if every MESH node were displaced by the infinitesimal
//   delta = eps * e_x + eps^2 * e_y + eps^3 * e_z,   0 < eps -> 0,
// (equivalently, the blade surface is displaced by -delta). orient3d is linear in each point, so a
// zero determinant D is replaced by the sign of the first non-zero component (x, then y, then z)
// of its gradient g with respect to the displaced points, computed exactly:
//   blade triangle (p,q,r) vs mesh node a:      g = (q-p) x (r-p)
//   mesh triangle (a,b,c) vs blade point x:     g = -((b-a) x (c-a))
//   mesh edge (a,b) vs blade edge (p,q):        g = (b-a) x (q-p)   for orient3d(a,b,p,q).
// The displaced mesh is a real configuration, so all decisions of one sweep are mutually
// consistent, depend only on the entities involved (an edge's decision only on its two nodes and
// the blade, a face's only on its three nodes), and every tetrahedron sharing an edge or a face sees
// the same answer. Consequences:
//   - a node lying on the swept surface counts as lying on the side delta points to; an edge through
//     it is cut exactly when its other node is on the other side;
//   - an edge lying in the swept surface, or a blade moving in the plane of a face, cuts nothing;
//   - an edge through the diagonal P_k-T_k+1 is in exactly one triangle (counted once), and an edge
//     on the current blade line is in this sweep or the next one, never both (when the blade keeps
//     moving the same way);
//   - a tip passing exactly through a face edge or vertex pierces exactly one of the faces there.
// Degenerate blade triangles (zero area, e.g. a back point that did not move) are skipped. A twisted
// quad is folded along its diagonal: an edge that really crosses both triangles is reported twice,
// with two values of u (it ends on the side it started from).
//
// Threads: a BladeSweep belongs to the thread that owns the mesh (the sim thread).
// Parameters and points are then computed in floating point from the same determinants and
// clamped to their ranges: t is 0 or 1 only when the edge passes through an end node.
//
// Acceleration: a dynamic AABB tree over tetrahedra with fat boxes (mesh/bvh.hpp), refit as the
// mesh deforms and updated per tetrahedron as the cutter adds and removes them; a query visits the
// tree nodes whose boxes touch the swept triangles, so a sweep costs what the blade touches.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "mesh/bvh.hpp"
#include "mesh/mesh.hpp"

namespace scalpel {

// The blade at one tool sample, in world space [m].
struct BladePose {
  Vec3 back = Vec3::Zero();  // P
  Vec3 tip = Vec3::Zero();   // T
  // The direction the sharp edge faces (unit or zero), world space. Zero: v_tool of Eq. 1 is the
  // blade's own motion. Otherwise v_tool is this direction, interpolated between the two samples by u.
  Vec3 cutting_direction = Vec3::Zero();
};

// A mesh edge (node slots a < b) crossing the swept surface.
struct EdgeCut {
  std::uint32_t a = 0, b = 0;
  double t = 0;  // crossing = (1-t) x_a + t x_b
  Vec3 point = Vec3::Zero();
  double s = 0, u = 0;  // surface coordinates of the crossing (see above)
  // Eq. 1 (section 5): with P_prev, P_curr the projections of the crossing onto the blade lines of
  // samples k and k+1 and v_tool the blade's motion at s (or the cutting direction),
  // forward iff (P_curr - P_prev) . v_tool > 0. Only forward crossings cut.
  bool forward = false;
};

// A blade point's path (tip: T_k -> T_k+1) through the interior of a face. Reported once per
// tetrahedron owning the face (an interior face gives two records: entering one, leaving the other,
// with identical nodes, point, bary and u).
struct FacePierce {
  std::uint32_t tet = 0;
  int local_face = 0;
  std::array<std::uint32_t, 3> nodes{};  // node slots, ascending
  Vec3 point = Vec3::Zero();             // on the face: sum bary[i] * x(nodes[i])
  Vec3 bary = Vec3::Zero();              // with respect to `nodes`
  double u = 0;                          // along the path
  bool entering = false;                 // the point enters `tet` (leaves it otherwise)
};

// A face crossed by the current blade segment P_k+1 -> T_k+1 (the ENP, section 4.1). One record per
// owning tetrahedron, as for pierces.
struct FaceCrossing {
  std::uint32_t tet = 0;
  int local_face = 0;
  std::array<std::uint32_t, 3> nodes{};  // node slots, ascending
  Vec3 point = Vec3::Zero();             // on the face: sum bary[i] * x(nodes[i])
  Vec3 bary = Vec3::Zero();              // with respect to `nodes`
  double s = 0;                          // along the blade, 0 back, 1 tip
};

struct SweepResult {
  std::vector<EdgeCut> edges;            // sorted by (u, a, b): sweep order
  std::vector<FacePierce> pierces;       // tip path; sorted by (u, tet, local_face)
  std::vector<FaceCrossing> crossings;   // current blade; sorted by (s, tet, local_face)
  std::vector<std::uint32_t> tets;       // touched tetrahedron slots, ascending
  std::vector<FacePierce> back_pierces;  // back path P_k -> P_k+1; sorted by (u, tet, local_face)

  void clear() {
    edges.clear();
    pierces.clear();
    crossings.clear();
    tets.clear();
    back_pierces.clear();
  }
};

// One crossing of a segment (x0 -> x1) with a triangle, from the perturbed predicates above.
struct SegmentTriangleHit {
  double segment_param = 0;           // along the segment, from its first point
  Vec3 triangle_bary = Vec3::Zero();  // weights of the triangle's three points
  int side0 = 0;  // perturbed orientation of the segment's first point against the triangle
};

// Mesh segment (a, b) against blade triangle (p, q, r): true iff it crosses (rule above).
// Symmetric in a, b (the parameter is then measured from the first argument).
bool mesh_segment_crosses_blade_triangle(const Vec3& a, const Vec3& b, const Vec3& p, const Vec3& q,
                                         const Vec3& r, SegmentTriangleHit* hit = nullptr);
// Blade segment (x0, x1) against mesh triangle (a, b, c).
bool blade_segment_crosses_mesh_triangle(const Vec3& x0, const Vec3& x1, const Vec3& a, const Vec3& b,
                                         const Vec3& c, SegmentTriangleHit* hit = nullptr);

// The perturbed orientation signs (never 0 unless the configuration stays degenerate, which needs a
// zero-area triangle or parallel segments).
int perturbed_orient_blade_triangle_mesh_point(const Vec3& p, const Vec3& q, const Vec3& r, const Vec3& a);
int perturbed_orient_mesh_triangle_blade_point(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& x);
int perturbed_orient_mesh_edge_blade_edge(const Vec3& a, const Vec3& b, const Vec3& p, const Vec3& q);

class BladeSweep {
 public:
  struct Options {
    // Fat-box margin of a leaf, as a fraction of its tight box's longest side.
    double fat_fraction = 0.1;
    // false: every live tetrahedron is a candidate (the O(n) reference the tree is tested against).
    bool use_tree = true;
  };

  explicit BladeSweep(const TetMesh& mesh) : BladeSweep(mesh, Options{}) {}
  BladeSweep(const TetMesh& mesh, Options options);

  // Incremental updates after the cutter changed the mesh (call after TetMesh::add_tet, and for a
  // removed tetrahedron after or before TetMesh::remove_tet: its positions are not read).
  void on_tet_added(std::uint32_t tet);
  void on_tet_removed(std::uint32_t tet);
  // After node positions changed: O(number of tetrahedra); leaves whose tight box left their fat box
  // get a new fat box and their ancestors are recomputed (by walks up from each when few moved, by
  // one bottom-up pass otherwise). The tree's shape is kept. Returns how many leaves moved.
  std::size_t refit();
  // Rebuilds the tree over all live tetrahedra (balanced, tight fat boxes).
  void rebuild();

  // The collision step between samples `prev` (k) and `curr` (k+1). Clears and fills `out`,
  // reusing its capacity (no allocation in steady state).
  void sweep(const BladePose& prev, const BladePose& curr, SweepResult& out);

  [[nodiscard]] const AabbTree& tree() const { return tree_; }
  // Candidates examined by the last sweep (tetrahedra whose boxes touched the swept triangles).
  [[nodiscard]] std::size_t last_candidate_count() const { return candidates_.size(); }

 private:
  struct EdgeEntry {
    std::uint32_t a, b, tet;
  };
  struct FaceEntry {
    std::array<std::uint32_t, 3> nodes;  // ascending
    std::uint32_t tet;
    int local_face;
    bool same_orientation;  // ascending order is the outward order (an even permutation)
  };

  Aabb fat_box(std::uint32_t tet) const;
  Aabb tight_box(std::uint32_t tet) const;
  void gather_candidates(const std::array<Vec3, 4>& quad);
  // The passes of sweep() over the candidates: edges the swept quad (P_k, T_k, T_k+1, P_k+1)
  // crosses, faces the tip and back paths pierce and the current blade crosses, tetrahedra holding
  // the current blade's ends. Each adds the tetrahedra it touches to touched_.
  void cut_edges(const BladePose& prev, const BladePose& curr, const std::array<Vec3, 4>& quad,
                 SweepResult& out);
  void cross_faces(const BladePose& prev, const BladePose& curr, SweepResult& out);
  void hold_blade_ends(const BladePose& curr);

  const TetMesh& mesh_;
  Options options_;
  AabbTree tree_;
  std::vector<std::int32_t> leaf_of_tet_;  // by tet slot; kNullNode if not in the tree

  // Scratch, capacity reused between sweeps.
  std::vector<std::int32_t> stack_;
  std::vector<std::uint32_t> candidates_;
  std::vector<EdgeEntry> edge_entries_;
  std::vector<FaceEntry> face_entries_;
  std::vector<std::uint32_t> touched_;
};

}  // namespace scalpel
