#include "mesh/io/mesh_io.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <stdexcept>
#include <utility>

#include "base/input_error.hpp"
#include "mesh/predicates.hpp"
#include "mesh/topology.hpp"

namespace scalpel {

namespace {

// ---- reading text --------------------------------------------------------------------------------

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, 0, 0, "", "cannot open file");
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  if (size < 0) throw InputError(path, 0, 0, "", "cannot read file");
  std::string text(static_cast<std::size_t>(size), '\0');
  in.seekg(0, std::ios::beg);
  in.read(text.data(), size);
  if (!in) throw InputError(path, 0, 0, "", "cannot read file");
  return text;
}

bool is_space(char c) {
  return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f';
}

// Parses a whole token as a number; false if it is not one (or is out of range).
bool parse_int(std::string_view s, long long& out) {
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return ec == std::errc() && end == s.data() + s.size() && !s.empty();
}

bool parse_double(std::string_view s, double& out) {
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return ec == std::errc() && end == s.data() + s.size() && !s.empty() && std::isfinite(out);
}

std::string quoted(std::string_view token) {
  std::string s = "'";
  s.append(token.substr(0, 40));
  if (token.size() > 40) s += "...";
  return s + "'";
}

// Line-by-line reader of a whole file: each record is one line, split into whitespace-separated
// tokens. With `hash_comments`, '#' starts a comment (TetGen) and blank lines are skipped.
class LineReader {
 public:
  LineReader(std::string file, std::string text, bool hash_comments)
      : file_(std::move(file)), text_(std::move(text)), comments_(hash_comments) {}

  const std::string& file() const { return file_; }
  int line_no() const { return line_no_; }
  std::string_view line() const { return line_; }

  // Moves to the next line (next record with hash_comments); false at the end of the file.
  bool next_line() {
    for (;;) {
      if (next_ >= text_.size()) {
        line_ = {};
        cursor_ = 0;
        at_end_ = true;
        return false;
      }
      const std::size_t nl = text_.find('\n', next_);
      const std::size_t end = nl == std::string::npos ? text_.size() : nl;
      line_ = std::string_view(text_).substr(next_, end - next_);
      next_ = end + 1;
      ++line_no_;
      cursor_ = 0;
      if (comments_) {
        const std::size_t hash = line_.find('#');
        if (hash != std::string_view::npos) line_ = line_.substr(0, hash);
      }
      while (!line_.empty() && is_space(line_.back())) line_.remove_suffix(1);
      if (!comments_ || !blank()) return true;
    }
  }
  // Like next_line, but a missing line is an error about `field`.
  void require_line(std::string_view field, std::string_view what) {
    if (!next_line()) fail(field, "unexpected end of file, expected " + std::string(what));
  }
  bool at_end() const { return at_end_; }
  bool blank() const {
    return std::all_of(line_.begin(), line_.end(), [](char c) { return is_space(c); });
  }

  // Next token of the current line, empty at the end of the line.
  std::string_view token() {
    while (cursor_ < line_.size() && is_space(line_[cursor_])) ++cursor_;
    const std::size_t start = cursor_;
    while (cursor_ < line_.size() && !is_space(line_[cursor_])) ++cursor_;
    token_column_ = static_cast<int>(start) + 1;
    return line_.substr(start, cursor_ - start);
  }
  std::string_view rest_of_line() {
    while (cursor_ < line_.size() && is_space(line_[cursor_])) ++cursor_;
    token_column_ = static_cast<int>(cursor_) + 1;
    const std::string_view r = line_.substr(cursor_);
    cursor_ = line_.size();
    return r;
  }

