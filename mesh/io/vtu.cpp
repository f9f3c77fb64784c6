// VTK .vtu, XML UnstructuredGrid with ASCII data arrays (mesh/io/mesh_io.hpp read_vtu, vtu_text,
// write_vtu).
// Reference: "VTK File Formats" (VTK User's Guide, XML formats, UnstructuredGrid). Only ASCII data
// arrays are read; VTK_TETRA is cell type 10.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "mesh/io/mesh_io.hpp"
#include "mesh/io/raw_mesh.hpp"
#include "mesh/io/reader.hpp"
#include "mesh/io/writer.hpp"
#include "mesh/io/xml.hpp"

namespace scalpel {

namespace {

using mesh_io::append;
using mesh_io::build_mesh;
using mesh_io::kMaxCount;
using mesh_io::kMaxItems;
using mesh_io::parse_double;
using mesh_io::parse_int;
using mesh_io::quoted;
using mesh_io::RawMesh;
using mesh_io::read_file;
using mesh_io::write_text;
using mesh_io::xml_escape;
using mesh_io::XmlReader;
using mesh_io::XmlTag;

constexpr int kVtkTetra = 10;

// What a VTK cell type is to the reader. Cells of lower dimension (vertices, lines, triangles,
// quadrilaterals, polygons, of any order) are left out of the mesh; a volume cell left out would
// leave a hole in the tissue, so those of other shapes are refused, as are types VTK does not have.
enum class VtkCell { Tetrahedron, Lower, OtherVolume, Unknown };
// Vertices to quadrilaterals; quadratic and cubic edges, triangles, quadrilaterals and polygons;
// Lagrange and Bezier curves, triangles and quadrilaterals.
constexpr std::array<int, 23> kVtkLower = {1,  2,  3,  4,  5,  6,  7,  8,  9,  21, 22, 23,
                                           28, 30, 34, 35, 36, 68, 69, 70, 75, 76, 77};
// Voxel to hexagonal prism; quadratic tetrahedra to pyramids; point sets and polyhedra; Lagrange and
// Bezier tetrahedra to pyramids.
constexpr std::array<int, 25> kVtkOtherVolume = {11, 12, 13, 14, 15, 16, 24, 25, 26, 27, 29, 31, 32,
                                                 33, 37, 41, 42, 71, 72, 73, 74, 78, 79, 80, 81};
VtkCell vtk_cell(long long type) {
  const auto in = [type](const auto& list) {
    return std::find(list.begin(), list.end(), type) != list.end();
  };
  if (type == kVtkTetra) return VtkCell::Tetrahedron;
  if (in(kVtkLower)) return VtkCell::Lower;
  if (in(kVtkOtherVolume)) return VtkCell::OtherVolume;
  return VtkCell::Unknown;
}

// ---- reading -------------------------------------------------------------------------------------

// Reads the values of a DataArray up to its closing tag: exactly `count` numbers.
template <class T, class Parse>
std::vector<T> read_array(XmlReader& x, const XmlTag& open, const std::string& field, std::size_t count,
                          std::vector<int>* lines, Parse parse) {
  std::vector<T> out;
  out.reserve(count);
  if (lines) lines->reserve(count);
  if (!open.self_closing) {
    for (;;) {
      const std::string_view t = x.token();
      if (t.empty()) break;
      if (out.size() == count)
        x.fail(x.token_line(), field, "more than the " + std::to_string(count) + " values expected");
      T v{};
      if (!parse(t, v)) x.fail(x.token_line(), field, "bad number " + quoted(t));
      out.push_back(v);
      if (lines) lines->push_back(x.token_line());
    }
    XmlTag close;
    if (!x.next_tag(close)) x.fail(x.line(), field, "unexpected end of file, expected </DataArray>");
    if (!close.closing || close.name != "DataArray")
      x.fail(close.line, field,
             "expected </DataArray>, found <" + std::string(close.closing ? "/" : "") + close.name + ">");
    if (out.size() != count)
      x.fail(close.line, field, std::to_string(out.size()) + " values, expected " + std::to_string(count));
  } else if (count != 0) {
    x.fail(open.line, field, "no values, expected " + std::to_string(count));
  }
  return out;
}

bool parse_index(std::string_view s, long long& v) {
  return parse_int(s, v);
}
bool parse_real(std::string_view s, double& v) {
  return parse_double(s, v);
}
// An integer array may be stored as floating point ("region" as Float64): integral values only.
bool parse_integral(std::string_view s, long long& v) {
  if (parse_int(s, v)) return true;
  double d = 0;
  if (!parse_double(s, d) || d != std::floor(d) || std::abs(d) > 9e15) return false;
  v = static_cast<long long>(d);
  return true;
}

// A count of items, each of which takes at least `min_bytes` of the file: more than kMaxItems or
// than the whole file could hold is refused before anything is allocated for them.
long long count_attribute(const XmlReader& x, const XmlTag& tag, const std::string& key, long long min_bytes,
                          const std::string& items) {
  const std::string* s = tag.attribute(key);
  long long v = 0;
  if (!s) x.fail(tag.line, key, "missing attribute of <" + tag.name + ">");
  if (!parse_int(*s, v) || v < 0 || v > kMaxCount)
    x.fail(tag.line, key, "expected a count, found " + quoted(*s));
  if (v > kMaxItems)
    x.fail(tag.line, key,
           std::to_string(v) + " " + items + " is more than the " + std::to_string(kMaxItems) +
               " a mesh file may have");
  if (v * min_bytes > static_cast<long long>(x.size()))
    x.fail(tag.line, key,
           std::to_string(v) + " " + items + " declared, more than the file's " + std::to_string(x.size()) +
               " bytes can hold");
  return v;
}

// The arrays of a .vtu's one Piece, as read, with the lines errors point at.
struct VtuArrays {
  long long npoints = -1, ncells = -1;
  std::vector<double> points, rest;
  std::vector<long long> connectivity, offsets, types, region;
  std::vector<int> connectivity_lines;
  int connectivity_end_line = 0;
  int piece_line = 0;
  bool have_points = false, have_conn = false, have_offsets = false, have_types = false, have_region = false;
};

// Reads the DataArray that `tag` opens inside `parent` into `a` when the mesh needs it, else skips
// it (an element of `stack` then when it has content).
void read_data_array(XmlReader& x, const XmlTag& tag, const std::string& parent, VtuArrays& a,
                     std::vector<std::pair<std::string, int>>& stack) {
  const std::string* name_attr = tag.attribute("Name");
  const std::string array = name_attr ? *name_attr : "";
  const std::string field = "DataArray '" + array + "'";
  const std::string* format = tag.attribute("format");
  const bool wanted =
      parent == "Points" ||
      (parent == "Cells" && (array == "connectivity" || array == "offsets" || array == "types")) ||
      (parent == "CellData" && array == "region") || (parent == "PointData" && array == "rest_position");
  if (wanted && (!format || *format != "ascii"))
    x.fail(tag.line, field,
           "format \"" + (format ? *format : std::string()) +
               "\" is not supported, write the .vtu with ASCII data arrays");
  if (wanted && a.npoints < 0) x.fail(tag.line, field, "DataArray outside a Piece");
  const auto points3 = static_cast<std::size_t>(a.npoints) * 3;
  const auto cells = static_cast<std::size_t>(a.ncells);
  if (parent == "Points") {
    const std::string* nc = tag.attribute("NumberOfComponents");
    if (!nc || *nc != "3") x.fail(tag.line, "Points NumberOfComponents", "must be 3");
    a.points = read_array<double>(x, tag, "Points", points3, nullptr, parse_real);
    a.have_points = true;
  } else if (parent == "Cells" && array == "offsets") {
    a.offsets = read_array<long long>(x, tag, field, cells, nullptr, parse_index);
    a.have_offsets = true;
  } else if (parent == "Cells" && array == "types") {
    a.types = read_array<long long>(x, tag, field, cells, nullptr, parse_index);
    a.have_types = true;
  } else if (parent == "Cells" && array == "connectivity") {
    // The size is known only from the offsets; read everything up to the closing tag.
    if (!tag.self_closing) {
      for (;;) {
        const std::string_view t = x.token();
        if (t.empty()) break;
        long long v = 0;
        if (!parse_int(t, v)) x.fail(x.token_line(), field, "bad number " + quoted(t));
        a.connectivity.push_back(v);
        a.connectivity_lines.push_back(x.token_line());
      }
      XmlTag close;
      if (!x.next_tag(close) || !close.closing || close.name != "DataArray")
        x.fail(x.line(), field, "expected </DataArray>");
      a.connectivity_end_line = close.line;
    } else {
      a.connectivity_end_line = tag.line;
    }
    a.have_conn = true;
  } else if (parent == "PointData" && array == "rest_position") {
    const std::string* nc = tag.attribute("NumberOfComponents");
    if (!nc || *nc != "3") x.fail(tag.line, field + " NumberOfComponents", "must be 3");
    a.rest = read_array<double>(x, tag, field, points3, nullptr, parse_real);
  } else if (parent == "CellData" && array == "region") {
    a.region = read_array<long long>(x, tag, field, cells, nullptr, parse_integral);
    a.have_region = true;
  } else {
    x.skip_text();
    if (!tag.self_closing) stack.emplace_back(tag.name, tag.line);
  }
}

// Walks the elements after <VTKFile>, checking that they nest, and reads the Piece's arrays.
VtuArrays read_arrays(XmlReader& x, const XmlTag& file) {
  VtuArrays a;
  std::vector<std::pair<std::string, int>> stack;  // enclosing elements and the lines they open on
  stack.emplace_back(file.name, file.line);
  XmlTag tag;
  while (x.next_tag(tag)) {
    if (tag.closing) {
      if (stack.empty() || stack.back().first != tag.name)
        x.fail(tag.line, "</" + tag.name + ">",
               stack.empty() ? "unexpected closing tag" : "expected </" + stack.back().first + ">");
      stack.pop_back();
      continue;
    }
    if (tag.name == "AppendedData")
      x.fail(tag.line, "AppendedData", "appended (binary) data is not supported, write the .vtu in ASCII");
    if (tag.name == "Piece") {
      if (a.npoints >= 0) x.fail(tag.line, "Piece", "more than one Piece is not supported");
      // A point is three numbers, a cell at least its offset and its type, each number followed by
      // a space or a '<'.
      a.npoints = count_attribute(x, tag, "NumberOfPoints", 6, "points");
      a.ncells = count_attribute(x, tag, "NumberOfCells", 4, "cells");
      a.piece_line = tag.line;
    }
    if (tag.name == "DataArray") {
      read_data_array(x, tag, stack.empty() ? "" : stack.back().first, a, stack);
      continue;
    }
    if (!tag.self_closing) stack.emplace_back(tag.name, tag.line);
  }
  if (!stack.empty())
    x.fail(stack.back().second, "<" + stack.back().first + ">",
           "unexpected end of file, the element is not closed");
  if (a.npoints < 0) x.fail(x.line(), "Piece", "missing");
  if (!a.have_points) x.fail(a.piece_line, "Points", "missing");
  if (!a.have_conn) x.fail(a.piece_line, "DataArray 'connectivity'", "missing");
  if (!a.have_offsets) x.fail(a.piece_line, "DataArray 'offsets'", "missing");
  if (!a.have_types) x.fail(a.piece_line, "DataArray 'types'", "missing");
  return a;
}

// The tetrahedron cell `c`, its points from connectivity[start, start + 4), with its region.
void add_tetrahedron(const XmlReader& x, const VtuArrays& a, std::size_t c, long long start, long long end,
                     RawMesh& raw) {
  const auto first = static_cast<std::size_t>(start);
  if (end - start != 4)
    x.fail(first < a.connectivity_lines.size() ? a.connectivity_lines[first] : a.piece_line,
           "DataArray 'connectivity'",
           "tetrahedron (cell " + std::to_string(c) + ") has " + std::to_string(end - start) + " points");
  std::array<std::uint32_t, 4> v{};
  for (std::size_t k = 0; k < 4; ++k) {
    const long long n = a.connectivity[first + k];
    if (n < 0 || n >= a.npoints)
      x.fail(
          a.connectivity_lines[first + k], "DataArray 'connectivity'",
          "point index " + std::to_string(n) + " is out of range [0, " + std::to_string(a.npoints - 1) + "]");
    v[k] = static_cast<std::uint32_t>(n);
  }
  const long long r = a.have_region ? a.region[c] : 0;
  if (r < std::numeric_limits<int>::min() || r > std::numeric_limits<int>::max())
    x.fail(a.piece_line, "DataArray 'region'", "value " + std::to_string(r) + " is out of range");
  raw.tets.push_back(v);
  raw.tags.push_back(static_cast<int>(r));
  raw.lines.push_back(a.connectivity_lines[first]);
}

// The mesh the arrays describe: points, rest positions, and the tetrahedra among the cells (lower
// cells counted as skipped, other volume cells refused).
RawMesh raw_mesh(const XmlReader& x, const VtuArrays& a, const std::string& path) {
  RawMesh raw;
  raw.tet_file = path;
  raw.tags_are_ids = true;
  raw.points.resize(static_cast<std::size_t>(a.npoints));
  for (std::size_t i = 0; i < raw.points.size(); ++i)
    raw.points[i] = Vec3(a.points[3 * i], a.points[3 * i + 1], a.points[3 * i + 2]);
  if (!a.rest.empty()) {
    raw.rest.resize(raw.points.size());
    for (std::size_t i = 0; i < raw.rest.size(); ++i)
      raw.rest[i] = Vec3(a.rest[3 * i], a.rest[3 * i + 1], a.rest[3 * i + 2]);
  }
  const long long used = a.ncells > 0 ? a.offsets.back() : 0;
  if (used != static_cast<long long>(a.connectivity.size()))
    x.fail(a.connectivity_end_line, "DataArray 'connectivity'",
           std::to_string(a.connectivity.size()) + " values, the offsets say " + std::to_string(used));
  long long start = 0;
  for (std::size_t c = 0; c < static_cast<std::size_t>(a.ncells); ++c) {
    const long long end = a.offsets[c];
    if (end < start || end > static_cast<long long>(a.connectivity.size()))
      x.fail(a.piece_line, "DataArray 'offsets'",
             "offset " + std::to_string(end) + " of cell " + std::to_string(c) + " is out of range");
    if (a.types[c] == kVtkTetra) {
      add_tetrahedron(x, a, c, start, end, raw);
    } else if (const VtkCell kind = vtk_cell(a.types[c]); kind == VtkCell::Lower) {
      ++raw.skipped;
    } else {
      x.fail(
          a.piece_line, "DataArray 'types'",
          "cell " + std::to_string(c) + " has type " + std::to_string(a.types[c]) +
              (kind == VtkCell::Unknown ? ", which is not a VTK cell type"
                                        : ", a volume cell that is not a tetrahedron (VTK_TETRA, type 10): "
                                          "mesh the volume with linear tetrahedra"));
    }
    start = end;
  }
  if (start != static_cast<long long>(a.connectivity.size()))
    x.fail(a.piece_line, "DataArray 'connectivity'",
           std::to_string(a.connectivity.size()) + " values, the offsets use " + std::to_string(start));
  if (raw.tets.empty()) x.fail(a.piece_line, "Cells", "no tetrahedra (VTK_TETRA, type 10)");
  return raw;
}

}  // namespace

TetMesh read_vtu(const std::string& path, MeshFileInfo* info) {
  return parse_vtu(read_file(path), path, info);
}

TetMesh parse_vtu(std::string text, const std::string& path, MeshFileInfo* info) {
  XmlReader x(path, std::move(text));
  XmlTag tag;
  if (!x.next_tag(tag) || tag.name != "VTKFile") x.fail(tag.line, "VTKFile", "not a VTK XML file");
  const std::string* type = tag.attribute("type");
  if (!type || *type != "UnstructuredGrid")
    x.fail(tag.line, "VTKFile type", "expected type=\"UnstructuredGrid\"");
  const VtuArrays arrays = read_arrays(x, tag);
  RawMesh raw = raw_mesh(x, arrays, path);
  return build_mesh(raw, info);
}

// ---- writing -------------------------------------------------------------------------------------

namespace {

// Live slots in order, and the compact number of each live slot.
struct Compaction {
  std::vector<std::uint32_t> slots;
  std::vector<std::uint32_t> number;  // per slot; kInvalidIndex if not included
};

Compaction compact_nodes(const TetMesh& m) {
  Compaction c;
  c.number.assign(m.node_capacity(), kInvalidIndex);
  for (std::uint32_t n = 0; n < m.node_capacity(); ++n)
    if (m.node_slot_alive(n)) {
      c.number[n] = static_cast<std::uint32_t>(c.slots.size());
      c.slots.push_back(n);
    }
  return c;
}

void open_array(std::string& out, const char* type, const std::string& name, int components) {
  out += "        <DataArray type=\"";
  out += type;
  out += "\" Name=\"" + xml_escape(name) + "\"";
  if (components > 1) out += " NumberOfComponents=\"" + std::to_string(components) + "\"";
  out += " format=\"ascii\">\n";
}
void close_array(std::string& out) {
  out += "        </DataArray>\n";
}

template <class Get>
void scalar_lines(std::string& out, const std::vector<std::uint32_t>& slots, Get get) {
  constexpr std::size_t kPerLine = 8;
  for (std::size_t i = 0; i < slots.size(); ++i) {
    if (i % kPerLine == 0) out += "          ";
    append(out, get(slots[i]));
    out += (i % kPerLine == kPerLine - 1 || i + 1 == slots.size()) ? '\n' : ' ';
  }
}

void vector_lines(std::string& out, const std::vector<std::uint32_t>& slots, const std::vector<Vec3>& v) {
  for (const std::uint32_t s : slots) {
    out += "          ";
    append(out, v[s].x());
    out += ' ';
    append(out, v[s].y());
    out += ' ';
    append(out, v[s].z());
    out += '\n';
  }
}

void check_size(const std::string& name, std::size_t size, std::size_t expected, const char* what) {
  if (size != expected)
    throw std::invalid_argument("write_vtu: array '" + name + "' has " + std::to_string(size) +
                                " values, expected " + std::to_string(expected) + " (one per " + what +
                                " slot)");
}

void check_unique(std::vector<std::string>& names, const char* what) {
  std::sort(names.begin(), names.end());
  const auto it = std::adjacent_find(names.begin(), names.end());
  if (it != names.end())
    throw std::invalid_argument("write_vtu: repeated " + std::string(what) + " array '" + *it + "'");
}

}  // namespace

std::string vtu_text(const TetMesh& mesh, const VtuData& data) {
  // Check the caller's arrays first: nothing is written for a bad request.
  std::vector<std::string> cell_names, point_names;
  if (data.region) cell_names.push_back("region");
  for (const auto& a : data.cell_ints) {
    check_size(a.name, a.values.size(), mesh.tet_capacity(), "tet");
    cell_names.push_back(a.name);
  }
  for (const auto& a : data.cell_reals) {
    check_size(a.name, a.values.size(), mesh.tet_capacity(), "tet");
    cell_names.push_back(a.name);
  }
  if (data.mesh_fields)
    for (const auto& f : mesh.field_names()) point_names.push_back(f);
  for (const auto& a : data.point_scalars) {
    check_size(a.name, a.values.size(), mesh.node_capacity(), "node");
    point_names.push_back(a.name);
  }
  for (const auto& a : data.point_vectors) {
    check_size(a.name, a.values.size(), mesh.node_capacity(), "node");
    point_names.push_back(a.name);
  }
  check_unique(cell_names, "cell");
  check_unique(point_names, "point");

  const Compaction nodes = compact_nodes(mesh);
  std::vector<std::uint32_t> tets;
  tets.reserve(mesh.tet_count());
  for (std::uint32_t t = 0; t < mesh.tet_capacity(); ++t)
    if (mesh.tet_slot_alive(t)) tets.push_back(t);

  std::string out;
  out.reserve(256 + nodes.slots.size() * 64 + tets.size() * 48);
  out += "<?xml version=\"1.0\"?>\n";
  out +=
      "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" "
      "header_type=\"UInt64\">\n";
  out += "  <UnstructuredGrid>\n";
  out += "    <Piece NumberOfPoints=\"" + std::to_string(nodes.slots.size()) + "\" NumberOfCells=\"" +
         std::to_string(tets.size()) + "\">\n";

  out += "      <PointData>\n";
  if (data.mesh_fields)
    for (std::size_t f = 0; f < mesh.field_names().size(); ++f) {
      open_array(out, "Float64", mesh.field_names()[f], 1);
      const int id = static_cast<int>(f);
      scalar_lines(out, nodes.slots, [&](std::uint32_t n) { return mesh.field(id, mesh.node_handle(n)); });
      close_array(out);
    }
  for (const auto& a : data.point_scalars) {
    open_array(out, "Float64", a.name, 1);
    scalar_lines(out, nodes.slots, [&](std::uint32_t n) { return a.values[n]; });
    close_array(out);
  }
  for (const auto& a : data.point_vectors) {
    open_array(out, "Float64", a.name, 3);
    vector_lines(out, nodes.slots, a.values);
    close_array(out);
  }
  out += "      </PointData>\n";

  out += "      <CellData>\n";
  if (data.region) {
    open_array(out, "Int32", "region", 1);
    scalar_lines(out, tets,
                 [&](std::uint32_t t) { return static_cast<long long>(mesh.region(mesh.tet_handle(t))); });
    close_array(out);
  }
  for (const auto& a : data.cell_ints) {
    open_array(out, "Int64", a.name, 1);
    scalar_lines(out, tets, [&](std::uint32_t t) { return static_cast<long long>(a.values[t]); });
    close_array(out);
  }
  for (const auto& a : data.cell_reals) {
    open_array(out, "Float64", a.name, 1);
    scalar_lines(out, tets, [&](std::uint32_t t) { return a.values[t]; });
    close_array(out);
  }
  out += "      </CellData>\n";

  out += "      <Points>\n";
  open_array(out, "Float64", "Points", 3);
  vector_lines(out, nodes.slots, mesh.positions());
  close_array(out);
  out += "      </Points>\n";

  out += "      <Cells>\n";
  open_array(out, "Int64", "connectivity", 1);
  for (const std::uint32_t t : tets) {
    const auto& v = mesh.tet_vertex_indices(t);
    out += "          ";
    for (std::size_t k = 0; k < 4; ++k) {
      append(out, static_cast<long long>(nodes.number[v[k]]));
      out += k == 3 ? '\n' : ' ';
    }
  }
  close_array(out);
  open_array(out, "Int64", "offsets", 1);
  std::vector<std::uint32_t> cell_numbers(tets.size());
  for (std::size_t i = 0; i < tets.size(); ++i) cell_numbers[i] = static_cast<std::uint32_t>(i);
  scalar_lines(out, cell_numbers, [](std::uint32_t i) { return 4LL * (i + 1); });
  close_array(out);
  open_array(out, "UInt8", "types", 1);
  scalar_lines(out, cell_numbers, [](std::uint32_t) { return static_cast<long long>(kVtkTetra); });
  close_array(out);
  out += "      </Cells>\n";

  out += "    </Piece>\n";
  out += "  </UnstructuredGrid>\n";
  out += "</VTKFile>\n";
  return out;
}

void write_vtu(const TetMesh& mesh, const std::string& path, const VtuData& data) {
  write_text(path, vtu_text(mesh, data));
}

}  // namespace scalpel
