// Picking and moving pieces of rigid tissue in the window (paper section 7.1: a separated piece is
// selected with the mouse and moved rigidly). Plain geometry on a snapshot and a camera, no OpenGL:
// the window turns the cursor into a ray, finds the piece under it, and shows the piece where the
// drag has taken it until the simulation has moved it there.
#pragma once

#include <cstdint>
#include <optional>

#include <Eigen/Core>

#include "sim/snapshot.hpp"
#include "viewer/camera.hpp"

namespace scalpel {

struct Ray {
  Vec3 origin = Vec3::Zero();
  Vec3 direction = Vec3::UnitZ();  // unit
};

// The ray through pixel (x, y) of a width x height picture (x right, y down, pixel centres at
// half-integers), from the near plane away from the eye.
[[nodiscard]] Ray camera_ray(const Camera& camera, double x, double y, int width, int height);

struct PieceHit {
  std::uint32_t piece = 0;      // index into FrameSnapshot::pieces
  Vec3 surface = Vec3::Zero();  // [m] where the ray meets the piece's surface
  Vec3 inside = Vec3::Zero();   // [m] a point just behind that face, in the piece (Simulation::piece_at)
  double distance = 0.0;        // [m] along the ray
};

// The nearest surface triangle facing the ray (the renderer culls the others), if it belongs to a
// piece; none when the snapshot has no pieces or the ray meets nothing.
[[nodiscard]] std::optional<PieceHit> pick_piece(const FrameSnapshot& snapshot, const Ray& ray);

// Where a ray meets the plane through `point` with normal `normal`, if it does (not parallel).
[[nodiscard]] std::optional<Vec3> ray_plane(const Ray& ray, const Vec3& point, const Vec3& normal);

// x -> centre + rotation (x - centre) + translation for the surface triangles and edges of `piece`
// (Simulation::move_piece turns about the piece's centroid too), normals turned with them.
void move_piece_preview(FrameSnapshot& snapshot, std::uint32_t piece, const Eigen::Matrix3d& rotation,
                        const Vec3& translation);

}  // namespace scalpel
