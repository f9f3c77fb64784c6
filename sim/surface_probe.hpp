// Where the tissue's outer surface is around the blade's tip: whether the tip is under it, how deep
// (the distance to the nearest point of the surface) and which way the surface faces there. The
// task score measures depth and the blade's bevel with it at the moment of cutting
// (docs/scoring.md), so on a curved or deformed organ depth is depth below the skin around the
// blade, not below a bounding box.
//
// The surface is the outer boundary of the uncut mesh. Cuts never split the original corner nodes
// (cutting/cut_engine.hpp), so its triangles stay defined by the corners' current positions as the
// tissue deforms; a triangle an incision has split spans its lips, which near the blade (where the
// crack has not yet opened) is still the skin. A deleted piece takes its corners with it, and the
// triangles on them go too (drop_faces_of), also one a cut split between that piece and the rest.
#pragma once

#include <array>
#include <cstdint>
#include <limits>
#include <optional>
#include <span>
#include <vector>

#include "mesh/bvh.hpp"
#include "mesh/mesh.hpp"

namespace scalpel {

struct SurfaceHit {
  double depth = 0;                     // [m] of the tip below the surface (see the functions)
  Vec3 point = Vec3::Zero();            // on the surface [m]
  Vec3 normal = Vec3::Zero();           // outward unit normal of the surface there
  std::array<std::uint32_t, 3> face{};  // node slots of its triangle (nearest() and entry())
};

class SurfaceProbe {
 public:
  // Keeps the outer boundary of `uncut` by its node slots.
  explicit SurfaceProbe(const TetMesh& uncut);

  // The first surface triangle the ray from `tip` towards `back` leaves the tissue through (its
  // outward normal along the ray), in `mesh`'s current positions; none when the ray leaves through
  // no triangle (the tip is not under the surface).
  [[nodiscard]] std::optional<SurfaceHit> above(const TetMesh& mesh, const Vec3& tip,
                                                const Vec3& back) const {
    return above(mesh.positions(), tip, back);
  }
  // The same in positions `x` by node slot.
  [[nodiscard]] std::optional<SurfaceHit> above(const std::vector<Vec3>& x, const Vec3& tip,
                                                const Vec3& back) const;

  // The deepest point of the blade in the tissue, in positions `x`: its tip when the tip is under
  // the surface (as above()), else the point where the blade, from its tip towards its back, first
  // enters the tissue: a blade pushed through the whole thickness cuts down to the far side. None
  // when the blade between tip and back does not meet the tissue.
  [[nodiscard]] std::optional<Vec3> deepest_in_tissue(const std::vector<Vec3>& x, const Vec3& tip,
                                                      const Vec3& back) const;

  // Where a point moving from `from` to `to` first crosses the surface into the tissue, in
  // positions `x`: the point, the triangle's outward normal and nodes, and how deep `to` lies below
  // that triangle's plane as `depth`. None when it does not cross the surface, or first crosses it
  // on the way out.
  [[nodiscard]] std::optional<SurfaceHit> entry(const std::vector<Vec3>& x, const Vec3& from,
                                                const Vec3& to) const;

  // The nearest point to `p`, in positions `x`, of the surface that faces `up` (outward normal
  // within kFacingDeg of it; the blade's axis towards its back): its distance as `depth`, the point
  // and the outward normal of its triangle. With the blade's axis as `up` this is the depth below
  // the skin the blade came through, on a curved organ too and however the blade leans within that
  // angle of the skin's normal; the far side of a thin layer faces away and is not taken for the
  // skin, nor is a side wall the blade stands parallel to (a slight lean does not make it skin).
  // Depth 0 when no triangle faces `up`. Given rest positions, `up` is still the blade's axis now:
  // the tissue's rotation under the blade is not undone.
  [[nodiscard]] SurfaceHit nearest(const std::vector<Vec3>& x, const Vec3& p, const Vec3& up) const;
  // Forgets the triangles with a corner among `removed` (sorted node slots of a deleted piece).
  void drop_faces_of(std::span<const std::uint32_t> removed);

  // Boxes the triangles in `mesh`'s current and rest positions, so that the queries in those
  // positions visit only the triangles near the point or the line (a tree of boxes, refitted, not
  // rebuilt). The owner calls it again whenever the positions move: a query in positions the probe
  // was not fitted to tests every triangle, but one in positions that moved since the fit would
  // miss triangles. Queries find the same triangle either way: among equals, the first in order
  // (but for a line that grazes a triangle, nearly in its plane, where rounding may place the
  // crossing anywhere along the line). Queries share scratch: one thread at a time.
  void fit(const TetMesh& mesh);
  // Whether the queries in `x` would use boxes that no longer hold its triangles: x moved since the
  // last fit (for checks; O(triangles)).
  [[nodiscard]] bool stale(const std::vector<Vec3>& x) const;

  static constexpr double kFacingDeg = 60;
  static constexpr double kFacingCos = 0.5;  // cos(kFacingDeg)

 private:
  // The nearest crossing of the blade's line, from its tip towards its back, with a triangle: its
  // distance from the tip, the triangle's (unnormalised, outward) normal, nodes and index, with the
  // line's unit direction and the blade's length.
  struct Crossing {
    double t = std::numeric_limits<double>::infinity();
    Vec3 normal = Vec3::Zero();
    std::array<std::uint32_t, 3> face{};
    std::size_t index = 0;  // in faces_
    Vec3 dir = Vec3::Zero();
    double length = 0;
    [[nodiscard]] bool leaving() const { return normal.dot(dir) > 0.0; }
  };
  // None for a blade of no length.
  [[nodiscard]] std::optional<Crossing> first_crossing(const std::vector<Vec3>& x, const Vec3& tip,
                                                       const Vec3& back) const;

  // The triangles' boxes in one set of positions, known by the vector that holds them (a mesh's,
  // which stays where it is as it grows: the triangles' corners keep their positions when nodes are
  // added).
  struct Boxes {
    const std::vector<Vec3>* positions = nullptr;
    AabbTree tree;  // leaf payload: index in faces_
    std::vector<std::int32_t> leaves;
    [[nodiscard]] bool fits(const std::vector<Vec3>& x) const { return positions == &x; }
  };
  void fit(Boxes& boxes, const std::vector<Vec3>& x);
  [[nodiscard]] const Boxes* boxes_for(const std::vector<Vec3>& x) const;
  [[nodiscard]] Aabb tight_box(const std::vector<Vec3>& x, std::size_t f) const;
  [[nodiscard]] Aabb face_box(const std::vector<Vec3>& x, std::size_t f) const;  // tight, and margin_

  std::vector<std::array<std::uint32_t, 3>> faces_;  // outward-oriented
  Boxes current_, rest_;
  double margin_ = 0;  // [m] each box grows by, beyond the rounding of the queries' tests (set once)
  mutable std::vector<std::int32_t> stack_;  // scratch of the tree's walks: one query at a time
  std::vector<std::int32_t> order_;          // scratch of the refit
};

}  // namespace scalpel
