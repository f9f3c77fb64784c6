// Mesh files (docs/architecture.md and docs/formats.md): readers for Gmsh .msh (ASCII 2.2 and 4.1), TetGen
// .node/.ele and VTK .vtu (XML, ASCII); writers for .vtu (with cell and point data) and for the boundary
// surface as Wavefront .obj and ASCII .ply.
//
// Readers keep only tetrahedra (Gmsh element type 4, VTK_TETRA = 10) and only the nodes they use, in
// file order. Positions become both rest and current positions. A tetrahedron given with negative
// orientation (exact orient3d) is re-oriented by swapping its last two vertices; a degenerate or
// repeated-vertex tetrahedron is an InputError. Every malformed input throws InputError naming the
// file, the line and the field. A node or element count above 100 million (mesh_io::kMaxItems) or
// above what the file's size can hold is refused before anything is allocated for it.
//
// The one public header of mesh/io/. Each format has its own source (gmsh.cpp, tetgen.cpp, vtu.cpp,
// obj.cpp, ply.cpp) over what they share: the text reader and its located errors (reader.hpp), the
// XML tokenizer (xml.hpp), the text writer and the boundary surface (writer.hpp), and the TetMesh
// built from a file's tetrahedra (raw_mesh.hpp).
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "mesh/mesh.hpp"

namespace scalpel {

// One region of a loaded mesh. Region ids are what TetMesh::region() returns.
struct MeshRegion {
  int id = 0;        // region id in the TetMesh
  int tag = 0;       // the file's number: Gmsh physical tag, TetGen region attribute, VTK "region" value
  std::string name;  // Gmsh $PhysicalNames name (dimension 3), empty if the file names none
};

// What a reader learnt besides the mesh.
//
// Region ids: Gmsh and TetGen tags are numbered 0, 1, 2, ... in increasing tag order (a tetrahedron
// without a physical tag or region attribute has tag 0); a .vtu "region" array is taken as the
// region id itself (id == tag), so a mesh written by write_vtu reads back with the same regions.
struct MeshFileInfo {
  std::vector<MeshRegion> regions;   // sorted by id
  std::size_t reoriented_tets = 0;   // tetrahedra given with negative orientation
  std::size_t skipped_elements = 0;  // elements that are not tetrahedra
  std::size_t unused_points = 0;     // points no tetrahedron uses (left out of the mesh)
  // The file gave rest positions besides the points (a .vtu's `rest_position` point array, as
  // scalpelsim writes): the mesh's rest positions are those, its current positions the points.
  bool has_rest_positions = false;

  // Region id of a physical name, or -1.
  [[nodiscard]] int region_id(std::string_view name) const;
  // Region id of a file tag, or -1.
  [[nodiscard]] int region_of_tag(int tag) const;
};

// Gmsh .msh, ASCII, format 2.2 or 4.1. Binary files are rejected with an InputError.
[[nodiscard]] TetMesh read_gmsh(const std::string& path, MeshFileInfo* info = nullptr);
// TetGen .node + .ele; `path` names either file, the other is found by changing the extension.
// Indices are 0- or 1-based, as the first point of the .node file says; the first tetrahedron
// attribute (tetgen -A) is the region tag.
[[nodiscard]] TetMesh read_tetgen(const std::string& path, MeshFileInfo* info = nullptr);
// VTK XML UnstructuredGrid, ASCII data arrays; cell data "region" (if present) gives the regions.
[[nodiscard]] TetMesh read_vtu(const std::string& path, MeshFileInfo* info = nullptr);
// The same readers on a file's text already in memory; `file` (and `node_file`, `ele_file`) name
// it in errors.
[[nodiscard]] TetMesh parse_gmsh(std::string text, const std::string& file, MeshFileInfo* info = nullptr);
[[nodiscard]] TetMesh parse_tetgen(std::string node_text, const std::string& node_file, std::string ele_text,
                                   const std::string& ele_file, MeshFileInfo* info = nullptr);
[[nodiscard]] TetMesh parse_vtu(std::string text, const std::string& file, MeshFileInfo* info = nullptr);
// Dispatches on the extension: .msh, .node or .ele, .vtu; anything else is an InputError.
[[nodiscard]] TetMesh read_mesh(const std::string& path, MeshFileInfo* info = nullptr);

// ---- .vtu output -------------------------------------------------------------------------------
// Extra arrays for write_vtu. Cell arrays hold one value per tet slot (size == tet_capacity()),
// point arrays one per node slot (size == node_capacity()), as the TetMesh slot arrays do; values of
// free slots are not written.
struct VtuIntCellArray {
  std::string name;
  std::vector<std::int64_t> values;
};
struct VtuRealCellArray {
  std::string name;
  std::vector<double> values;
};
struct VtuScalarPointArray {
  std::string name;
  std::vector<double> values;
};
struct VtuVectorPointArray {
  std::string name;
  std::vector<Vec3> values;
};

struct VtuData {
  std::vector<VtuIntCellArray> cell_ints;  // e.g. "component", "parent", "cut_state"
  std::vector<VtuRealCellArray> cell_reals;
  std::vector<VtuScalarPointArray> point_scalars;
  std::vector<VtuVectorPointArray> point_vectors;  // e.g. "rest_position", "displacement"
  // Written unless switched off: cell data "region" (Int32) from TetMesh::region, and one point array
  // per TetMesh field, named after it.
  bool region = true;
  bool mesh_fields = true;
};

// Points are the current positions of the live nodes and cells the live tetrahedra, both numbered
// compactly in slot order. Numbers are written in shortest round-trip form, so the same mesh and data
// give byte-identical files. Throws std::invalid_argument for an array of the wrong size or a repeated
// name, InputError if the file cannot be written.
void write_vtu(const TetMesh& mesh, const std::string& path, const VtuData& data = {});
[[nodiscard]] std::string vtu_text(const TetMesh& mesh, const VtuData& data = {});

// ---- boundary surface output ---------------------------------------------------------------------
// The boundary faces (mesh/topology.hpp boundary_faces, outward-oriented triangles) at current positions;
// vertices are the nodes on the boundary, numbered compactly in slot order.
void write_boundary_obj(const TetMesh& mesh, const std::string& path);
void write_boundary_ply(const TetMesh& mesh, const std::string& path);
// Binary STL: a triangle soup (each triangle its three corners and its unit normal, as floats); a
// reader that merges corners by position joins the copies of a node on the two lips of a closed cut.
void write_boundary_stl(const TetMesh& mesh, const std::string& path);

// ---- tetrahedral mesh output ---------------------------------------------------------------------
// Gmsh .msh, ASCII 2.2: the live nodes at current positions and the live tetrahedra, numbered from 1
// in slot order, each tagged region id + 1 (physical and elementary), with $PhysicalNames from
// `region_names` (region id -> name) when given. read_gmsh reads it back with the same regions in
// the same order and names (ids renumbered 0, 1, 2, ... as for any Gmsh file).
void write_msh(const TetMesh& mesh, const std::string& path,
               const std::map<int, std::string>& region_names = {});

}  // namespace scalpel