  long long read_int(std::string_view field) {
    const std::string_view t = token();
    if (t.empty()) fail(field, "missing value (line ends early)");
    long long v = 0;
    if (!parse_int(t, v)) fail(field, "expected an integer, found " + quoted(t));
    return v;
  }
  long long read_int(std::string_view field, long long lo, long long hi) {
    const long long v = read_int(field);
    if (v < lo || v > hi)
      fail(field,
           std::to_string(v) + " is out of range [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    return v;
  }
  double read_double(std::string_view field) {
    const std::string_view t = token();
    if (t.empty()) fail(field, "missing value (line ends early)");
    double v = 0;
    if (!parse_double(t, v)) fail(field, "expected a finite number, found " + quoted(t));
    return v;
  }
  void expect_line_end(std::string_view field) {
    const std::string_view t = token();
    if (!t.empty()) fail(field, "unexpected extra value " + quoted(t));
  }

  [[noreturn]] void fail(std::string_view field, const std::string& message) const {
    throw InputError(file_, line_no_, line_.empty() ? 0 : token_column_, std::string(field), message);
  }
  [[noreturn]] void fail_line(std::string_view field, const std::string& message) const {
    throw InputError(file_, line_no_, 0, std::string(field), message);
  }

 private:
  std::string file_;
  std::string text_;
  bool comments_;
  std::size_t next_ = 0;
  std::string_view line_;
  std::size_t cursor_ = 0;
  int line_no_ = 0;
  int token_column_ = 0;
  bool at_end_ = false;
};

// ---- building the mesh ---------------------------------------------------------------------------

// A file's tetrahedra before they enter a TetMesh: vertex indices into `points` (file order).
struct RawMesh {
  std::vector<Vec3> points;
  std::vector<std::array<std::uint32_t, 4>> tets;
  std::vector<int> tags;   // region tag per tet
  std::vector<int> lines;  // line of each tet in `tet_file`
  std::string tet_file;
  bool tags_are_ids = false;  // .vtu: the tag is the region id
  std::size_t skipped = 0;
};

TetMesh build_mesh(RawMesh& raw, MeshFileInfo* info) {
  // Region ids: sorted distinct tags (std::set: deterministic), or the tags themselves.
  std::set<int> distinct(raw.tags.begin(), raw.tags.end());
  std::map<int, int> id_of_tag;
  MeshFileInfo out;
  int next_id = 0;
  for (const int tag : distinct) {
    const int id = raw.tags_are_ids ? tag : next_id++;
    id_of_tag[tag] = id;
    out.regions.push_back({id, tag, {}});
  }

  // Vertex checks and orientation (Invariant 1 needs orient3d > 0 in the rest configuration).
  for (std::size_t t = 0; t < raw.tets.size(); ++t) {
    auto& v = raw.tets[t];
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j)
        if (v[static_cast<std::size_t>(i)] == v[static_cast<std::size_t>(j)])
          throw InputError(raw.tet_file, raw.lines[t], 0, "tetrahedron",
                           "repeated vertex (local vertices " + std::to_string(i + 1) + " and " +
                               std::to_string(j + 1) + ")");
    const int s = orient3d(raw.points[v[0]], raw.points[v[1]], raw.points[v[2]], raw.points[v[3]]);
    if (s == 0) throw InputError(raw.tet_file, raw.lines[t], 0, "tetrahedron", "degenerate (zero volume)");
    if (s < 0) {
      std::swap(v[2], v[3]);
      ++out.reoriented_tets;
    }
  }

  // Only the nodes the tetrahedra use, in file order.
  std::vector<std::uint8_t> used(raw.points.size(), 0);
  for (const auto& v : raw.tets)
    for (const std::uint32_t n : v) used[n] = 1;
  TetMesh mesh;
  std::vector<NodeId> node(raw.points.size());
  for (std::size_t i = 0; i < raw.points.size(); ++i)
    if (used[i]) node[i] = mesh.add_node(raw.points[i]);
  for (std::size_t t = 0; t < raw.tets.size(); ++t) {
    const auto& v = raw.tets[t];
    mesh.add_tet({node[v[0]], node[v[1]], node[v[2]], node[v[3]]}, id_of_tag[raw.tags[t]]);
  }
  out.skipped_elements = raw.skipped;
  if (info) *info = std::move(out);
  return mesh;
}

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

// ---- Gmsh .msh -----------------------------------------------------------------------------------
// Reference: Gmsh manual, section "MSH file format" (version 4.1) and "Legacy formats" (version 2.2).

constexpr int kGmshTetrahedron = 4;
constexpr long long kMaxCount = 2'000'000'000;

