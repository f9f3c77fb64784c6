#include "sim/scenario.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <initializer_list>
#include <numbers>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string_view>
#include <utility>

#include <yaml-cpp/yaml.h>

#include "base/input_error.hpp"
#include "base/input_file.hpp"
#include "sim/task_config.hpp"
#include "sim/yaml_reader.hpp"

namespace scalpel {

namespace fs = std::filesystem;

namespace {

// Sanity bounds that catch millimetres written as metres and meshes too large to simulate.
constexpr int kMaxCellsPerAxis = 1000;                   // hexahedral cells along one axis
constexpr std::uintmax_t kMaxScenarioBytes = 16u << 20;  // a scenario is a page or two of YAML
constexpr double kUnitTolerance = 1e-6;                  // |q| - 1 of a rotation given as a quaternion

std::string region_list(const RegionIds& names) {
  std::vector<std::string> n;
  for (const auto& [name, id] : names) n.push_back(name + " (" + std::to_string(id) + ")");
  return n.empty() ? std::string("none named") : join(n);
}

using Value = YamlValue;
using Map = YamlMap;

class Parser : public YamlReader {
 public:
  Parser(std::string file, fs::path base_dir) : YamlReader(std::move(file)), base_dir_(std::move(base_dir)) {}

  Scenario parse(const std::string& text) const;

  fs::path resolve(const std::string& p) const {
    const fs::path path(p);
    return (path.is_absolute() ? path : base_dir_ / path).lexically_normal();
  }

  // ---- sections ------------------------------------------------------------------------------
  void mesh(const Value& v, MeshSource& out) const;
  void materials(const Value& v, Scenario& s) const;
  void tissue(const Value& v, TissueSection& out) const;
  void fixed(const Value& v, std::vector<FixedSelector>& out) const;
  void tool(const Value& v, ToolSettings& out) const;
  void device(const Value& v, DeviceSettings& out) const;
  void simulation(const Value& v, SimulationSettings& out) const;
  void volume(const Value& v, VolumeSource& out) const;
  void moves(const Value& v, std::vector<PieceMove>& out) const;
  void check_against_mesh(const Scenario& s, const Map& top) const;

