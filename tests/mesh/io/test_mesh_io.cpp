#include <doctest/doctest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "base/input_error.hpp"
#include "mesh/generators.hpp"
#include "mesh/io/mesh_io.hpp"
#include "mesh/mesh.hpp"
#include "mesh/topology.hpp"
#include "mesh/validate.hpp"

using namespace scalpel;

namespace {

std::string scratch_path(const std::string& name) {
  const std::filesystem::path dir = std::filesystem::path(SCALPEL_TEST_OUTPUT_DIR) / "mesh_io_scratch";
  std::filesystem::create_directories(dir);
  return (dir / name).string();
}

std::string write_scratch(const std::string& name, const std::string& text) {
  const std::string path = scratch_path(name);
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

void check_valid(const TetMesh& m) {
  const auto report = validate(m, {.reference_volume = m.total_rest_volume()});
  CHECK_MESSAGE(report.ok(), report.summary());
}

double region_volume(const TetMesh& m, int region) {
  double v = 0;
  for (const TetId t : m.tets())
    if (m.region(t) == region) v += m.rest_volume(t);
  return v;
}

// The error a reader throws for `path`, or a failed check if it throws none.
InputError read_error(const std::string& path) {
  try {
    (void)read_mesh(path);
  } catch (const InputError& e) {
    return e;
  }
  FAIL("no InputError for " << path);
  return InputError(path, 0, 0, "", "");
}

constexpr double kBlockVolume = 0.04 * 0.03 * 0.02;  // [m^3], box_inclusion.geo and layered_box.poly

}  // namespace

TEST_CASE("mesh_io reads the Gmsh 2.2 and 4.1 meshes of box_inclusion.geo") {
  MeshFileInfo info22, info41;
  const TetMesh m22 = read_gmsh(SCALPEL_TEST_MSH22, &info22);
  const TetMesh m41 = read_mesh(SCALPEL_TEST_MSH41, &info41);
  for (const auto* p : {&m22, &m41}) {
    const TetMesh& m = *p;
    CHECK(m.tet_count() > 300);
    CHECK(m.tet_count() < 20000);
    check_valid(m);
    CHECK(connected_components(m).count() == 1);
    // The outer surface is the box itself, so the total volume is exact up to rounding.
    CHECK(m.total_rest_volume() == doctest::Approx(kBlockVolume).epsilon(1e-9));
  }
  for (const auto* info : {&info22, &info41}) {
    REQUIRE(info->regions.size() == 2);
    // Physical tags in increasing order become regions 0, 1.
    CHECK(info->regions[0].tag == 10);
    CHECK(info->regions[0].name == "tissue");
    CHECK(info->regions[1].tag == 20);
    CHECK(info->regions[1].name == "inclusion");
    CHECK(info->region_id("inclusion") == 1);
    CHECK(info->region_id("bone") == -1);
    CHECK(info->region_of_tag(10) == 0);
    CHECK(info->skipped_elements == 0);
  }
  // The inclusion is a faceted cylinder of radius 6 mm and height 10 mm: a little smaller.
  const double cylinder = std::numbers::pi * 0.006 * 0.006 * 0.01;
  const double inclusion = region_volume(m22, info22.region_id("inclusion"));
  CHECK(inclusion < cylinder);
  CHECK(inclusion > 0.9 * cylinder);
  // One geometry, one single-threaded mesher: both formats carry the same mesh.
  CHECK(m22.tet_count() == m41.tet_count());
  CHECK(m22.node_count() == m41.node_count());
  CHECK(region_volume(m41, 1) == doctest::Approx(inclusion).epsilon(1e-12));
}

TEST_CASE("mesh_io reads TetGen .node/.ele numbered from 1 and from 0") {
  MeshFileInfo one_info, zero_info;
  const TetMesh one = read_mesh(SCALPEL_TEST_TETGEN_ONE, &one_info);
  const TetMesh zero = read_tetgen(SCALPEL_TEST_TETGEN_ZERO, &zero_info);
  for (const auto* p : {&one, &zero}) {
    const TetMesh& m = *p;
    CHECK(m.tet_count() > 300);
    check_valid(m);
    CHECK(m.total_rest_volume() == doctest::Approx(kBlockVolume).epsilon(1e-9));
    // Region attribute 1 is the bottom layer (z < 8 mm), 2 the top one.
    CHECK(region_volume(m, 0) == doctest::Approx(0.04 * 0.03 * 0.008).epsilon(1e-9));
    CHECK(region_volume(m, 1) == doctest::Approx(0.04 * 0.03 * 0.012).epsilon(1e-9));
  }
  for (const auto* info : {&one_info, &zero_info}) {
    REQUIRE(info->regions.size() == 2);
    CHECK(info->regions[0].tag == 1);
    CHECK(info->regions[1].tag == 2);
    CHECK(info->regions[1].id == 1);
  }
  CHECK(one.tet_count() == zero.tet_count());
}

TEST_CASE("mesh_io re-orients negative tetrahedra and maps sparse node tags") {
  // Tags with large gaps; the second tetrahedron is given negatively; a triangle is skipped.
  const std::string path = write_scratch("sparse.msh",
                                         "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n"
                                         "$Nodes\n5\n"
                                         "7 0 0 0\n"
                                         "900000000 1 0 0\n"
                                         "12 0 1 0\n"
                                         "3 0 0 1\n"
                                         "44 0 0 -1\n"
                                         "$EndNodes\n"
                                         "$Elements\n3\n"
                                         "1 2 2 5 5 7 900000000 12\n"
                                         "2 4 2 5 1 7 900000000 12 3\n"
                                         "3 4 2 6 1 7 900000000 12 44\n"
                                         "$EndElements\n");
  MeshFileInfo info;
  const TetMesh m = read_mesh(path, &info);
  CHECK(m.tet_count() == 2);
  CHECK(m.node_count() == 5);
  CHECK(info.reoriented_tets == 1);
  CHECK(info.skipped_elements == 1);
  REQUIRE(info.regions.size() == 2);
  CHECK(info.regions[0].name.empty());
  CHECK(m.region(m.tets()[1]) == 1);
  check_valid(m);
  CHECK(m.total_rest_volume() == doctest::Approx(1.0 / 6.0 + 1.0 / 6.0));
}

TEST_CASE("mesh_io reads msh 4.1 entities, parametric node blocks and physical names") {
  const std::string path =
      write_scratch("entities41.msh",
                    "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n"
                    "$PhysicalNames\n2\n2 3 \"skin surface\"\n3 7 \"liver lobe\"\n$EndPhysicalNames\n"
                    "$Entities\n1 0 0 1\n"
                    "1 0 0 0 0\n"
                    "5 0 0 0 1 1 1 1 7 0\n"
                    "$EndEntities\n"
                    "$Nodes\n2 4 10 40\n"
                    "0 1 0 1\n10\n0 0 0\n"
                    "3 5 1 3\n20\n30\n40\n"
                    "1 0 0 0.5 0.5 0.5\n0 1 0 0.1 0.2 0.3\n0 0 1 0.1 0.2 0.3\n"
                    "$EndNodes\n"
                    "$Elements\n2 2 1 2\n"
                    "0 1 15 1\n1 10\n"
                    "3 5 4 1\n2 10 20 30 40\n"
                    "$EndElements\n");
  MeshFileInfo info;
  const TetMesh m = read_gmsh(path, &info);
  CHECK(m.tet_count() == 1);
  CHECK(m.node_count() == 4);
  CHECK(info.skipped_elements == 1);
  REQUIRE(info.regions.size() == 1);
  CHECK(info.regions[0].tag == 7);
  CHECK(info.region_id("liver lobe") == 0);
  CHECK(info.region_id("skin surface") == -1);  // a surface group is not a region
  CHECK(m.rest_volume(m.tets()[0]) == doctest::Approx(1.0 / 6.0));
}

TEST_CASE("mesh_io names file, line and field for malformed input") {
  struct Case {
    const char* file;
    const char* text;
    int line;
    const char* field;
  };
  const std::string fmt = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n";                        // lines 1-3
  const std::string nodes = "$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n$EndNodes\n";  // lines 4-10
  const std::string v41 = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n";
  const std::string node_file = "4 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n";
  const std::string vtu_head =
      "<?xml version=\"1.0\"?>\n"                                                 // 1
      "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\">\n"                     // 2
      "<UnstructuredGrid>\n"                                                      // 3
      "<Piece NumberOfPoints=\"4\" NumberOfCells=\"1\">\n"                        // 4
      "<Points>\n"                                                                // 5
      "<DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">\n"  // 6
      "0 0 0 1 0 0\n"                                                             // 7
      "0 1 0 0 0 1\n"                                                             // 8
      "</DataArray>\n"                                                            // 9
      "</Points>\n"                                                               // 10
      "<Cells>\n";                                                                // 11
  const std::string vtu_tail =
      "<DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">4</DataArray>\n"
      "<DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">10</DataArray>\n"
      "</Cells>\n</Piece>\n</UnstructuredGrid>\n</VTKFile>\n";
  const std::vector<std::pair<Case, std::string>> cases = {
      {{"truncated.msh", "", 8, "$Nodes count"}, fmt + "$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 0 1 0\n"},
      {{"bad_number.msh", "", 7, "node y"}, fmt + "$Nodes\n4\n1 0 0 0\n2 1 x 0\n"},
      {{"short_count.msh", "", 9, "$Nodes count"}, fmt + "$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 0 1 0\n$EndNodes\n"},
      {{"long_count.msh", "", 8, "$Nodes count"}, fmt + "$Nodes\n2\n1 0 0 0\n2 1 0 0\n3 0 1 0\n$EndNodes\n"},
      {{"no_elements.msh", "", 10, "$Elements"}, fmt + nodes},
      {{"no_nodes.msh", "", 7, "$Nodes"}, fmt + "$Elements\n1\n1 4 0 1 2 3 4\n$EndElements\n"},
      {{"missing_node.msh", "", 14, "element node"},
       fmt + nodes + "$Elements\n2\n1 4 0 1 2 3 4\n2 4 0 1 2 3 9\n$EndElements\n"},
      {{"degenerate.msh", "", 13, "tetrahedron"},
       fmt + "$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 1 1 0\n$EndNodes\n$Elements\n1\n1 4 0 1 2 3 "
             "4\n$EndElements\n"},
      {{"repeated.msh", "", 13, "tetrahedron"}, fmt + nodes + "$Elements\n1\n1 4 0 1 2 3 3\n$EndElements\n"},
      {{"short_element.msh", "", 13, "element node"},
       fmt + nodes + "$Elements\n1\n1 4 0 1 2 3\n$EndElements\n"},
      {{"binary.msh", "", 2, "$MeshFormat file-type"}, "$MeshFormat\n2.2 1 8\n\x01\n$EndMeshFormat\n"},
      {{"version.msh", "", 2, "$MeshFormat version"}, "$MeshFormat\n3.0 0 8\n$EndMeshFormat\n"},
      {{"not_msh.msh", "", 1, "$MeshFormat"}, "hello\n"},
      {{"unterminated.msh", "", 4, "$Comments"}, fmt + "$Comments\nno end\n"},
      {{"blocks41.msh", "", 5, "$Nodes count"},
       v41 + "$Nodes\n1 5 1 4\n3 1 0 4\n1\n2\n3\n4\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n$EndNodes\n"},
      {{"entity41.msh", "", 22, "element block entity tag"},
       v41 + "$Entities\n0 0 0 1\n1 0 0 0 1 1 1 1 5 0\n$EndEntities\n" +
           "$Nodes\n1 4 1 4\n3 1 0 4\n1\n2\n3\n4\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n$EndNodes\n" +
           "$Elements\n1 1 1 1\n3 2 4 1\n1 1 2 3 4\n$EndElements\n"},
      {{"range.ele", "", 4, "tetrahedron node"}, "# two tetrahedra\n2 4 0\n1 1 2 3 4\n2 1 2 3 5  # bad\n"},
      {{"few.ele", "", 2, "tetrahedron count"}, "2 4 0\n1 1 2 3 4\n"},
      {{"attribute.ele", "", 2, "region attribute"}, "1 4 1\n1 1 2 3 4 1.5\n"},
      {{"vtu_missing_value.vtu", "", 14, "DataArray 'connectivity'"},
       vtu_head + "<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n0 1 2\n</DataArray>\n" +
           vtu_tail},
      {{"vtu_bad_number.vtu", "", 13, "DataArray 'connectivity'"},
       vtu_head +
           "<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n0 1 2 z\n</DataArray>\n" +
           vtu_tail},
      {{"vtu_range.vtu", "", 14, "DataArray 'connectivity'"},
       vtu_head +
           "<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n0 1\n2 4\n</DataArray>\n" +
           vtu_tail},
      {{"vtu_binary.vtu", "", 12, "DataArray 'connectivity'"},
       vtu_head + "<DataArray type=\"Int64\" Name=\"connectivity\" format=\"binary\">\nAAAA\n</DataArray>\n" +
           vtu_tail},
      {{"vtu_truncated.vtu", "", 11, "<Cells>"}, vtu_head},
      {{"mesh.stl", "", 0, "mesh file"}, "solid\n"},
      // A volume element of another shape would leave a hole if left out; an unknown type is no
      // element at all. (Lines, triangles and points are left out: Gmsh writes them with a volume.)
      {{"hexahedron.msh", "", 14, "element type"},
       fmt + nodes + "$Elements\n2\n1 4 0 1 2 3 4\n2 5 0 1 2 3 4 1 2 3 4\n$EndElements\n"},
      {{"tet10.msh", "", 13, "element type"},
       fmt + nodes + "$Elements\n1\n1 11 0 1 2 3 4 1 2 3 4 1 2\n$EndElements\n"},
      {{"unknown_type.msh", "", 13, "element type"},
       fmt + nodes + "$Elements\n1\n1 999 0 1 2\n$EndElements\n"},
      {{"prism41.msh", "", 18, "element block type"},
       v41 + "$Nodes\n1 4 1 4\n3 1 0 4\n1\n2\n3\n4\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n$EndNodes\n" +
           "$Elements\n1 1 1 1\n3 1 6 1\n1 1 2 3 4 1 2\n$EndElements\n"},
      {{"vtu_hexahedron.vtu", "", 4, "DataArray 'types'"},
       vtu_head + "<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">0 1 2 3</DataArray>\n" +
           "<DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">4</DataArray>\n" +
           "<DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">12</DataArray>\n" +
           "</Cells>\n</Piece>\n</UnstructuredGrid>\n</VTKFile>\n"},
      {{"vtu_unknown_type.vtu", "", 4, "DataArray 'types'"},
       vtu_head + "<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">0 1 2 3</DataArray>\n" +
           "<DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">4</DataArray>\n" +
           "<DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">200</DataArray>\n" +
           "</Cells>\n</Piece>\n</UnstructuredGrid>\n</VTKFile>\n"},
  };
  // The .ele cases share one .node file.
  for (const char* stem : {"range", "few", "attribute"})
    write_scratch(std::string(stem) + ".node", node_file);
  for (const auto& [c, text] : cases) {
    const std::string name = c.file;
    CAPTURE(name);
    const std::string path = write_scratch(c.file, text);
    const InputError e = read_error(path);
    CHECK(e.file() == path);
    CHECK(e.line() == c.line);
    CHECK(e.field() == std::string(c.field));
    CHECK(std::string(e.what()).find(path) == 0);
  }
  // A .node problem names the .node file even when the .ele was asked for.
  write_scratch("short_node.node", "4 3 0 0\n1 0 0 0\n2 1 0 0\n");
  const InputError e = read_error(write_scratch("short_node.ele", "1 4 0\n1 1 2 3 4\n"));
  CHECK(e.file() == scratch_path("short_node.node"));
  CHECK(e.line() == 3);
  CHECK(e.field() == "point count");
  const InputError missing = read_error(scratch_path("does_not_exist.msh"));
  CHECK(std::string(missing.what()).find("cannot open") != std::string::npos);
}

namespace {

// A box with a hole in its slot numbering (a removed tet) and two regions.
TetMesh holed_box() {
  TetMesh m = make_box({.min = Vec3(-0.01, 0, 0), .max = Vec3(0.02, 0.01, 0.01), .cells = {3, 2, 2}});
  for (const TetId t : m.tets())
    if (m.rest_volume(t) > 0 && t.index % 3 == 0) m.set_region(t, 1);
  // Remove a boundary tet (slot 0 is at the min corner) to leave a free slot.
  m.remove_tet(m.tets().front());
  // Deform the current configuration so that current and rest positions differ.
  for (const NodeId n : m.nodes()) m.set_position(n, m.rest(n) * 1.1 + Vec3(0.1 / 3.0, 0, 0));
  const int f = m.add_field("dye");
  for (const NodeId n : m.nodes()) m.set_field(f, n, static_cast<double>(n.index) / 7.0);
  return m;
}

}  // namespace

TEST_CASE("mesh_io vtu round trip keeps counts, positions and regions") {
  const TetMesh m = holed_box();
  const Components comp = connected_components(m);
  VtuData data;
  std::vector<std::int64_t> component(m.tet_capacity(), -1), parent(m.tet_capacity(), -1);
  for (const TetId t : m.tets()) {
    component[t.index] = comp.of_tet[t.index];
    parent[t.index] = m.parent(t);
  }
  data.cell_ints = {{"component", component}, {"parent", parent}};
  data.cell_reals = {{"quality", std::vector<double>(m.tet_capacity(), 0.25)}};
  std::vector<Vec3> displacement(m.node_capacity());
  for (const NodeId n : m.nodes()) displacement[n.index] = m.position(n) - m.rest(n);
  data.point_vectors = {{"rest_position", m.rest_positions()}, {"displacement", displacement}};

  const std::string path = scratch_path("round_trip.vtu");
  write_vtu(m, path, data);
  const std::string text = slurp(path);
  CHECK(text == vtu_text(m, data));  // same mesh, same bytes
  for (const char* name : {"\"component\"", "\"parent\"", "\"quality\"", "\"rest_position\"",
                           "\"displacement\"", "\"dye\"", "\"region\""})
    CHECK(text.find(name) != std::string::npos);

  MeshFileInfo info;
  const TetMesh back = read_mesh(path, &info);
  REQUIRE(back.tet_count() == m.tet_count());
  // Nodes are compacted in slot order and the box's nodes are all used.
  REQUIRE(back.node_count() == m.node_count());
  const auto tets = m.tets(), back_tets = back.tets();
  bool same_positions = true, same_regions = true, same_vertices = true;
  const auto nodes = m.nodes();
  // Exact (shortest round trip): the points are the current positions, the rest_position array the
  // rest positions.
  for (std::size_t i = 0; i < nodes.size(); ++i)
    same_positions &=
        back.positions()[i] == m.position(nodes[i]) && back.rest_positions()[i] == m.rest(nodes[i]);
  for (std::size_t i = 0; i < tets.size(); ++i) {
    same_regions &= back.region(back_tets[i]) == m.region(tets[i]);
    for (int k = 0; k < 4; ++k)
      same_vertices &= back.tet_node(back_tets[i], k).index == m.tet_node(tets[i], k).index;
  }
  CHECK(same_positions);
  CHECK(same_regions);
  CHECK(same_vertices);  // slot 0 was the removed tet, not a node: node numbering is unchanged
  CHECK(info.reoriented_tets == 0);
  CHECK(info.has_rest_positions);
  CHECK(info.unused_points == 0);
  REQUIRE(info.regions.size() == 2);
  CHECK(info.regions[1].id == 1);
  check_valid(back);
}

TEST_CASE("mesh_io write_vtu rejects arrays of the wrong size or a repeated name") {
  const TetMesh m = holed_box();
  VtuData wrong;
  wrong.cell_ints = {{"component", std::vector<std::int64_t>(m.tet_count(), 0)}};  // tet_count < capacity
  CHECK_THROWS_AS((void)vtu_text(m, wrong), std::invalid_argument);
  VtuData repeated;
  repeated.point_scalars = {{"dye", std::vector<double>(m.node_capacity(), 0.0)}};  // also a mesh field
  CHECK_THROWS_AS((void)vtu_text(m, repeated), std::invalid_argument);
  repeated.mesh_fields = false;
  CHECK_NOTHROW((void)vtu_text(m, repeated));
  CHECK_THROWS_AS(write_vtu(m, scratch_path("no_such_dir/x.vtu")), InputError);
}

namespace {

struct Triangles {
  std::size_t vertices = 0;
  std::vector<Vec3> points;
  std::vector<std::array<long, 3>> tris;  // 0-based
};

// Each undirected edge in exactly two triangles, each directed edge once (consistent orientation).
void check_closed(const Triangles& s) {
  std::map<std::pair<long, long>, int> undirected, directed;
  for (const auto& t : s.tris)
    for (int e = 0; e < 3; ++e) {
      const long a = t[static_cast<std::size_t>(e)], b = t[static_cast<std::size_t>((e + 1) % 3)];
      ++directed[{a, b}];
      ++undirected[{std::min(a, b), std::max(a, b)}];
    }
  bool two = true, once = true;
  for (const auto& [edge, n] : undirected) two &= n == 2;
  for (const auto& [edge, n] : directed) once &= n == 1;
  CHECK(two);
  CHECK(once);
}

// Enclosed volume by the divergence theorem: positive for an outward-oriented surface.
double enclosed_volume(const Triangles& s) {
  double v = 0;
  for (const auto& t : s.tris)
    v += s.points[static_cast<std::size_t>(t[0])].dot(
             s.points[static_cast<std::size_t>(t[1])].cross(s.points[static_cast<std::size_t>(t[2])])) /
         6.0;
  return v;
}

Triangles parse_obj(const std::string& path) {
  Triangles s;
  std::istringstream in(slurp(path));
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream l(line);
    std::string kind;
    l >> kind;
    if (kind == "v") {
      Vec3 p;
      l >> p.x() >> p.y() >> p.z();
      s.points.push_back(p);
    } else if (kind == "f") {
      std::array<long, 3> t{};
      l >> t[0] >> t[1] >> t[2];
      s.tris.push_back({t[0] - 1, t[1] - 1, t[2] - 1});
    }
  }
  return s;
}

Triangles parse_ply(const std::string& path) {
  Triangles s;
  std::istringstream in(slurp(path));
  std::string word;
  std::size_t nv = 0, nf = 0;
  while (in >> word && word != "end_header") {
    if (word == "element") {
      std::string what;
      std::size_t n = 0;
      in >> what >> n;
      (what == "vertex" ? nv : nf) = n;
    }
  }
  for (std::size_t i = 0; i < nv; ++i) {
    Vec3 p;
    in >> p.x() >> p.y() >> p.z();
    s.points.push_back(p);
  }
  for (std::size_t i = 0; i < nf; ++i) {
    int count = 0;
    std::array<long, 3> t{};
    in >> count >> t[0] >> t[1] >> t[2];
    CHECK(count == 3);
    s.tris.push_back(t);
  }
  CHECK(in);
  return s;
}

}  // namespace