struct GmshElements {
  std::vector<std::array<long long, 4>> tets;  // node tags
  std::vector<int> tags;
  std::vector<int> lines;
  std::size_t skipped = 0;
};

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
  const long long count = r.read_int("$Nodes count", 0, kMaxCount);
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
  const long long count = r.read_int("$Elements count", 0, kMaxCount);
  r.expect_line_end("$Elements count");
  for (long long i = 0; i < count; ++i) {
    section_line(r, "$Elements count", "element", i, count);
    (void)r.read_int("element tag", 1, kMaxCount * 4);
    const long long type = r.read_int("element type");
    if (type != kGmshTetrahedron) {
      ++el.skipped;
      continue;
    }
    const long long ntags = r.read_int("element number of tags", 0, 64);
    int physical = 0;
    for (long long k = 0; k < ntags; ++k) {
      const long long tag = r.read_int("element tag list", -kMaxCount, kMaxCount);
      if (k == 0) physical = static_cast<int>(tag);  // the first tag is the physical entity
    }
    std::array<long long, 4> v{};
    for (auto& n : v) n = r.read_int("element node");
    r.expect_line_end("element (a tetrahedron has 4 nodes)");
    el.tets.push_back(v);
    el.tags.push_back(physical);
    el.lines.push_back(r.line_no());
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
  const long long count = r.read_int("$Nodes count", 0, kMaxCount);
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
  const long long count = r.read_int("$Elements count", 0, kMaxCount);
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
    const bool keep = type == kGmshTetrahedron;
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
      std::array<long long, 4> v{};
      for (auto& x : v) x = r.read_int("element node");
      r.expect_line_end("element (a tetrahedron has 4 nodes)");
      el.tets.push_back(v);
      el.tags.push_back(physical);
      el.lines.push_back(r.line_no());
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

TetMesh read_gmsh(const std::string& path, MeshFileInfo* info) {
  LineReader r(path, read_file(path), false);
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

// ---- TetGen .node / .ele -------------------------------------------------------------------------
// Reference: TetGen 1.5 user manual, section 5.2 (".node" and ".ele" files).

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
    LineReader r(node_path, read_file(node_path), true);
    r.require_line("point count", "the .node header");
    const long long count = r.read_int("point count", 1, kMaxCount);
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
        r.fail("point index",
               "expected " + std::to_string(base + i) + " (points are numbered consecutively)");
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
  }

  LineReader r(ele_path, read_file(ele_path), true);
  r.require_line("tetrahedron count", "the .ele header");
  const long long count = r.read_int("tetrahedron count", 1, kMaxCount);
  const long long per = r.read_int("nodes per tetrahedron");
  if (per != 4 && per != 10) r.fail("nodes per tetrahedron", "must be 4 or 10, found " + std::to_string(per));
  const long long nattr = r.read_int("number of attributes", 0, 1'000'000);
  r.expect_line_end(".ele header");
  const auto npoints = static_cast<long long>(raw.points.size());
  raw.tet_file = ele_path;
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
  return build_mesh(raw, info);
}

// ---- VTK .vtu ------------------------------------------------------------------------------------
// Reference: "VTK File Formats" (VTK User's Guide, XML formats, UnstructuredGrid). Only ASCII data
// arrays are read; VTK_TETRA is cell type 10.

namespace {

constexpr int kVtkTetra = 10;

struct XmlTag {
  std::string name;
  std::vector<std::pair<std::string, std::string>> attributes;
  bool closing = false;
  bool self_closing = false;
  int line = 0;
  const std::string* attribute(const std::string& key) const {
    for (const auto& [k, v] : attributes)
      if (k == key) return &v;
    return nullptr;
  }
};

std::string xml_unescape(std::string_view s) {
  std::string out;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s[i] != '&') {
      out += s[i];
      continue;
    }
    static constexpr std::array<std::pair<std::string_view, char>, 5> entities = {
        {{"&amp;", '&'}, {"&lt;", '<'}, {"&gt;", '>'}, {"&quot;", '"'}, {"&apos;", '\''}}};
    bool matched = false;
    for (const auto& [e, c] : entities)
      if (s.substr(i, e.size()) == e) {
        out += c;
        i += e.size() - 1;
        matched = true;
        break;
      }
    if (!matched) out += '&';
  }
  return out;
}

// A minimal XML scanner: tags with attributes, and whitespace-separated numbers as text.
class XmlReader {
 public:
  XmlReader(std::string file, std::string text) : file_(std::move(file)), text_(std::move(text)) {}
  const std::string& file() const { return file_; }
  int line() const { return line_; }

  [[noreturn]] void fail(int line, const std::string& field, const std::string& message) const {
    throw InputError(file_, line, 0, field, message);
  }

