// The boundary surface as a binary STL (mesh/io/mesh_io.hpp write_boundary_stl).

#include <bit>
#include <cstdint>
#include <cstring>
#include <string>

#include "mesh/io/mesh_io.hpp"
#include "mesh/io/writer.hpp"

namespace scalpel {

using mesh_io::boundary_surface;
using mesh_io::Surface;
using mesh_io::write_text;

namespace {

// STL is little-endian, 32-bit IEEE floats and integers.
void put_u32(std::string& out, std::uint32_t v) {
  static_assert(std::endian::native == std::endian::little, "STL output assumes a little-endian machine");
  char b[4];
  std::memcpy(b, &v, 4);
  out.append(b, 4);
}
void put_f32(std::string& out, double v) {
  const auto f = static_cast<float>(v);
  char b[4];
  std::memcpy(b, &f, 4);
  out.append(b, 4);
}
void put_point(std::string& out, const Vec3& p) {
  for (int a = 0; a < 3; ++a) put_f32(out, p[a]);
}

}  // namespace

void write_boundary_stl(const TetMesh& mesh, const std::string& path) {
  const Surface s = boundary_surface(mesh);
  std::string out(80, ' ');
  const std::string header = "scalpelsim boundary surface, binary STL, metres";
  out.replace(0, header.size(), header);
  put_u32(out, static_cast<std::uint32_t>(s.tris.size()));
  const auto& x = mesh.positions();
  for (const auto& t : s.tris) {
    const Vec3 &a = x[s.vertex_slots[t[0]]], &b = x[s.vertex_slots[t[1]]], &c = x[s.vertex_slots[t[2]]];
    const Vec3 n = (b - a).cross(c - a);
    put_point(out, n.norm() > 0.0 ? Vec3(n.normalized()) : Vec3::Zero());
    put_point(out, a);
    put_point(out, b);
    put_point(out, c);
    out.append(2, '\0');  // attribute byte count
  }
  write_text(path, out);
}

}  // namespace scalpel
