// The wound an incision leaves at the tissue surface: how far its lips stand apart, along it.
//
// A cut node whose rest position lies on the outer surface of the uncut mesh is a point of the
// incision's edge at the skin. While the crack is closed there, live elements use one real copy of
// it; once the blade has passed and the cut surface surrounds it, one copy per side (the paper's
// virtual nodes made real, section 4.1). Those copies are the same material point on the two lips,
// so their distance, less its part along the incision, is the lateral gape there. A surface cut
// node with a single copy is a bridge: tissue still joins the lips (gape 0).
#pragma once

#include <cstddef>
#include <span>
#include <vector>

#include "cutting/cut_engine.hpp"
#include "mesh/mesh.hpp"

namespace scalpel {

struct WoundGape {
  // One surface cut node, by its place along the path.
  struct Point {
    double s = 0;         // arc length of its nearest point on the path [m]
    double gape = 0;      // lateral gape [m]
    bool bridge = false;  // still closed: one copy
  };
  std::size_t surface_nodes = 0;  // surface cut nodes measured
  std::size_t bridges = 0;        // of those, still closed
  double mean = 0, max = 0;       // lateral gape over the measured nodes [m]
  // Mean gape of the nodes within the window around the middle of the path, or of the node nearest
  // to it when none is (0 without a path) [m].
  double middle = 0;
  std::vector<Point> profile;  // along the path, by s (empty without one)
};

class WoundMeter {
 public:
  // Keeps the outer surface of `uncut` in rest coordinates.
  explicit WoundMeter(const TetMesh& uncut);

  // The gape of the cut nodes on that surface. With a path (at least two points), only nodes
  // within `band` [m] of it laterally (in the xy plane, as the task measures) are measured, the gape
  // is taken across the path's direction, and the middle is the mean over +-window/2 [m] around the
  // path's midpoint; without one, every surface cut node counts and the gape is the whole distance
  // between its copies.
  [[nodiscard]] WoundGape measure(const TetMesh& mesh, std::span<const CutEngine::CutNodeCopies> cuts,
                                  std::span<const Vec3> path, double band, double window) const;

 private:
  [[nodiscard]] bool on_surface(const Vec3& rest) const;

  struct Triangle {
    Vec3 a, b, c;
    Vec3 lo, hi;  // bounding box, widened by tolerance_
  };
  std::vector<Triangle> surface_;
  double tolerance_ = 0;  // [m] a point this close to a surface triangle lies on it
};

}  // namespace scalpel