  // Next tag, skipping text, the XML declaration and comments; false at the end of the file.
  bool next_tag(XmlTag& tag) {
    for (;;) {
      while (pos_ < text_.size() && text_[pos_] != '<') advance();
      if (pos_ >= text_.size()) return false;
      if (starts_with("<?")) {
        skip_past("?>", "XML declaration");
        continue;
      }
      if (starts_with("<!--")) {
        skip_past("-->", "XML comment");
        continue;
      }
      break;
    }
    tag = XmlTag{};
    tag.line = line_;
    advance();  // '<'
    if (pos_ < text_.size() && text_[pos_] == '/') {
      tag.closing = true;
      advance();
    }
    tag.name = name();
    if (tag.name.empty()) fail(line_, "XML", "expected a tag name after '<'");
    for (;;) {
      skip_ws();
      if (pos_ >= text_.size()) fail(tag.line, "<" + tag.name + ">", "unexpected end of file inside the tag");
      const char c = text_[pos_];
      if (c == '>') {
        advance();
        return true;
      }
      if (c == '/' && pos_ + 1 < text_.size() && text_[pos_ + 1] == '>') {
        advance();
        advance();
        tag.self_closing = true;
        return true;
      }
      std::string key = name();
      if (key.empty()) fail(line_, "<" + tag.name + ">", "malformed attribute");
      skip_ws();
      if (pos_ >= text_.size() || text_[pos_] != '=')
        fail(line_, key, "expected '=' after the attribute name");
      advance();
      skip_ws();
      if (pos_ >= text_.size() || (text_[pos_] != '"' && text_[pos_] != '\''))
        fail(line_, key, "expected a quoted attribute value");
      const char q = text_[pos_];
      advance();
      const std::size_t start = pos_;
      while (pos_ < text_.size() && text_[pos_] != q) advance();
      if (pos_ >= text_.size()) fail(tag.line, key, "unterminated attribute value");
      tag.attributes.emplace_back(std::move(key),
                                  xml_unescape(std::string_view(text_).substr(start, pos_ - start)));
      advance();
    }
  }

  // Next whitespace-separated token of the text before the next '<'; empty when the text ends.
  std::string_view token() {
    skip_ws();
    const std::size_t start = pos_;
    token_line_ = line_;
    while (pos_ < text_.size() && !std::isspace(static_cast<unsigned char>(text_[pos_])) &&
           text_[pos_] != '<')
      ++pos_;
    return std::string_view(text_).substr(start, pos_ - start);
  }
  int token_line() const { return token_line_; }

  // Skips the text content up to the next tag.
  void skip_text() {
    while (pos_ < text_.size() && text_[pos_] != '<') advance();
  }

 private:
  void advance() {
    if (text_[pos_] == '\n') ++line_;
    ++pos_;
  }
  void skip_ws() {
    while (pos_ < text_.size() && std::isspace(static_cast<unsigned char>(text_[pos_]))) advance();
  }
  bool starts_with(std::string_view s) const { return std::string_view(text_).substr(pos_, s.size()) == s; }
  void skip_past(std::string_view end, const std::string& what) {
    const int start = line_;
    while (pos_ < text_.size() && !starts_with(end)) advance();
    if (pos_ >= text_.size()) fail(start, "XML", what + " is not terminated");
    for (std::size_t i = 0; i < end.size(); ++i) advance();
  }
  std::string name() {
    const std::size_t start = pos_;
    while (pos_ < text_.size()) {
      const char c = text_[pos_];
      if (std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == ':' || c == '.')
        ++pos_;
      else
        break;
    }
    return text_.substr(start, pos_ - start);
  }

  std::string file_;
  std::string text_;
  std::size_t pos_ = 0;
  int line_ = 1;
  int token_line_ = 1;
};

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

long long count_attribute(const XmlReader& x, const XmlTag& tag, const std::string& key) {
  const std::string* s = tag.attribute(key);
  long long v = 0;
  if (!s) x.fail(tag.line, key, "missing attribute of <" + tag.name + ">");
  if (!parse_int(*s, v) || v < 0 || v > kMaxCount)
    x.fail(tag.line, key, "expected a count, found " + quoted(*s));
  return v;
}

}  // namespace