 private:
  fs::path base_dir_;
};

// ---- mesh -----------------------------------------------------------------------------------------

// A generated mesh of `cells` cells split into tetrahedra, against kMaxTetrahedra.
void check_size(const Parser& p, const Value& where, long long cells, CubeSplit split) {
  const long long tets = cells * static_cast<long long>(split);
  if (tets > kMaxTetrahedra)
    p.fail(where, std::to_string(cells) + " cells make " + std::to_string(tets) +
                      " tetrahedra, more than the " + std::to_string(kMaxTetrahedra) +
                      " a scenario may hold (a replay needs about 2.2 kB each)");
}

CubeSplit split_of(const Parser& p, const Map& m) {
  const auto v = m.get("split");
  if (!v) return CubeSplit::Six;
  const int n = p.integer(*v);
  if (n != 5 && n != 6) p.fail(*v, std::to_string(n) + " is out of range, expected 5 or 6");
  return n == 5 ? CubeSplit::Five : CubeSplit::Six;
}

void Parser::mesh(const Value& v, MeshSource& out) const {
  const Map m(*this, v);
  out.where = yaml_location(v.key_mark);
  const auto generator = m.get("generator");
  const auto file = m.get("file");
  if (generator && file) fail(file->key_mark, file->path, "give either 'generator' or 'file', not both");
  if (!generator && !file) fail(v.key_mark, v.path, "missing key 'generator' (box or slab) or 'file'");

  if (file) {
    m.only({"file"});
    const std::string name = string(*file);
    const fs::path resolved = resolve(name);
    std::string ext = resolved.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    if (ext != ".msh" && ext != ".node" && ext != ".ele" && ext != ".vtu")
      fail(*file, "unsupported mesh file '" + name + "', expected .msh (Gmsh), .node/.ele (TetGen) or .vtu");
    if (!fs::is_regular_file(resolved)) fail(*file, "mesh file not found: " + resolved.string());
    out.kind = MeshKind::File;
    out.file = resolved;
    return;
  }

  const int kind = choice(*generator, {"box", "slab"});
  const std::string max_length = format(kMaxScenarioLength);
  if (kind == 0) {
    m.only({"generator", "min", "max", "cells", "split", "region"});
    out.kind = MeshKind::Box;
    const Value vmin = m.require("min"), vmax = m.require("max"), vcells = m.require("cells");
    out.box.min = vector<3>(vmin);
    out.box.max = vector<3>(vmax);
    for (int a = 0; a < 3; ++a) {
      const double extent = out.box.max[a] - out.box.min[a];
      if (!(extent > 0.0 && extent <= kMaxScenarioLength))
        fail(vmax, "max - min = " + format(extent) + " on axis " + "xyz"[a] +
                       ", expected 0 < max - min <= " + max_length + " [m]");
    }
    out.box.cells = integers<3>(vcells, 1, kMaxCellsPerAxis);
    out.box.split = split_of(*this, m);
    check_size(*this, vcells, static_cast<long long>(out.box.cells[0]) * out.box.cells[1] * out.box.cells[2],
               out.box.split);
    out.box.region = 0;
    if (const auto r = m.get("region")) {
      out.box_region = string(*r);
      if (out.box_region.empty()) fail(*r, "expected a region name");
    }
    return;
  }

  m.only({"generator", "size", "cells", "layers", "split"});
  out.kind = MeshKind::Slab;
  const Value vsize = m.require("size");
  const auto size = vector<2>(vsize);
  for (int a = 0; a < 2; ++a)
    if (!(size[a] > 0.0 && size[a] <= kMaxScenarioLength))
      fail(vsize,
           "size " + format(size[a]) + " is out of range, expected 0 < size <= " + max_length + " [m]");
  out.slab.size_x = size[0];
  out.slab.size_y = size[1];
  const Value vcells = m.require("cells");
  out.slab.cells = integers<2>(vcells, 1, kMaxCellsPerAxis);
  out.slab.split = split_of(*this, m);
  const Value vlayers = m.require("layers");
  const auto layers = list(vlayers, "a list of layers");
  if (layers.empty()) fail(vlayers, "expected at least one layer");
  long long layer_cells = 0;
  double depth = 0.0;
  out.slab.layers.clear();
  for (const auto& lv : layers) {
    const Map l(*this, lv);
    l.only({"name", "thickness", "cells"});
    SlabLayer layer;
    const Value vname = l.require("name");
    layer.name = string(vname);
    if (layer.name.empty()) fail(vname, "expected a region name");
    for (const auto& other : out.slab.layers)
      if (other.name == layer.name) fail(vname, "duplicate layer name '" + layer.name + "'");
    layer.thickness = positive(l.require("thickness"), kMaxScenarioLength);
    layer.cells = in_range(l.require("cells"), integer(l.require("cells")), 1, kMaxCellsPerAxis);
    layer_cells += layer.cells;
    depth += layer.thickness;
    out.slab.layers.push_back(layer);
  }
  if (depth > kMaxScenarioLength)
    fail(vlayers, "total thickness " + format(depth) + " exceeds " + max_length + " [m]");
  check_size(*this, vcells, layer_cells * out.slab.cells[0] * out.slab.cells[1], out.slab.split);
}

// ---- materials ------------------------------------------------------------------------------------

void Parser::materials(const Value& v, Scenario& s) const {
  const Map m(*this, v);
  if (m.entries().empty()) fail(v, "expected at least one region");
  for (const auto& [region, rv] : m.entries()) {
    const Map r(*this, rv);
    r.only({"young", "poisson", "density", "damping", "prestress", "puncture_force"});
    RegionMaterial rm;
    rm.region = region;
    rm.where = yaml_location(rv.key_mark);
    Material& mat = rm.material;
    mat.young = positive(r.require("young"), 1e12);  // [Pa]: stiffer than any tissue, bone included
    const Value vp = r.require("poisson");
    mat.poisson = number(vp);
    check(vp, mat.poisson > -1.0 && mat.poisson < 0.5, "-1 < poisson < 0.5");
    if (const auto d = r.get("density")) mat.density = positive(*d, 1e5);  // [kg/m^3]
    if (const auto d = r.get("damping")) {
      const Map dm(*this, *d);
      dm.only({"mass", "stiffness"});
      if (const auto a = dm.get("mass")) {
        mat.damping_mass = number(*a);
        check(*a, mat.damping_mass >= 0.0, "a value >= 0 [1/s]");
      }
      if (const auto b = dm.get("stiffness")) {
        mat.damping_stiffness = number(*b);
        check(*b, mat.damping_stiffness >= 0.0, "a value >= 0 [s]");
      }
    }
    if (const auto p = r.get("prestress")) {
      mat.prestress = number(*p);
      check(*p, mat.prestress >= 1.0 && mat.prestress < 2.0, "1 <= prestress < 2");
    }
    if (const auto p = r.get("puncture_force")) mat.puncture_force = positive(*p, 1e3);  // [N]
    s.materials.push_back(rm);
  }
}

// ---- tissue, boundary, tool, device, simulation, task ------------------------------------------------

void Parser::tissue(const Value& v, TissueSection& out) const {
  const Map m(*this, v);
  m.only({"model", "rate", "solver", "gravity", "volume_springs"});
  if (const auto x = m.get("model")) {
    const int model = choice(*x, {"corotational", "mass_spring", "rigid"});
    out.model = model == 1 ? TissueKind::MassSpring : TissueKind::Corotational;
    out.rigid = model == 2;
  }
  if (const auto x = m.get("rate")) out.rate = positive(*x, 10000.0);
  if (const auto x = m.get("solver")) {
    const Map sm(*this, *x);
    sm.only({"tolerance", "max_iterations", "local_rings", "threads"});
    if (const auto t = sm.get("tolerance")) {
      out.cg_tolerance = number(*t);
      check(*t, out.cg_tolerance > 0.0 && out.cg_tolerance < 1.0, "0 < tolerance < 1");
    }
    if (const auto i = sm.get("max_iterations")) out.cg_max_iterations = in_range(*i, integer(*i), 1, 100000);
    if (const auto i = sm.get("local_rings")) out.local_rings = in_range(*i, integer(*i), 0, 64);
    if (const auto i = sm.get("threads")) out.threads = in_range(*i, integer(*i), 1, 64);
  }
  if (const auto x = m.get("gravity")) {
    out.gravity = vector<3>(*x);
    check(*x, out.gravity.norm() <= 1000.0, "|gravity| <= 1000 [m/s^2]");
  }
  if (const auto x = m.get("volume_springs")) {
    out.volume_springs = boolean(*x);
    if (out.model != TissueKind::MassSpring) fail(x->key_mark, x->path, "applies to model: mass_spring only");
  }
}

void Parser::fixed(const Value& v, std::vector<FixedSelector>& out) const {
  for (const auto& item : list(v, "a list of selectors ({side: ...} or {box: ...})")) {
    const Map m(*this, item);
    m.only({"side", "box"});
    FixedSelector sel;
    sel.where = yaml_location(item.mark);
    const auto side = m.get("side");
    const auto box = m.get("box");
    if (side && box) fail(box->key_mark, box->path, "give either 'side' or 'box', not both");
    if (side) {
      sel.kind = FixedSelector::Kind::Side;
      static constexpr Side kSides[] = {Side::ZMin, Side::ZMax, Side::XMin, Side::XMax,
                                        Side::YMin, Side::YMax, Side::ZMin, Side::ZMax};
      sel.side =
          kSides[choice(*side, {"bottom", "top", "x_min", "x_max", "y_min", "y_max", "z_min", "z_max"})];
    } else if (box) {
      sel.kind = FixedSelector::Kind::Box;
      const Map bm(*this, *box);
      bm.only({"min", "max"});
      sel.min = vector<3>(bm.require("min"));
      const Value vmax = bm.require("max");
      sel.max = vector<3>(vmax);
      if ((sel.max.array() < sel.min.array()).any()) fail(vmax, "expected max >= min on every axis");
    } else {
      fail(item.mark, item.path, "expected 'side' or 'box'");
    }
    out.push_back(sel);
  }
}

void Parser::tool(const Value& v, ToolSettings& out) const {
  const Map m(*this, v);
  m.only({"name", "blade", "handle", "cutting_resistance", "contact"});
  if (const auto x = m.get("name")) out.name = string(*x);
  if (const auto x = m.get("contact")) {
    const std::string c = string(*x);
    if (c == "indent")
      out.contact = ToolContactKind::Indent;
    else if (c == "none")
      out.contact = ToolContactKind::None;
    else
      fail(*x, "unknown contact '" + c + "', expected indent or none");
  }
  if (const auto x = m.get("cutting_resistance")) {
    out.cutting_resistance = number(*x);
    check(*x, out.cutting_resistance >= 0.0 && out.cutting_resistance <= 1e5, "0 <= value <= 1e5 [N/m]");
  }
  if (const auto x = m.get("blade")) {
    const Map b(*this, *x);
    b.only({"back", "tip", "edge", "width"});
    out.blade_back = vector<3>(b.require("back"));
    const Value vtip = b.require("tip");
    out.blade_tip = vector<3>(vtip);
    const double length = (out.blade_tip - out.blade_back).norm();
    if (!(length > 0.0 && length <= 0.2))
      fail(vtip, "blade length " + format(length) + " is out of range, expected 0 < length <= 0.2 [m]");
    if (const auto e = b.get("edge")) {
      // Only the part across the blade counts: the direction the sharp edge faces.
      const Vec3 along = (out.blade_tip - out.blade_back) / length;
      Vec3 edge = vector<3>(*e);
      edge -= edge.dot(along) * along;
      if (!(edge.norm() > 1e-9)) fail(*e, "the edge direction must not be parallel to the blade");
      out.blade_edge = edge.normalized();
    }
    if (const auto w = b.get("width")) {
      out.blade_width = number(*w);
      check(*w, out.blade_width >= 0.0 && out.blade_width <= 0.05, "0 <= value <= 0.05 [m]");
      if (out.blade_width > 0.0 && !out.blade_edge)
        fail(*w, "a blade width needs blade.edge: the spine lies opposite the edge");
      if (out.blade_width > 0.0 && out.contact != ToolContactKind::Indent)
        fail(*w, "the blade's flats push the tissue only with contact: indent");
    }
  }
  if (const auto x = m.get("handle")) {
    const Map h(*this, *x);
    h.only({"radius", "length"});
    const Value r = h.require("radius"), l = h.require("length");
    out.handle_radius = number(r);
    check(r, out.handle_radius > 0.0 && out.handle_radius <= 0.05, "0 < value <= 0.05 [m]");
    out.handle_length = number(l);
    check(l, out.handle_length >= 2.0 * out.handle_radius && out.handle_length <= 0.5,
          "2 radius <= value <= 0.5 [m]");
    if (out.contact != ToolContactKind::Indent)
      fail(*x, "the handle pushes the tissue only with contact: indent");
  }
}

void Parser::device(const Value& v, DeviceSettings& out) const {
  const Map m(*this, v);
  m.only({"kind", "profile", "mapping", "rate", "queue_capacity"});
  if (const auto x = m.get("kind")) {
    static constexpr DeviceKind kKinds[] = {DeviceKind::Mock, DeviceKind::Hid, DeviceKind::Libusb,
                                            DeviceKind::Mouse};
    out.kind = kKinds[choice(*x, {"mock", "hid", "libusb", "mouse"})];
  }
  if (const auto x = m.get("profile")) out.profile = string(*x);
  if (const auto x = m.get("rate")) {
    out.rate = number(*x);
    check(*x, out.rate >= 100.0 && out.rate <= 10000.0, "100 <= rate <= 10000 [Hz]");
  }
  if (const auto x = m.get("queue_capacity")) out.queue_capacity = in_range(*x, integer(*x), 16, 1 << 20);
  if (const auto x = m.get("mapping")) {
    const Map mm(*this, *x);
    mm.only({"scale", "offset", "rotation"});
    if (const auto s = mm.get("scale")) out.mapping.scale = positive(*s);
    if (const auto o = mm.get("offset")) out.mapping.offset = vector<3>(*o);
    if (const auto r = mm.get("rotation")) {
      if (r->node.IsSequence()) {
        const Eigen::Vector4d q = vector<4>(*r);
        if (!(std::abs(q.norm() - 1.0) <= kUnitTolerance))
          fail(*r, "quaternion [w, x, y, z] has norm " + format(q.norm()) + ", expected 1 (tolerance 1e-6)");
        out.mapping.rotation = Eigen::Quaterniond(q[0], q[1], q[2], q[3]);
      } else if (r->node.IsMap()) {
        const Map am(*this, *r);
        am.only({"axis", "angle_deg"});
        const Value vaxis = am.require("axis");
        const Vec3 axis = vector<3>(vaxis);
        if (!(axis.norm() > 0.0)) fail(vaxis, "expected a non-zero axis");
        const double angle = number(am.require("angle_deg")) * std::numbers::pi / 180.0;
        out.mapping.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(angle, axis.normalized()));
      } else {
        fail(*r, "expected a quaternion [w, x, y, z] or {axis: [x, y, z], angle_deg: a}, found " +
                     describe(r->node));
      }
    }
  }
}

void Parser::simulation(const Value& v, SimulationSettings& out) const {
  const Map m(*this, v);
  m.only({"visual_rate", "duration", "cut_recursion_depth"});
  if (const auto x = m.get("visual_rate")) {
    out.visual_rate = number(*x);
    // Below 10 Hz a frame is no longer a frame (and a step of the tissue spans a tenth of a second).
    check(*x, out.visual_rate >= 10.0 && out.visual_rate <= 1000.0, "10 <= visual_rate <= 1000 [Hz]");
  }
  if (const auto x = m.get("duration")) out.duration = positive(*x, kMaxSessionSeconds);
  if (const auto x = m.get("cut_recursion_depth")) out.cut_recursion_depth = in_range(*x, integer(*x), 0, 32);
}

void Parser::volume(const Value& v, VolumeSource& out) const {
  const Map m(*this, v);
  m.only({"file", "field", "box", "range", "colour_map"});
  out.where = yaml_location(v.key_mark);
  const Value file = m.require("file");
  const std::string name = string(file);
  out.file = resolve(name);
  std::string ext = out.file.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  if (ext != ".nrrd" && ext != ".nhdr")
    fail(file, "unsupported volume file '" + name + "', expected .nrrd or .nhdr (NRRD)");
  if (!fs::is_regular_file(out.file)) fail(file, "volume file not found: " + out.file.string());
  if (const auto x = m.get("field")) {
    out.field = string(*x);
    const bool word = !out.field.empty() &&
                      std::all_of(out.field.begin(), out.field.end(),
                                  [](unsigned char c) { return std::isalnum(c) || c == '_' || c == '-'; });
    if (!word) fail(*x, "expected a name of letters, digits, '_' or '-'");
    if (out.field == "rest_position" || out.field == "displacement")
      fail(*x, "'" + out.field + "' is a point array mesh.vtu already holds; choose another name");
  }
  if (const auto x = m.get("box")) {
    const Map b(*this, *x);
    b.only({"min", "max"});
    const Value vmax = b.require("max");
    const Vec3 lo = vector<3>(b.require("min")), hi = vector<3>(vmax);
    for (int a = 0; a < 3; ++a)
      if (!(hi[a] > lo[a] && hi[a] - lo[a] <= kMaxScenarioLength))
        fail(vmax, "max - min = " + format(hi[a] - lo[a]) + " on axis " + "xyz"[a] +
                       ", expected 0 < max - min <= " + format(kMaxScenarioLength) + " [m]");
    out.box = std::array<Vec3, 2>{lo, hi};
  }
  if (const auto x = m.get("range")) {
    const auto r = vector<2>(*x);
    check(*x, r[0] < r[1], "range[0] < range[1]");
    out.range = std::array<double, 2>{r[0], r[1]};
  }
  if (const auto x = m.get("colour_map"))
    out.colour_map = choice(*x, {"viridis", "seismic"}) == 0 ? ColourMap::Viridis : ColourMap::Seismic;
}

void Parser::moves(const Value& v, std::vector<PieceMove>& out) const {
  double last = 0.0;
  for (const Value& item : list(v,
                                "a list of moves ({at, point, translate, rotate}, {at, undo: true} or {at, "
                                "point, delete: true})")) {
    const Map m(*this, item);
    PieceMove move;
    move.where = yaml_location(item.mark);
    const Value at = m.require("at");
    move.at = number(at);
    check(at, move.at >= 0.0 && move.at <= kMaxSessionSeconds,
          "0 <= at <= " + format(kMaxSessionSeconds) + " [s]");
    check(at, move.at >= last, "at >= the move before's (moves are listed in time order)");
    last = move.at;
    if (const auto u = m.get("undo")) {
      m.only({"at", "undo"});
      if (!boolean(*u)) fail(*u, "expected true (a move is given by point, translate and rotate)");
      move.action = PieceAction::Undo;
      out.push_back(move);
      continue;
    }
    if (const auto d = m.get("delete")) {
      m.only({"at", "point", "delete"});
      if (!boolean(*d)) fail(*d, "expected true (a move is given by point, translate and rotate)");
      move.action = PieceAction::Delete;
      move.point = vector<3>(m.require("point"));
      out.push_back(move);
      continue;
    }
    m.only({"at", "point", "translate", "rotate"});
    move.point = vector<3>(m.require("point"));
    if (const auto t = m.get("translate")) {
      move.translation = vector<3>(*t);
      check(*t, move.translation.norm() <= kMaxScenarioLength,
            "|translate| <= " + format(kMaxScenarioLength) + " [m]");
    }
    if (const auto r = m.get("rotate")) {
      const Map rm(*this, *r);
      rm.only({"axis", "angle_deg"});
      const Value vaxis = rm.require("axis");
      const Vec3 axis = vector<3>(vaxis);
      check(vaxis, axis.norm() > 0.0, "a non-zero axis");
      const double angle = number(rm.require("angle_deg"));
      move.rotation =
          Eigen::Quaterniond(Eigen::AngleAxisd(angle * std::numbers::pi / 180.0, axis.normalized()));
    }
    out.push_back(move);
  }
}

// Checks that need the mesh: region names, and a task inside a generated mesh.
void Parser::check_against_mesh(const Scenario& s, const Map& top) const {
  if (s.mesh.kind == MeshKind::File) return;
  std::vector<int> ids;
  for (const auto& [name, id] : generated_region_ids(s)) ids.push_back(id);
  if (!s.tissue.rigid || !s.materials.empty()) (void)resolve_materials(s, generated_region_ids(s), ids);

  if (!s.task) return;
  Vec3 lo, hi;
  if (s.mesh.kind == MeshKind::Box) {
    lo = s.mesh.box.min;
    hi = s.mesh.box.max;
  } else {
    double depth = 0.0;
    for (const auto& l : s.mesh.slab.layers) depth += l.thickness;
    lo = Vec3(-s.mesh.slab.size_x / 2, -s.mesh.slab.size_y / 2, -depth);
    hi = Vec3(s.mesh.slab.size_x / 2, s.mesh.slab.size_y / 2, 0.0);
  }
  const double tol = 1e-9 * (hi - lo).norm();
  const Map task(*this, *top.get("task"));
  const auto incisions = task.get("incisions");
  const auto items = incisions ? list(*incisions, "") : std::vector<Value>{*top.get("task")};
  for (std::size_t k = 0; k < s.task->incisions.size(); ++k) {
    const Incision& in = s.task->incisions[k];
    const Map im(*this, items[k]);
    const auto points = list(im.require("path"), "");
    for (std::size_t i = 0; i < in.path.size(); ++i) {
      const Vec3& p = in.path[i];
      if (((p - lo).array() < -tol).any() || ((p - hi).array() > tol).any()) {
        std::ostringstream msg;
        msg << "point [" << p.x() << ", " << p.y() << ", " << p.z()
            << "] lies outside the mesh, which spans [" << lo.x() << ", " << hi.x() << "] x [" << lo.y()
            << ", " << hi.y() << "] x [" << lo.z() << ", " << hi.z() << "] [m]";
        fail(points[i], msg.str());
      }
    }
    if (in.depth_max > hi.z() - lo.z())
      fail(im.require("depth"), "maximum depth " + format(in.depth_max) + " exceeds the mesh height " +
                                    format(hi.z() - lo.z()) + " [m]");
  }
  const RegionIds names = generated_region_ids(s);
  if (const auto x = task.get("protected"))
    for (const Value& r : list(*x, ""))
      if (!names.contains(string(r)))
        fail(r, "no region '" + string(r) + "' in the mesh; its regions: " + region_list(names));
}

Scenario Parser::parse(const std::string& text) const {
  const std::optional<Value> root = this->root(text);
  if (!root) throw InputError(file(), 0, 0, "", "the scenario is empty");
  const Map top(*this, *root);
  // Every section is read whatever the others hold, so one run reports all their errors.
  std::vector<InputError> errors;
  const auto read = [&errors](const auto& section) {
    try {
      section();
      return true;
    } catch (const InputError& e) {
      errors.push_back(e);
      return false;
    }
  };
  (void)read([&] {
    top.only({"name", "description", "mesh", "materials", "tissue", "fixed", "tool", "device", "simulation",
              "task", "volume", "moves", "log"});
  });

  Scenario s;
  s.file = file();
  (void)read([&] { s.name = string(top.require("name")); });
  (void)read([&] {
    if (const auto x = top.get("description")) s.description = string(*x);
  });
  bool whole = read([&] { mesh(top.require("mesh"), s.mesh); });
  (void)read([&] {
    if (const auto x = top.get("tissue")) tissue(*x, s.tissue);
  });
  // Rigid tissue is never stepped: its regions need no material.
  if (!s.tissue.rigid || top.get("materials"))
    whole = read([&] { materials(top.require("materials"), s); }) && whole;
  (void)read([&] {
    if (const auto x = top.get("fixed")) fixed(*x, s.fixed);
  });
  (void)read([&] {
    if (const auto x = top.get("tool")) tool(*x, s.tool);
  });
  (void)read([&] {
    if (const auto x = top.get("device")) device(*x, s.device);
  });
  (void)read([&] {
    if (const auto x = top.get("simulation")) simulation(*x, s.simulation);
  });
  whole = read([&] {
            if (const auto x = top.get("task")) s.task = read_task(*this, *x);
          }) &&
          whole;
  (void)read([&] {
    if (const auto x = top.get("volume")) {
      VolumeSource v;
      volume(*x, v);
      s.volume = std::move(v);
    }
  });
  (void)read([&] {
    if (const auto x = top.get("moves")) {
      if (!s.tissue.rigid)
        fail(x->key_mark, x->path,
             "moving pieces needs rigid tissue (tissue.model: rigid): a tissue solve would fight it");
      moves(*x, s.moves);
    }
  });
  (void)read([&] {
    if (s.tissue.rigid && s.tool.contact == ToolContactKind::Indent)
      fail(*Map(*this, top.require("tool")).get("contact"),
           "contact: indent presses the tissue in, which rigid tissue (tissue.model: rigid) cannot; use "
           "contact: none");
  });
  (void)read([&] {
    if (const auto x = top.get("log")) {
      const std::string p = string(*x);
      if (p.empty()) fail(*x, "expected a file path");
      s.log = resolve(p);
    }
  });
  // The checks against the mesh need the mesh, the materials and the task read whole.
  if (whole)
    (void)read([&] {
      if (const auto x = top.get("materials")) s.materials_where = yaml_location(x->key_mark);
      check_against_mesh(s, top);
    });
  throw_input_errors(std::move(errors));
  return s;
}

}  // namespace