TEST_CASE("mesh_io writes the boundary of a box as a closed outward surface (obj, ply)") {
  const TetMesh m = make_box({.cells = {2, 2, 2}, .split = CubeSplit::Six});
  const auto boundary = boundary_faces(m);
  const std::string obj = scratch_path("box.obj"), ply = scratch_path("box.ply");
  write_boundary_obj(m, obj);
  write_boundary_ply(m, ply);
  for (const Triangles& s : {parse_obj(obj), parse_ply(ply)}) {
    CHECK(s.points.size() == 26u);  // the 3x3x3 grid without its centre node
    CHECK(s.tris.size() == boundary.size());
    check_closed(s);
    CHECK(enclosed_volume(s) == doctest::Approx(1.0).epsilon(1e-12));
  }
}

TEST_CASE("mesh_io writes the vtu that meshio reads") {
  // Used by the CTest check mesh_io_meshio_reads_vtu (tests/CMakeLists.txt), which reads this file
  // with python3-meshio and compares with the counts written next to it.
  const TetMesh m = holed_box();
  VtuData data;
  data.point_vectors = {{"rest_position", m.rest_positions()}};
  const std::string dir = SCALPEL_TEST_OUTPUT_DIR;
  write_vtu(m, dir + "/meshio_check.vtu", data);
  std::ofstream(dir + "/meshio_check.counts")
      << m.node_count() << ' ' << m.tet_count() << ' ' << m.tet_count() << '\n';
  const TetMesh back = read_vtu(dir + "/meshio_check.vtu");
  CHECK(back.tet_count() == m.tet_count());
}