TetMesh read_vtu(const std::string& path, MeshFileInfo* info) {
  XmlReader x(path, read_file(path));
  XmlTag tag;
  if (!x.next_tag(tag) || tag.name != "VTKFile") x.fail(tag.line, "VTKFile", "not a VTK XML file");
  const std::string* type = tag.attribute("type");
  if (!type || *type != "UnstructuredGrid")
    x.fail(tag.line, "VTKFile type", "expected type=\"UnstructuredGrid\"");

  std::vector<std::pair<std::string, int>> stack;  // enclosing elements and the lines they open on
  stack.emplace_back(tag.name, tag.line);
  long long npoints = -1, ncells = -1;
  std::vector<double> points;
  std::vector<long long> connectivity, offsets, types, region;
  std::vector<int> connectivity_lines;
  int connectivity_end_line = 0;
  bool have_points = false, have_conn = false, have_offsets = false, have_types = false, have_region = false;
  int piece_line = 0;
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
      if (npoints >= 0) x.fail(tag.line, "Piece", "more than one Piece is not supported");
      npoints = count_attribute(x, tag, "NumberOfPoints");
      ncells = count_attribute(x, tag, "NumberOfCells");
      piece_line = tag.line;
    }
    if (tag.name == "DataArray") {
      const std::string parent = stack.empty() ? "" : stack.back().first;
      const std::string* name_attr = tag.attribute("Name");
      const std::string array = name_attr ? *name_attr : "";
      const std::string field = "DataArray '" + array + "'";
      const std::string* format = tag.attribute("format");
      const bool wanted =
          parent == "Points" ||
          (parent == "Cells" && (array == "connectivity" || array == "offsets" || array == "types")) ||
          (parent == "CellData" && array == "region");
      if (wanted && (!format || *format != "ascii"))
        x.fail(tag.line, field,
               "format \"" + (format ? *format : std::string()) +
                   "\" is not supported, write the .vtu with ASCII data arrays");
      if (wanted && npoints < 0) x.fail(tag.line, field, "DataArray outside a Piece");
      if (parent == "Points") {
        const std::string* nc = tag.attribute("NumberOfComponents");
        if (!nc || *nc != "3") x.fail(tag.line, "Points NumberOfComponents", "must be 3");
        points =
            read_array<double>(x, tag, "Points", static_cast<std::size_t>(npoints) * 3, nullptr, parse_real);
        have_points = true;
      } else if (parent == "Cells" && array == "offsets") {
        offsets =
            read_array<long long>(x, tag, field, static_cast<std::size_t>(ncells), nullptr, parse_index);
        have_offsets = true;
      } else if (parent == "Cells" && array == "types") {
        types = read_array<long long>(x, tag, field, static_cast<std::size_t>(ncells), nullptr, parse_index);
        have_types = true;
      } else if (parent == "Cells" && array == "connectivity") {
        // The size is known only from the offsets; read everything up to the closing tag.
        if (!tag.self_closing) {
          for (;;) {
            const std::string_view t = x.token();
            if (t.empty()) break;
            long long v = 0;
            if (!parse_int(t, v)) x.fail(x.token_line(), field, "bad number " + quoted(t));
            connectivity.push_back(v);
            connectivity_lines.push_back(x.token_line());
          }
          XmlTag close;
          if (!x.next_tag(close) || !close.closing || close.name != "DataArray")
            x.fail(x.line(), field, "expected </DataArray>");
          connectivity_end_line = close.line;
        } else {
          connectivity_end_line = tag.line;
        }
        have_conn = true;
      } else if (parent == "CellData" && array == "region") {
        region =
            read_array<long long>(x, tag, field, static_cast<std::size_t>(ncells), nullptr, parse_integral);
        have_region = true;
      } else {
        x.skip_text();
        if (!tag.self_closing) stack.emplace_back(tag.name, tag.line);
      }
      continue;
    }
    if (!tag.self_closing) stack.emplace_back(tag.name, tag.line);
  }
  if (!stack.empty())
    x.fail(stack.back().second, "<" + stack.back().first + ">",
           "unexpected end of file, the element is not closed");
  if (npoints < 0) x.fail(x.line(), "Piece", "missing");
  if (!have_points) x.fail(piece_line, "Points", "missing");
  if (!have_conn) x.fail(piece_line, "DataArray 'connectivity'", "missing");
  if (!have_offsets) x.fail(piece_line, "DataArray 'offsets'", "missing");
  if (!have_types) x.fail(piece_line, "DataArray 'types'", "missing");

  RawMesh raw;
  raw.tet_file = path;
  raw.tags_are_ids = true;
  raw.points.resize(static_cast<std::size_t>(npoints));
  for (std::size_t i = 0; i < raw.points.size(); ++i)
    raw.points[i] = Vec3(points[3 * i], points[3 * i + 1], points[3 * i + 2]);
  const long long used = ncells > 0 ? offsets.back() : 0;
  if (used != static_cast<long long>(connectivity.size()))
    x.fail(connectivity_end_line, "DataArray 'connectivity'",
           std::to_string(connectivity.size()) + " values, the offsets say " + std::to_string(used));
  long long start = 0;
  for (std::size_t c = 0; c < static_cast<std::size_t>(ncells); ++c) {
    const long long end = offsets[c];
    if (end < start || end > static_cast<long long>(connectivity.size()))
      x.fail(piece_line, "DataArray 'offsets'",
             "offset " + std::to_string(end) + " of cell " + std::to_string(c) + " is out of range");
    if (types[c] == kVtkTetra) {
      if (end - start != 4)
        x.fail(static_cast<std::size_t>(start) < connectivity_lines.size()
                   ? connectivity_lines[static_cast<std::size_t>(start)]
                   : piece_line,
               "DataArray 'connectivity'",
               "tetrahedron (cell " + std::to_string(c) + ") has " + std::to_string(end - start) + " points");
      std::array<std::uint32_t, 4> v{};
      for (std::size_t k = 0; k < 4; ++k) {
        const auto at = static_cast<std::size_t>(start) + k;
        const long long n = connectivity[at];
        if (n < 0 || n >= npoints)
          x.fail(connectivity_lines[at], "DataArray 'connectivity'",
                 "point index " + std::to_string(n) + " is out of range [0, " + std::to_string(npoints - 1) +
                     "]");
        v[k] = static_cast<std::uint32_t>(n);
      }
      const long long r = have_region ? region[c] : 0;
      if (r < std::numeric_limits<int>::min() || r > std::numeric_limits<int>::max())
        x.fail(piece_line, "DataArray 'region'", "value " + std::to_string(r) + " is out of range");
      raw.tets.push_back(v);
      raw.tags.push_back(static_cast<int>(r));
      raw.lines.push_back(connectivity_lines[static_cast<std::size_t>(start)]);
    } else {
      ++raw.skipped;
    }
    start = end;
  }
  if (start != static_cast<long long>(connectivity.size()))
    x.fail(piece_line, "DataArray 'connectivity'",
           std::to_string(connectivity.size()) + " values, the offsets use " + std::to_string(start));
  if (raw.tets.empty()) x.fail(piece_line, "Cells", "no tetrahedra (VTK_TETRA, type 10)");
  return build_mesh(raw, info);
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

