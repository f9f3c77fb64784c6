// Gmsh .msh, ASCII 2.2 and 4.1 (mesh/io/mesh_io.hpp read_gmsh).
// Reference: Gmsh manual, section "MSH file format" (version 4.1) and "Legacy formats" (version 2.2).

#include <algorithm>
#include <array>
#include <cstdint>
#include <limits>
#include <map>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "base/input_error.hpp"
#include "mesh/io/mesh_io.hpp"
#include "mesh/io/raw_mesh.hpp"
#include "mesh/io/reader.hpp"

namespace scalpel {

namespace {

using mesh_io::build_mesh;
using mesh_io::kMaxCount;
using mesh_io::LineReader;
using mesh_io::quoted;
using mesh_io::RawMesh;
using mesh_io::read_file;

// Node tag -> index into the node arrays, for tags that may have gaps.
class TagMap {
 public:
  void build(const std::vector<long long>& tags, const std::vector<int>& lines, const std::string& file,
             const std::string& field) {
    long long max_tag = 0;
    for (const long long t : tags) max_tag = std::max(max_tag, t);
    dense_ = max_tag <= static_cast<long long>(4 * tags.size() + 1024);
    if (dense_) {
      index_.assign(static_cast<std::size_t>(max_tag) + 1, kInvalidIndex);
      for (std::size_t i = 0; i < tags.size(); ++i) {
        auto& slot = index_[static_cast<std::size_t>(tags[i])];
        if (slot != kInvalidIndex)
          throw InputError(file, lines[i], 0, field, "node tag " + std::to_string(tags[i]) + " is repeated");
        slot = static_cast<std::uint32_t>(i);
      }
    } else {
      sorted_.resize(tags.size());
      for (std::size_t i = 0; i < tags.size(); ++i) sorted_[i] = {tags[i], static_cast<std::uint32_t>(i)};
      std::sort(sorted_.begin(), sorted_.end());
      for (std::size_t i = 1; i < sorted_.size(); ++i)
        if (sorted_[i].first == sorted_[i - 1].first)
          throw InputError(file, lines[std::max(sorted_[i].second, sorted_[i - 1].second)], 0, field,
                           "node tag " + std::to_string(sorted_[i].first) + " is repeated");
    }
  }
  std::uint32_t find(long long tag) const {
    if (dense_)
      return tag >= 0 && tag < static_cast<long long>(index_.size()) ? index_[static_cast<std::size_t>(tag)]
                                                                     : kInvalidIndex;
    const auto it =
        std::lower_bound(sorted_.begin(), sorted_.end(), std::pair<long long, std::uint32_t>{tag, 0});
    return it != sorted_.end() && it->first == tag ? it->second : kInvalidIndex;
  }

