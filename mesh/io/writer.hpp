// Writing mesh files as text (mesh/io/mesh_io.hpp): numbers in shortest round-trip form, the file
// written at once, and the boundary surface shared by the .obj and .ply writers. Not part of the
// public API.
#pragma once

#include <array>
#include <charconv>
#include <cstdint>
#include <string>
#include <vector>

#include "mesh/mesh.hpp"

namespace scalpel::mesh_io {

// Shortest round-trip decimal form: the same double always gives the same characters.
inline void append(std::string& out, double v) {
  char buf[32];
  const auto [end, ec] = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, end);
}
inline void append(std::string& out, long long v) {
  char buf[24];
  const auto [end, ec] = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, end);
}

// `text` as the whole file at `path`; InputError if it cannot be written.
void write_text(const std::string& path, const std::string& text);

// The boundary faces (topology.hpp boundary_faces) with their nodes numbered compactly.
struct Surface {
  std::vector<std::uint32_t> vertex_slots;         // boundary nodes in slot order
  std::vector<std::array<std::uint32_t, 3>> tris;  // compact vertex numbers, outward
};
[[nodiscard]] Surface boundary_surface(const TetMesh& mesh);

// "x y z" of a point.
void append_point(std::string& out, const Vec3& p);

}  // namespace scalpel::mesh_io
