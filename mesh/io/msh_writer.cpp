// The tetrahedral mesh as a Gmsh .msh, ASCII 2.2 (mesh/io/mesh_io.hpp write_msh).

#include <map>
#include <string>
#include <vector>

#include "mesh/io/mesh_io.hpp"
#include "mesh/io/writer.hpp"

namespace scalpel {

using mesh_io::append;
using mesh_io::append_point;
using mesh_io::write_text;

void write_msh(const TetMesh& mesh, const std::string& path, const std::map<int, std::string>& region_names) {
  std::vector<long long> number(mesh.node_capacity(), 0);
  long long nodes = 0;
  for (std::uint32_t n = 0; n < mesh.node_capacity(); ++n)
    if (mesh.node_slot_alive(n)) number[n] = ++nodes;
  std::string out = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n";
  if (!region_names.empty()) {
    out += "$PhysicalNames\n" + std::to_string(region_names.size()) + "\n";
    for (const auto& [id, name] : region_names) out += "3 " + std::to_string(id + 1) + " \"" + name + "\"\n";
    out += "$EndPhysicalNames\n";
  }
  out += "$Nodes\n" + std::to_string(nodes) + "\n";
  for (std::uint32_t n = 0; n < mesh.node_capacity(); ++n) {
    if (!mesh.node_slot_alive(n)) continue;
    append(out, number[n]);
    out += ' ';
    append_point(out, mesh.positions()[n]);
    out += '\n';
  }
  out += "$EndNodes\n$Elements\n" + std::to_string(mesh.tet_count()) + "\n";
  long long element = 0;
  for (std::uint32_t t = 0; t < mesh.tet_capacity(); ++t) {
    if (!mesh.tet_slot_alive(t)) continue;
    // Type 4 (4-node tetrahedron), two tags: the physical (region id + 1: Gmsh numbers from 1) and
    // the elementary entity, the same.
    const long long tag = mesh.region(mesh.tet_handle(t)) + 1;
    append(out, ++element);
    out += " 4 2 ";
    append(out, tag);
    out += ' ';
    append(out, tag);
    for (const std::uint32_t v : mesh.tet_vertex_indices(t)) {
      out += ' ';
      append(out, number[v]);
    }
    out += '\n';
  }
  out += "$EndElements\n";
  write_text(path, out);
}

}  // namespace scalpel