// ---- public API --------------------------------------------------------------------------------------

Scenario load_scenario(const fs::path& path) {
  const std::string text = read_input_file(path.string(), "scenario", kMaxScenarioBytes);
  Scenario s = parse_scenario(text, path.string(), path.parent_path());
  s.file = path;
  return s;
}

Scenario parse_scenario(const std::string& text, const std::string& file_name, const fs::path& base_dir) {
  return Parser(file_name, base_dir).parse(text);
}

TetMesh build_generated_mesh(const Scenario& s) {
  switch (s.mesh.kind) {
    case MeshKind::Box:
      return make_box(s.mesh.box);
    case MeshKind::Slab:
      return make_slab(s.mesh.slab);
    case MeshKind::File:
      break;
  }
  throw std::logic_error("build_generated_mesh: the scenario's mesh is a file, " + s.mesh.file.string());
}

RegionIds generated_region_ids(const Scenario& s) {
  RegionIds ids;
  if (s.mesh.kind == MeshKind::Box) ids[s.mesh.box_region] = s.mesh.box.region;
  if (s.mesh.kind == MeshKind::Slab)
    for (std::size_t i = 0; i < s.mesh.slab.layers.size(); ++i)
      ids[s.mesh.slab.layers[i].name] = static_cast<int>(i);
  return ids;
}

