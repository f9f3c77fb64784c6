// TetGen .node and .ele (mesh/io/mesh_io.hpp read_tetgen).
// Reference: TetGen 1.5 user manual, section 5.2 (".node" and ".ele" files).

#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <utility>

#include "base/input_error.hpp"
#include "mesh/io/mesh_io.hpp"
#include "mesh/io/raw_mesh.hpp"
#include "mesh/io/reader.hpp"

namespace scalpel {

using mesh_io::build_mesh;
using mesh_io::LineReader;
using mesh_io::RawMesh;
using mesh_io::read_file;

namespace {

// The .node file's points into `raw`; returns the index of the first point (0 or 1).
long long read_nodes(LineReader& r, RawMesh& raw) {
  long long base = 0;
  r.require_line("point count", "the .node header");
  const long long count = r.read_count("point count", 1, "points");
  const long long dim = r.read_int("dimension");
  if (dim != 3) r.fail("dimension", "must be 3, found " + std::to_string(dim));
  const long long nattr = r.read_int("number of attributes", 0, 1'000'000);
  const long long nmarkers = r.read_int("number of boundary markers", 0, 1);
  r.expect_line_end(".node header");
  raw.points.reserve(static_cast<std::size_t>(count));
  for (long long i = 0; i < count; ++i) {
    if (!r.next_line())
      r.fail_line("point count",
                  "file ends after " + std::to_string(i) + " of " + std::to_string(count) + " points");
    const long long index = r.read_int("point index");
    if (i == 0) {
      if (index != 0 && index != 1) r.fail("point index", "the first point must be numbered 0 or 1");
      base = index;
    } else if (index != base + i) {
      r.fail("point index", "expected " + std::to_string(base + i) + " (points are numbered consecutively)");
    }
    Vec3 x;
    x.x() = r.read_double("point x");
    x.y() = r.read_double("point y");
    x.z() = r.read_double("point z");
    for (long long k = 0; k < nattr; ++k) (void)r.read_double("point attribute");
    if (nmarkers) (void)r.read_int("point boundary marker");
    r.expect_line_end("point");
    raw.points.push_back(x);
  }
  if (r.next_line()) r.fail_line("point count", "more points than the count says");
  return base;
}

// The .ele file's tetrahedra into `raw`, their nodes numbered from `base`.
void read_elements(LineReader& r, long long base, RawMesh& raw) {
  r.require_line("tetrahedron count", "the .ele header");
  const long long count = r.read_count("tetrahedron count", 1, "tetrahedra");
  const long long per = r.read_int("nodes per tetrahedron");
  if (per != 4 && per != 10) r.fail("nodes per tetrahedron", "must be 4 or 10, found " + std::to_string(per));
  const long long nattr = r.read_int("number of attributes", 0, 1'000'000);
  r.expect_line_end(".ele header");
  const auto npoints = static_cast<long long>(raw.points.size());
  raw.tet_file = r.file();
  raw.tets.reserve(static_cast<std::size_t>(count));
  for (long long i = 0; i < count; ++i) {
    if (!r.next_line())
      r.fail_line("tetrahedron count",
                  "file ends after " + std::to_string(i) + " of " + std::to_string(count) + " tetrahedra");
    (void)r.read_int("tetrahedron index");
    std::array<std::uint32_t, 4> v{};
    for (long long k = 0; k < per; ++k) {
      const long long n = r.read_int("tetrahedron node", base, base + npoints - 1);
      if (k < 4) v[static_cast<std::size_t>(k)] = static_cast<std::uint32_t>(n - base);
    }
    int tag = 0;
    for (long long k = 0; k < nattr; ++k) {
      const double a = r.read_double("region attribute");
      if (k == 0) {
        if (a != std::floor(a) || std::abs(a) > 1e9) r.fail("region attribute", "must be an integer");
        tag = static_cast<int>(a);
      }
    }
    r.expect_line_end("tetrahedron");
    raw.tets.push_back(v);
    raw.tags.push_back(tag);
    raw.lines.push_back(r.line_no());
  }
  if (r.next_line()) r.fail_line("tetrahedron count", "more tetrahedra than the count says");
}

}  // namespace

TetMesh read_tetgen(const std::string& path, MeshFileInfo* info) {
  const std::size_t dot = path.find_last_of('.');
  const std::size_t slash = path.find_last_of('/');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash))
    throw InputError(path, 0, 0, "", "expected a .node or .ele file");
  const std::string stem = path.substr(0, dot);
  const std::string node_path = stem + ".node", ele_path = stem + ".ele";

  RawMesh raw;
  long long base = 0;
  {
    // The .ele file is read only once the .node file has been, so a .node problem is reported first.
    LineReader r(node_path, read_file(node_path), true);
    base = read_nodes(r, raw);
  }
  LineReader r(ele_path, read_file(ele_path), true);
  read_elements(r, base, raw);
  return build_mesh(raw, info);
}

TetMesh parse_tetgen(std::string node_text, const std::string& node_file, std::string ele_text,
                     const std::string& ele_file, MeshFileInfo* info) {
  RawMesh raw;
  long long base = 0;
  {
    LineReader r(node_file, std::move(node_text), true);
    base = read_nodes(r, raw);
  }
  LineReader r(ele_file, std::move(ele_text), true);
  read_elements(r, base, raw);
  return build_mesh(raw, info);
}

}  // namespace scalpel
