#include "mesh/io/writer.hpp"

#include <fstream>

#include "base/input_error.hpp"
#include "mesh/topology.hpp"

namespace scalpel::mesh_io {

void write_text(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw InputError(path, 0, 0, "", "cannot open file for writing");
  out.write(text.data(), static_cast<std::streamsize>(text.size()));
  out.close();
  if (!out) throw InputError(path, 0, 0, "", "cannot write file");
}

Surface boundary_surface(const TetMesh& mesh) {
  const auto faces = boundary_faces(mesh);
  std::vector<std::uint32_t> number(mesh.node_capacity(), kInvalidIndex);
  for (const auto& f : faces)
    for (const std::uint32_t n : f.nodes) number[n] = 0;
  Surface s;
  for (std::uint32_t n = 0; n < number.size(); ++n)
    if (number[n] == 0) {
      number[n] = static_cast<std::uint32_t>(s.vertex_slots.size());
      s.vertex_slots.push_back(n);
    }
  s.tris.reserve(faces.size());
  for (const auto& f : faces) s.tris.push_back({number[f.nodes[0]], number[f.nodes[1]], number[f.nodes[2]]});
  return s;
}

void append_point(std::string& out, const Vec3& p) {
  append(out, p.x());
  out += ' ';
  append(out, p.y());
  out += ' ';
  append(out, p.z());
}

}  // namespace scalpel::mesh_io
