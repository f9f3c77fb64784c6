// The boundary surface as ASCII .ply (mesh/io/mesh_io.hpp write_boundary_ply).

#include <string>

#include "mesh/io/mesh_io.hpp"
#include "mesh/io/writer.hpp"

namespace scalpel {

using mesh_io::append;
using mesh_io::append_point;
using mesh_io::boundary_surface;
using mesh_io::Surface;
using mesh_io::write_text;

void write_boundary_ply(const TetMesh& mesh, const std::string& path) {
  const Surface s = boundary_surface(mesh);
  std::string out = "ply\nformat ascii 1.0\ncomment scalpelsim boundary surface\n";
  out += "element vertex " + std::to_string(s.vertex_slots.size()) + "\n";
  out += "property double x\nproperty double y\nproperty double z\n";
  out += "element face " + std::to_string(s.tris.size()) + "\n";
  out += "property list uchar int vertex_indices\nend_header\n";
  for (const std::uint32_t n : s.vertex_slots) {
    append_point(out, mesh.positions()[n]);
    out += '\n';
  }
  for (const auto& t : s.tris) {
    out += "3 ";
    append(out, static_cast<long long>(t[0]));
    out += ' ';
    append(out, static_cast<long long>(t[1]));
    out += ' ';
    append(out, static_cast<long long>(t[2]));
    out += '\n';
  }
  write_text(path, out);
}

}  // namespace scalpel