TEST_CASE(
    "mesh_io writes a Gmsh 2.2 mesh that reads back with its nodes, tetrahedra and named regions, and a "
    "binary STL of the boundary") {
  TetMesh m = holed_box();
  for (const TetId t : m.tets()) m.set_region(t, m.rest_volume(t) > 0 && t.index % 3 == 0 ? 2 : 0);
  const std::string dir = SCALPEL_TEST_OUTPUT_DIR;
  write_msh(m, dir + "/written.msh", {{0, "rock"}, {2, "clay"}});
  MeshFileInfo info;
  const TetMesh back = read_mesh(dir + "/written.msh", &info);
  REQUIRE(back.tet_count() == m.tet_count());
  CHECK(back.node_count() == m.node_count());
  double current = 0.0;  // the file holds the current positions
  for (const TetId t : m.tets()) current += m.current_volume(t);
  CHECK(back.total_rest_volume() == doctest::Approx(current).epsilon(1e-12));
  REQUIRE(info.regions.size() == 2);
  CHECK(info.regions[0].name == "rock");
  CHECK(info.regions[1].name == "clay");
  std::size_t clay = 0, clay_back = 0;
  for (const TetId t : m.tets()) clay += m.region(t) == 2 ? 1 : 0;
  for (const TetId t : back.tets()) clay_back += back.region(t) == 1 ? 1 : 0;  // ids renumbered 0, 1
  CHECK(clay_back == clay);
  CHECK(validate(back).ok());

  write_boundary_stl(m, dir + "/written.stl");
  const auto faces = boundary_faces(m);
  CHECK(std::filesystem::file_size(dir + "/written.stl") == 84 + 50 * faces.size());
}