std::map<int, Material> resolve_materials(const Scenario& s, const RegionIds& names,
                                          const std::vector<int>& region_ids_in_mesh) {
  const std::string file = s.file.string();
  const std::set<int> in_mesh(region_ids_in_mesh.begin(), region_ids_in_mesh.end());
  std::map<int, Material> out;
  std::map<int, std::string> named_by;
  for (const auto& rm : s.materials) {
    const std::string field = "materials." + rm.region;
    int id = -1;
    if (const auto it = names.find(rm.region); it != names.end()) {
      id = it->second;
    } else if (constexpr std::string_view prefix = "region_"; rm.region.starts_with(prefix)) {
      const char* first = rm.region.data() + prefix.size();
      const char* last = rm.region.data() + rm.region.size();
      const auto [end, ec] = std::from_chars(first, last, id);
      if (ec != std::errc() || end != last || first == last) id = -1;
    }
    if (id < 0)
      throw InputError(
          file, rm.where.line, rm.where.column, field,
          "no region of this name in the mesh; regions: " + region_list(names) + ", or region_<id>");
    if (!in_mesh.count(id))
      throw InputError(file, rm.where.line, rm.where.column, field,
                       "region id " + std::to_string(id) + " does not occur in the mesh");
    if (named_by.count(id))
      throw InputError(
          file, rm.where.line, rm.where.column, field,
          "region " + std::to_string(id) + " already has a material, from materials." + named_by[id]);
    named_by[id] = rm.region;
    out[id] = rm.material;
  }
  for (const int id : in_mesh)
    if (!out.count(id)) {
      std::string label = "region_" + std::to_string(id);
      for (const auto& [name, nid] : names)
        if (nid == id) label = name;
      throw InputError(file, s.materials_where.line, s.materials_where.column, "materials",
                       "no material for region '" + label + "'");
    }
  return out;
}

