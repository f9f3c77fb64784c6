// What a picture of one simulation frame needs, copied out of the live state (docs/threads.md): the
// simulation thread fills a FrameSnapshot after each frame and publishes it; a renderer reads only
// snapshots, never the mesh the next frame is changing. Plain data, no OpenGL.
//
// The surface is every boundary face of the live tetrahedra, split in two kinds:
// - skin: a face on the outer surface of the uncut mesh, coloured by its region;
// - wound: a face of the cut surface (the crack the blade opened, paper section 4.1).
// A face is on the outer surface when its rest points lie on a boundary face of the original
// tetrahedron it was cut from (TetMesh::parent); every other boundary face was made by a cut.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "mesh/mesh.hpp"

namespace scalpel {

class Simulation;

// How a scalar field's values become colours: viridis (sequential, perceptually uniform) or a
// blue-white-red diverging map centred on the middle of the range (seismic amplitudes).
enum class ColourMap { Viridis, Seismic };

// One vertex of a surface triangle, ready for a vertex buffer: position and face normal (current
// configuration, float), and the region id of a skin face or kWoundRegion for a wound face.
struct SurfaceVertex {
  static constexpr float kWoundRegion = -1.0f;
  std::array<float, 3> position{};
  std::array<float, 3> normal{};
  float region = 0.0f;
  float value = 0.0f;  // the shown field's value at the vertex (FrameSnapshot::field), else 0
};

struct FrameSnapshot {
  std::uint64_t frame = 0;  // simulation frames since the start
  double time = 0.0;        // [s] simulation time at the end of the frame

  // Wound triangles first (wound_vertices of them, three vertices each), then the skin's.
  std::vector<SurfaceVertex> surface;
  std::size_t wound_vertices = 0;
  // Every tetrahedron edge once, as pairs of points, when the builder was asked for them.
  std::vector<std::array<float, 3>> edges;

  // The blade where the last tool sample put it [m]; none before the first sample.
  bool has_blade = false;
  Vec3 blade_back = Vec3::Zero(), blade_tip = Vec3::Zero();
  // From the edge to the spine across the blade at its back point [m] (the spine meets the edge
  // at the tip), zero without flats (sim/tool_body.hpp); the handle's radius and length [m], zero
  // when the scenario gives none.
  Vec3 blade_spine = Vec3::Zero();
  double handle_radius = 0.0, handle_length = 0.0;

  // The instructor's target incisions (the scenario's task), empty without one.
  struct Target {
    std::vector<Vec3> path;
    double tolerance = 0.0;  // [m]
  };
  std::vector<Target> targets;

  // The scalar field the surface is coloured by (SurfaceVertex::value), none: by region.
  struct Field {
    std::string name;
    double lo = 0.0, hi = 1.0;  // the values at the colour map's ends
    ColourMap colour_map = ColourMap::Viridis;
  };
  std::optional<Field> field;

  // With rigid tissue, whose pieces can be moved: the piece of every surface triangle and of every
  // edge (an index into `pieces`), and each piece's volume and centroid now, where a move turns it
  // (Simulation::move_piece). Empty otherwise.
  struct Piece {
    Vec3 centroid = Vec3::Zero();  // [m]
    double volume = 0.0;           // [m^3] now
    std::size_t tetrahedra = 0;
  };
  std::vector<std::uint32_t> triangle_piece, edge_piece;
  std::vector<Piece> pieces;

  // Bounding box of the uncut mesh's rest positions, for framing views [m].
  Vec3 bounds_min = Vec3::Zero(), bounds_max = Vec3::Zero();

  std::size_t nodes = 0, tetrahedra = 0;
};

// Builds snapshots of one simulation's mesh. Built once from the uncut mesh (it keeps that mesh's
// outer faces in rest coordinates); `fill` then reuses the snapshot's storage frame after frame.
class SnapshotBuilder {
 public:
  explicit SnapshotBuilder(const TetMesh& uncut);

  // Colour the surface by mesh field `id` (its values go to SurfaceVertex::value) as `field` says.
  void show_field(int id, FrameSnapshot::Field field) {
    field_id_ = id;
    field_ = std::move(field);
  }

  // Fill in the pieces (FrameSnapshot::pieces) too.
  void show_pieces(bool on) { pieces_ = on; }

  // The surface (and with `with_edges` the edges) of `mesh` now, into `out`.
  void fill_surface(const TetMesh& mesh, bool with_edges, FrameSnapshot& out) const;
  // The surface, the blade, the task and the counts of `sim` after a frame.
  void fill(const Simulation& sim, bool with_edges, FrameSnapshot& out) const;

 private:
  // Whether the face with rest points a, b, c of a tetrahedron cut from original tet `parent` lies
  // on the outer surface of the uncut mesh.
  [[nodiscard]] bool on_outer_surface(std::uint32_t parent, const Vec3& a, const Vec3& b,
                                      const Vec3& c) const;

  // An original tetrahedron with a face on the boundary: its rest corners and which of its faces
  // are (bit f: the face opposite corner f).
  struct Original {
    std::array<Vec3, 4> corners;
    std::uint8_t boundary_faces = 0;
  };
  std::vector<std::uint32_t> boundary_index_;  // by original slot: index into boundary_, or none
  std::vector<Original> boundary_;
  Vec3 bounds_min_ = Vec3::Zero(), bounds_max_ = Vec3::Zero();
  int field_id_ = -1;
  bool pieces_ = false;
  std::optional<FrameSnapshot::Field> field_;
};

}  // namespace scalpel
