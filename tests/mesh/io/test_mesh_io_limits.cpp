// Counts a mesh file declares are checked before anything is allocated for them, and the readers
// take a file's text as well as its path (the entry points of the fuzzers, fuzz/).
#include <doctest/doctest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "base/input_error.hpp"
#include "mesh/io/mesh_io.hpp"

using namespace scalpel;

namespace {

std::string write_scratch(const std::string& name, const std::string& text) {
  const std::filesystem::path dir = std::filesystem::path(SCALPEL_TEST_OUTPUT_DIR) / "mesh_io_limits";
  std::filesystem::create_directories(dir);
  const std::string path = (dir / name).string();
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

struct Expected {
  int line;
  const char* field;
  const char* message;
};

void check_refused(const std::string& path, const Expected& e) {
  CAPTURE(path);
  try {
    (void)read_mesh(path);
    FAIL("read without an error");
  } catch (const InputError& error) {
    CHECK(error.file() == path);
    CHECK(error.line() == e.line);
    CHECK(error.field() == e.field);
    CHECK_MESSAGE(std::string(error.what()).find(e.message) != std::string::npos, error.what());
  }
}

const std::string kMsh22 = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n";
const std::string kMsh41 = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n";
const std::string kNodes22 = "$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n$EndNodes\n";
const std::string kVtuHead =
    "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\">\n<UnstructuredGrid>\n";
const std::string kVtuPoints =
    "<Points>\n<DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">0 0 0</DataArray>\n"
    "</Points>\n";
const std::string kVtuTail = "</Piece>\n</UnstructuredGrid>\n</VTKFile>\n";

}  // namespace

TEST_CASE("mesh_io refuses a declared count of 2e9 nodes or elements before allocating") {
  const char* limit = "2000000000 nodes is more than the 100000000 a mesh file may have";
  check_refused(write_scratch("huge22.msh", kMsh22 + "$Nodes\n2000000000\n1 0 0 0\n$EndNodes\n"),
                {5, "$Nodes count", limit});
  check_refused(
      write_scratch("huge41.msh", kMsh41 + "$Nodes\n1 2000000000 1 2000000000\n0 1 0 1\n1\n0 0 0\n"),
      {5, "$Nodes count", limit});
  check_refused(write_scratch("huge_elements22.msh", kMsh22 + kNodes22 + "$Elements\n2000000000\n"),
                {12, "$Elements count", "2000000000 elements is more than the 100000000"});
  write_scratch("huge.ele", "1 4 0\n1 1 2 3 4\n");
  check_refused(write_scratch("huge.node", "2000000000 3 0 0\n1 0 0 0\n"),
                {1, "point count", "2000000000 points is more than the 100000000"});
  write_scratch("huge_tets.node", "4 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n");
  check_refused(write_scratch("huge_tets.ele", "2000000000 4 0\n1 1 2 3 4\n"),
                {1, "tetrahedron count", "2000000000 tetrahedra is more than the 100000000"});
  check_refused(
      write_scratch("huge.vtu", kVtuHead + "<Piece NumberOfPoints=\"2000000000\" NumberOfCells=\"1\">\n" +
                                    kVtuPoints + kVtuTail),
      {4, "NumberOfPoints", "2000000000 points is more than the 100000000"});
  check_refused(write_scratch("huge_cells.vtu",
                              kVtuHead + "<Piece NumberOfPoints=\"0\" NumberOfCells=\"2000000000\">\n"),
                {4, "NumberOfCells", "2000000000 cells is more than the 100000000"});
}

TEST_CASE("mesh_io refuses a declared count that the whole file cannot hold") {
  // Within the limit, but more than the file's size allows: reserving for them would take
  // gigabytes for a file of a few bytes.
  check_refused(write_scratch("short22.msh", kMsh22 + "$Nodes\n90000000\n1 0 0 0\n$EndNodes\n"),
                {5, "$Nodes count", "90000000 nodes declared, more lines than the file's 69 bytes can hold"});
  check_refused(write_scratch("short41.msh", kMsh41 + "$Nodes\n1 90000000 1 90000000\n0 1 0 1\n1\n0 0 0\n"),
                {5, "$Nodes count", "90000000 nodes declared, more lines than"});
  write_scratch("short.ele", "1 4 0\n1 1 2 3 4\n");
  check_refused(write_scratch("short.node", "# one point\n90000000 3 0 0\n1 0 0 0\n"),
                {2, "point count", "90000000 points declared, more lines than the file's 35 bytes can hold"});
  write_scratch("short_tets.node", "4 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n");
  check_refused(write_scratch("short_tets.ele", "90000000 4 0\n1 1 2 3 4\n"),
                {1, "tetrahedron count", "90000000 tetrahedra declared, more lines than"});
  check_refused(
      write_scratch("short.vtu", kVtuHead + "<Piece NumberOfPoints=\"90000000\" NumberOfCells=\"1\">\n" +
                                     kVtuPoints + kVtuTail),
      {4, "NumberOfPoints", "90000000 points declared, more than the file's"});
  // A file cut short a few nodes early is read up to its end, which the error names.
  check_refused(write_scratch("cut_short.msh", kMsh22 + "$Nodes\n5\n1 0 0 0\n2 1 0 0\n"),
                {7, "$Nodes count", "unexpected end of file, expected node 3 of 5"});
  const std::string exact = kMsh22 + kNodes22 + "$Elements\n1\n1 4 0 1 2 3 4\n$EndElements";
  CHECK(read_mesh(write_scratch("exact.msh", exact)).tet_count() == 1);
}

TEST_CASE("mesh_io reads a file's text as it reads the file") {
  const std::string msh = kMsh22 + kNodes22 + "$Elements\n1\n1 4 2 7 1 1 2 3 4\n$EndElements\n";
  MeshFileInfo info;
  const TetMesh m = parse_gmsh(msh, "mem.msh", &info);
  CHECK(m.tet_count() == 1);
  REQUIRE(info.regions.size() == 1);
  CHECK(info.regions[0].tag == 7);

  const std::string node = "4 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n", ele = "1 4 1\n1 1 2 4 3 5\n";
  const TetMesh t = parse_tetgen(node, "mem.node", ele, "mem.ele", &info);
  CHECK(t.tet_count() == 1);
  CHECK(info.reoriented_tets == 1);
  CHECK_THROWS_WITH_AS((void)parse_tetgen(node, "mem.node", "1 4 0\n1 1 2 3 9\n", "mem.ele"),
                       doctest::Contains("mem.ele:2:"), InputError);
  CHECK(vtu_text(parse_vtu(vtu_text(m), "mem.vtu")) == vtu_text(m));
  CHECK_THROWS_WITH_AS((void)parse_gmsh("$Nodes\n", "mem.msh"), doctest::Contains("mem.msh:1: $MeshFormat"),
                       InputError);
}