// ---- writers -------------------------------------------------------------------------------------

namespace {

// Shortest round-trip decimal form: the same double always gives the same characters.
void append(std::string& out, double v) {
  char buf[32];
  const auto [end, ec] = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, end);
}
void append(std::string& out, long long v) {
  char buf[24];
  const auto [end, ec] = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, end);
}

std::string xml_escape(const std::string& s) {
  std::string out;
  for (const char c : s) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

void write_text(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw InputError(path, 0, 0, "", "cannot open file for writing");
  out.write(text.data(), static_cast<std::streamsize>(text.size()));
  out.close();
  if (!out) throw InputError(path, 0, 0, "", "cannot write file");
}

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

namespace {

struct Surface {
  std::vector<std::uint32_t> vertex_slots;         // boundary nodes in slot order
  std::vector<std::array<std::uint32_t, 3>> tris;  // compact vertex numbers, outward
};

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

}  // namespace

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

void write_boundary_ply(const TetMesh& mesh, const std::string& path) {
  const Surface s = boundary_surface(mesh);
  std::string out = "ply\nformat ascii 1.0\ncomment scalpelsim boundary surface\n";
  out += "element vertex " + std::to_string(s.vertex_slots.size()) + "\n";
  out += "property double x\nproperty double y\nproperty double z\n";
  out += "element face " + std::to_string(s.tris.size()) + "\n";
  out += "property list uchar int vertex_indices\nend_header\n";
  for (const std::uint32_t n : s.vertex_slots) {
    append_point(out, mesh.positions()[n]);
    out += '\n';
  }
  for (const auto& t : s.tris) {
    out += "3 ";
    append(out, static_cast<long long>(t[0]));
    out += ' ';
    append(out, static_cast<long long>(t[1]));
    out += ' ';
    append(out, static_cast<long long>(t[2]));
    out += '\n';
  }
  write_text(path, out);
}

}  // namespace scalpel
