// A mesh file's tetrahedra before they enter a TetMesh, and the one step that builds the TetMesh
// from them for every reader (mesh/io/mesh_io.hpp): region ids, vertex checks, orientation, and
// only the nodes the tetrahedra use. Not part of the public API.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "mesh/io/mesh_io.hpp"
#include "mesh/mesh.hpp"

namespace scalpel::mesh_io {

// A file's tetrahedra before they enter a TetMesh: vertex indices into `points` (file order).
struct RawMesh {
  std::vector<Vec3> points;
  std::vector<Vec3> rest;  // rest positions per point when the file has them (our .vtu); else empty
  std::vector<std::array<std::uint32_t, 4>> tets;
  std::vector<int> tags;   // region tag per tet
  std::vector<int> lines;  // line of each tet in `tet_file`
  std::string tet_file;
  bool tags_are_ids = false;  // .vtu: the tag is the region id
  std::size_t skipped = 0;
};

// The TetMesh of `raw` (re-orienting its tetrahedra in place), and into `info` (if given) the
// regions and counts. InputError for a repeated vertex or a degenerate tetrahedron.
[[nodiscard]] TetMesh build_mesh(RawMesh& raw, MeshFileInfo* info);

}  // namespace scalpel::mesh_io