std::map<int, Material> resolve_materials(const Scenario& s, const RegionIds& names, const TetMesh& mesh) {
  std::set<int> ids;
  for (const TetId t : mesh.tets()) ids.insert(mesh.region(t));
  return resolve_materials(s, names, std::vector<int>(ids.begin(), ids.end()));
}

std::vector<NodeId> select_fixed_nodes(const Scenario& s, const TetMesh& mesh) {
  const std::vector<NodeId> nodes = mesh.nodes();
  if (nodes.empty()) return {};
  Vec3 lo = mesh.rest(nodes.front()), hi = lo;
  for (const NodeId n : nodes) {
    lo = lo.cwiseMin(mesh.rest(n));
    hi = hi.cwiseMax(mesh.rest(n));
  }
  const double tol = 1e-9 * (hi - lo).norm();
  std::vector<std::uint8_t> fixed(mesh.node_capacity(), 0);
  for (std::size_t i = 0; i < s.fixed.size(); ++i) {
    const FixedSelector& sel = s.fixed[i];
    int axis = 0;
    double plane = 0.0;
    if (sel.kind == FixedSelector::Kind::Side) {
      axis = static_cast<int>(sel.side) / 2;
      plane = static_cast<int>(sel.side) % 2 == 0 ? lo[axis] : hi[axis];
    }
    std::size_t count = 0;
    for (const NodeId n : nodes) {
      const Vec3& x = mesh.rest(n);
      const bool hit = sel.kind == FixedSelector::Kind::Side
                           ? std::abs(x[axis] - plane) <= tol
                           : ((x - sel.min).array() >= -tol).all() && ((x - sel.max).array() <= tol).all();
      if (hit) {
        fixed[n.index] = 1;
        ++count;
      }
    }
    if (count == 0)
      throw InputError(s.file.string(), sel.where.line, sel.where.column, "fixed[" + std::to_string(i) + "]",
                       "selects no node of the mesh");
  }
  std::vector<NodeId> out;
  for (const NodeId n : nodes)
    if (fixed[n.index]) out.push_back(n);
  return out;
}

const char* to_string(TissueKind m) {
  return m == TissueKind::Corotational ? "corotational" : "mass_spring";
}

const char* to_string(DeviceKind k) {
  switch (k) {
    case DeviceKind::Mock:
      return "mock";
    case DeviceKind::Hid:
      return "hid";
    case DeviceKind::Libusb:
      return "libusb";
    case DeviceKind::Mouse:
      return "mouse";
  }
  return "?";
}

const char* to_string(Side s) {
  static constexpr const char* kNames[] = {"x_min", "x_max", "y_min", "y_max", "z_min", "z_max"};
  return kNames[static_cast<int>(s)];
}

}  // namespace scalpel
