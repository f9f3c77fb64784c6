#include "mesh/io/mesh_io.hpp"

#include <algorithm>
#include <cctype>

#include "base/input_error.hpp"

namespace scalpel {

int MeshFileInfo::region_id(std::string_view name) const {
  for (const auto& r : regions)
    if (r.name == name) return r.id;
  return -1;
}

int MeshFileInfo::region_of_tag(int tag) const {
  for (const auto& r : regions)
    if (r.tag == tag) return r.id;
  return -1;
}

TetMesh read_mesh(const std::string& path, MeshFileInfo* info) {
  const std::size_t dot = path.find_last_of('.');
  const std::size_t slash = path.find_last_of('/');
  std::string ext =
      dot == std::string::npos || (slash != std::string::npos && dot < slash) ? "" : path.substr(dot);
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (ext == ".msh") return read_gmsh(path, info);
  if (ext == ".node" || ext == ".ele") return read_tetgen(path, info);
  if (ext == ".vtu") return read_vtu(path, info);
  throw InputError(path, 0, 0, "mesh file",
                   "unknown mesh format '" + ext + "' (expected .msh, .node, .ele or .vtu)");
}

}  // namespace scalpel
