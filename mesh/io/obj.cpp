// The boundary surface as a Wavefront .obj (mesh/io/mesh_io.hpp write_boundary_obj).

#include <string>

#include "mesh/io/mesh_io.hpp"
#include "mesh/io/writer.hpp"

namespace scalpel {

using mesh_io::append;
using mesh_io::append_point;
using mesh_io::boundary_surface;
using mesh_io::Surface;
using mesh_io::write_text;

void write_boundary_obj(const TetMesh& mesh, const std::string& path) {
  const Surface s = boundary_surface(mesh);
  std::string out = "# scalpelsim boundary surface: " + std::to_string(s.vertex_slots.size()) +
                    " vertices, " + std::to_string(s.tris.size()) + " triangles\n";
  for (const std::uint32_t n : s.vertex_slots) {
    out += "v ";
    append_point(out, mesh.positions()[n]);
    out += '\n';
  }
  for (const auto& t : s.tris) {  // OBJ indices are 1-based
    out += "f ";
    append(out, static_cast<long long>(t[0]) + 1);
    out += ' ';
    append(out, static_cast<long long>(t[1]) + 1);
    out += ' ';
    append(out, static_cast<long long>(t[2]) + 1);
    out += '\n';
  }
  write_text(path, out);
}

}  // namespace scalpel