 private:
  bool dense_ = true;
  std::vector<std::uint32_t> index_;
  std::vector<std::pair<long long, std::uint32_t>> sorted_;
};

constexpr int kGmshTetrahedron = 4;
constexpr long long kGmshLastType = 140;  // Gmsh's element types are numbered 1 to 140

// The volume elements of Gmsh's numbering that are not a 4-node tetrahedron, by name. Elements of
// lower dimension (points, lines, triangles, quadrangles, of any order), which Gmsh writes for the
// boundary with the volume, are left out of the mesh; a volume element left out would leave a hole
// in the tissue, so these are refused.
constexpr std::pair<int, const char*> kOtherVolumeElements[] = {
    {5, "8-node hexahedron"},
    {6, "6-node prism"},
    {7, "5-node pyramid"},
    {11, "10-node second-order tetrahedron"},
    {12, "27-node second-order hexahedron"},
    {13, "18-node second-order prism"},
    {14, "14-node second-order pyramid"},
    {17, "20-node second-order hexahedron"},
    {18, "15-node second-order prism"},
    {19, "13-node second-order pyramid"},
    {29, "20-node third-order tetrahedron"},
    {30, "35-node fourth-order tetrahedron"},
    {31, "56-node fifth-order tetrahedron"},
    {35, "polyhedron"},
};

const char* other_volume_element(long long type) {
  for (const auto& [number, name] : kOtherVolumeElements)
    if (number == type) return name;
  return nullptr;
}

// An element type read at `field`: whether it is a tetrahedron to keep (else one to leave out);
// refuses unknown types and volume elements of other shapes.
bool keep_element_type(LineReader& r, std::string_view field, long long type) {
  if (type < 1 || type > kGmshLastType)
    r.fail(field,
           std::to_string(type) + " is not a Gmsh element type (1-" + std::to_string(kGmshLastType) + ")");
  if (const char* name = other_volume_element(type))
    r.fail(field, "type " + std::to_string(type) + " (" + name +
                      ") is a volume element that is not a 4-node tetrahedron (type 4): mesh the volume with "
                      "linear tetrahedra");
  return type == kGmshTetrahedron;
}

struct GmshElements {
  std::vector<std::array<long long, 4>> tets;  // node tags
  std::vector<int> tags;
  std::vector<int> lines;
  std::size_t skipped = 0;
};

// The four node tags that end a tetrahedron's line, with its physical tag and line number.
void read_tet_nodes(LineReader& r, int physical, GmshElements& el) {
  std::array<long long, 4> v{};
  for (auto& n : v) n = r.read_int("element node");
  r.expect_line_end("element (a tetrahedron has 4 nodes)");
  el.tets.push_back(v);
  el.tags.push_back(physical);
  el.lines.push_back(r.line_no());
}

struct GmshNodes {
  std::vector<long long> tags;
  std::vector<Vec3> points;
  std::vector<int> lines;
};

// Checks that the current line is "$End<name>".
void expect_end(LineReader& r, const std::string& name, const std::string& count_field,
                const std::string& what) {
  if (!r.next_line()) r.fail_line(count_field, "unexpected end of file, expected $End" + name);
  if (r.line() != "$End" + name) {
    if (!r.line().empty() && r.line().front() == '$')
      r.fail_line(count_field, "unexpected " + std::string(r.line()) + ", expected $End" + name);
    r.fail_line(count_field, "more " + what + " than the count says (expected $End" + name + ")");
  }
}

// Reads the next line of a section; a '$' line there means the section ended before its count.
// The item is described as "what", or "what i of n" when n >= 0 (i 0-based).
void section_line(LineReader& r, std::string_view count_field, std::string_view what, long long i = 0,
                  long long n = -1) {
  const bool ok = r.next_line();
  if (ok && (r.line().empty() || r.line().front() != '$')) return;
  std::string item(what);
  if (n >= 0) item += " " + std::to_string(i + 1) + " of " + std::to_string(n);
  if (!ok) r.fail_line(count_field, "unexpected end of file, expected " + item);
  r.fail_line(count_field, "section ends early, expected " + item);
}

void read_physical_names(LineReader& r, std::map<int, std::string>& names) {
  section_line(r, "$PhysicalNames count", "the number of names");
  const long long count = r.read_int("$PhysicalNames count", 0, kMaxCount);
  r.expect_line_end("$PhysicalNames count");
  for (long long i = 0; i < count; ++i) {
    section_line(r, "$PhysicalNames count", "a physical name");
    const long long dim = r.read_int("physical dimension", 0, 3);
    const long long tag = r.read_int("physical tag", 0, std::numeric_limits<int>::max());
    std::string_view name = r.rest_of_line();
    if (name.size() < 2 || name.front() != '"' || name.back() != '"')
      r.fail("physical name", "expected a name in double quotes");
    name = name.substr(1, name.size() - 2);
    if (dim == 3) names[static_cast<int>(tag)] = std::string(name);
  }
  expect_end(r, "PhysicalNames", "$PhysicalNames count", "names");
}

void read_nodes_v2(LineReader& r, GmshNodes& nodes) {
  section_line(r, "$Nodes count", "the number of nodes");
  const long long count = r.read_count("$Nodes count", 0, "nodes");
  r.expect_line_end("$Nodes count");
  nodes.tags.reserve(static_cast<std::size_t>(count));
  nodes.points.reserve(static_cast<std::size_t>(count));
  nodes.lines.reserve(static_cast<std::size_t>(count));
  for (long long i = 0; i < count; ++i) {
    section_line(r, "$Nodes count", "node", i, count);
    nodes.tags.push_back(r.read_int("node tag", 1, kMaxCount * 4));
    Vec3 x;
    x.x() = r.read_double("node x");
    x.y() = r.read_double("node y");
    x.z() = r.read_double("node z");
    r.expect_line_end("node");
    nodes.points.push_back(x);
    nodes.lines.push_back(r.line_no());
  }
  expect_end(r, "Nodes", "$Nodes count", "nodes");
}

void read_elements_v2(LineReader& r, GmshElements& el) {
  section_line(r, "$Elements count", "the number of elements");
  const long long count = r.read_count("$Elements count", 0, "elements");
  r.expect_line_end("$Elements count");
  for (long long i = 0; i < count; ++i) {
    section_line(r, "$Elements count", "element", i, count);
    (void)r.read_int("element tag", 1, kMaxCount * 4);
    const long long type = r.read_int("element type");
    if (!keep_element_type(r, "element type", type)) {
      ++el.skipped;
      continue;
    }
    const long long ntags = r.read_int("element number of tags", 0, 64);
    int physical = 0;
    for (long long k = 0; k < ntags; ++k) {
      const long long tag = r.read_int("element tag list", -kMaxCount, kMaxCount);
      if (k == 0) physical = static_cast<int>(tag);  // the first tag is the physical entity
    }
    read_tet_nodes(r, physical, el);
  }
  expect_end(r, "Elements", "$Elements count", "elements");
}

// $Entities (4.1): physical tag of each volume entity (the first one; 0 if it has none).
void read_entities_v41(LineReader& r, std::map<int, int>& volume_physical) {
  section_line(r, "$Entities count", "the entity counts");
  std::array<long long, 4> counts{};
  for (auto& c : counts) c = r.read_int("$Entities count", 0, kMaxCount);
  r.expect_line_end("$Entities count");
  for (int dim = 0; dim < 4; ++dim)
    for (long long i = 0; i < counts[static_cast<std::size_t>(dim)]; ++i) {
      section_line(r, "$Entities count", dim < 3 ? "an entity" : "a volume entity");
      if (dim < 3) continue;
      const long long tag = r.read_int("volume entity tag", 0, std::numeric_limits<int>::max());
      for (int k = 0; k < 6; ++k) (void)r.read_double("volume bounding box");
      const long long nphys = r.read_int("volume number of physical tags", 0, kMaxCount);
      int physical = 0;
      for (long long k = 0; k < nphys; ++k) {
        const long long p = r.read_int("volume physical tag", -kMaxCount, kMaxCount);
        if (k == 0) physical = static_cast<int>(p);
      }
      volume_physical[static_cast<int>(tag)] = physical;
    }
  expect_end(r, "Entities", "$Entities count", "entities");
}

void read_nodes_v41(LineReader& r, GmshNodes& nodes) {
  section_line(r, "$Nodes count", "the block and node counts");
  const long long blocks = r.read_int("$Nodes count", 0, kMaxCount);
  const long long count = r.read_count("$Nodes count", 0, "nodes");
  const int count_line = r.line_no();
  (void)r.read_int("$Nodes count");  // min node tag
  (void)r.read_int("$Nodes count");  // max node tag
  r.expect_line_end("$Nodes count");
  nodes.tags.reserve(static_cast<std::size_t>(count));
  nodes.points.reserve(static_cast<std::size_t>(count));
  nodes.lines.reserve(static_cast<std::size_t>(count));
  long long total = 0;
  for (long long b = 0; b < blocks; ++b) {
    section_line(r, "$Nodes count", "node block", b, blocks);
    const long long dim = r.read_int("node block entity dimension", 0, 3);
    (void)r.read_int("node block entity tag");
    const long long parametric = r.read_int("node block parametric flag", 0, 1);
    const long long n = r.read_int("node block size", 0, kMaxCount);
    r.expect_line_end("node block");
    total += n;
    if (total > count)
      r.fail_line("$Nodes count",
                  "node blocks hold more than the " + std::to_string(count) + " nodes counted");
    const std::size_t first = nodes.tags.size();
    for (long long i = 0; i < n; ++i) {
      section_line(r, "node block size", "node tag", i, n);
      nodes.tags.push_back(r.read_int("node tag", 1, kMaxCount * 4));
      r.expect_line_end("node tag");
      nodes.lines.push_back(r.line_no());
    }
    for (long long i = 0; i < n; ++i) {
      section_line(r, "node block size", "node coordinates", i, n);
      Vec3 x;
      x.x() = r.read_double("node x");
      x.y() = r.read_double("node y");
      x.z() = r.read_double("node z");
      if (parametric)
        for (long long k = 0; k < dim; ++k) (void)r.read_double("node parametric coordinate");
      r.expect_line_end("node coordinates");
      nodes.points.push_back(x);
      nodes.lines[first + static_cast<std::size_t>(i)] = r.line_no();
    }
  }
  if (total != count)
    throw InputError(
        r.file(), count_line, 0, "$Nodes count",
        "node blocks hold " + std::to_string(total) + " nodes, the count says " + std::to_string(count));
  expect_end(r, "Nodes", "$Nodes count", "nodes");
}

void read_elements_v41(LineReader& r, const std::map<int, int>* volume_physical, GmshElements& el) {
  section_line(r, "$Elements count", "the block and element counts");
  const long long blocks = r.read_int("$Elements count", 0, kMaxCount);
  const long long count = r.read_count("$Elements count", 0, "elements");
  const int count_line = r.line_no();
  (void)r.read_int("$Elements count");
  (void)r.read_int("$Elements count");
  r.expect_line_end("$Elements count");
  long long total = 0;
  for (long long b = 0; b < blocks; ++b) {
    section_line(r, "$Elements count", "element block", b, blocks);
    const long long dim = r.read_int("element block entity dimension", 0, 3);
    const long long entity = r.read_int("element block entity tag", 0, std::numeric_limits<int>::max());
    const long long type = r.read_int("element block type");
    const long long n = r.read_int("element block size", 0, kMaxCount);
    r.expect_line_end("element block");
    total += n;
    if (total > count)
      r.fail_line("$Elements count",
                  "element blocks hold more than the " + std::to_string(count) + " elements counted");
    const bool keep = keep_element_type(r, "element block type", type);
    if (keep && dim != 3)
      r.fail("element block entity dimension", "tetrahedra in an entity of dimension " + std::to_string(dim));
    int physical = 0;
    if (keep && volume_physical) {
      const auto it = volume_physical->find(static_cast<int>(entity));
      if (it == volume_physical->end())
        r.fail_line("element block entity tag", "volume " + std::to_string(entity) + " is not in $Entities");
      physical = it->second;
    }
    for (long long i = 0; i < n; ++i) {
      section_line(r, "element block size", "element", i, n);
      if (!keep) {
        ++el.skipped;
        continue;
      }
      (void)r.read_int("element tag", 1, kMaxCount * 4);
      read_tet_nodes(r, physical, el);
    }
  }
  if (total != count)
    throw InputError(r.file(), count_line, 0, "$Elements count",
                     "element blocks hold " + std::to_string(total) + " elements, the count says " +
                         std::to_string(count));
  expect_end(r, "Elements", "$Elements count", "elements");
}

void skip_section(LineReader& r, const std::string& name) {
  const int start = r.line_no();
  const std::string end = "$End" + name;
  while (r.next_line())
    if (r.line() == end) return;
  throw InputError(r.file(), start, 0, "$" + name, "section has no " + end);
}

}  // namespace

TetMesh read_gmsh(const std::string& path, MeshFileInfo* info) {
  return parse_gmsh(read_file(path), path, info);
}

TetMesh parse_gmsh(std::string text, const std::string& path, MeshFileInfo* info) {
  LineReader r(path, std::move(text), false);
  // $MeshFormat: "version file-type data-size"; file-type 1 is binary.
  while (r.next_line() && r.blank()) {
  }
  if (r.at_end() || r.line() != "$MeshFormat")
    r.fail_line("$MeshFormat", "not a Gmsh file (expected $MeshFormat)");
  r.require_line("$MeshFormat", "the format line");
  const std::string_view version_token = r.token();
  const long long file_type = r.read_int("$MeshFormat file-type", 0, 1);
  (void)r.read_int("$MeshFormat data-size");
  if (file_type == 1)
    r.fail("$MeshFormat file-type",
           "binary msh is not supported, re-export as ASCII (gmsh -format msh22 or msh41, Mesh.Binary = 0)");
  const std::string version(version_token);
  int major = 0;
  if (version == "4.1")
    major = 4;
  else if (version.size() >= 2 && version.compare(0, 2, "2.") == 0)
    major = 2;
  else
    r.fail("$MeshFormat version", "msh version " + version + " is not supported (use 2.2 or 4.1)");
  expect_end(r, "MeshFormat", "$MeshFormat", "format lines");

  std::map<int, std::string> names;
  std::map<int, int> volume_physical;
  bool have_entities = false;
  GmshNodes nodes;
  GmshElements el;
  bool have_nodes = false, have_elements = false;
  int elements_line = 0;
  while (r.next_line()) {
    if (r.blank()) continue;
    const std::string_view head = r.line();
    if (head.front() != '$' || head.compare(0, 4, "$End") == 0)
      r.fail_line("section", "expected a section header such as $Nodes, found " + quoted(head));
    const std::string name(head.substr(1));
    if (name == "PhysicalNames") {
      read_physical_names(r, names);
    } else if (name == "Entities" && major == 4) {
      if (have_elements) r.fail_line("$Entities", "must come before $Elements");
      have_entities = true;
      read_entities_v41(r, volume_physical);
    } else if (name == "Nodes") {
      if (have_nodes) r.fail_line("$Nodes", "repeated section");
      have_nodes = true;
      if (major == 2)
        read_nodes_v2(r, nodes);
      else
        read_nodes_v41(r, nodes);
    } else if (name == "Elements") {
      if (have_elements) r.fail_line("$Elements", "repeated section");
      have_elements = true;
      elements_line = r.line_no();
      if (major == 2)
        read_elements_v2(r, el);
      else
        read_elements_v41(r, have_entities ? &volume_physical : nullptr, el);
    } else {
      skip_section(r, name);
    }
  }
  const int last = r.line_no();
  if (!have_nodes) throw InputError(path, last, 0, "$Nodes", "missing section");
  if (!have_elements) throw InputError(path, last, 0, "$Elements", "missing section");
  if (el.tets.empty())
    throw InputError(path, elements_line, 0, "$Elements", "no tetrahedra (element type 4) in the mesh");

  TagMap map;
  map.build(nodes.tags, nodes.lines, path, "node tag");
  RawMesh raw;
  raw.points = std::move(nodes.points);
  raw.tet_file = path;
  raw.tets.resize(el.tets.size());
  for (std::size_t t = 0; t < el.tets.size(); ++t)
    for (std::size_t k = 0; k < 4; ++k) {
      const std::uint32_t i = map.find(el.tets[t][k]);
      if (i == kInvalidIndex)
        throw InputError(path, el.lines[t], 0, "element node",
                         "node tag " + std::to_string(el.tets[t][k]) + " is not in $Nodes");
      raw.tets[t][k] = i;
    }
  raw.tags = std::move(el.tags);
  raw.lines = std::move(el.lines);
  raw.skipped = el.skipped;
  MeshFileInfo local;
  TetMesh mesh = build_mesh(raw, &local);
  for (auto& region : local.regions) {
    const auto it = names.find(region.tag);
    if (it != names.end()) region.name = it->second;
  }
  if (info) *info = std::move(local);
  return mesh;
}

}  // namespace scalpel
