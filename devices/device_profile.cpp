#include "devices/device_profile.hpp"

#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>

#include <yaml-cpp/yaml.h>

#include "base/input_error.hpp"

namespace scalpel {

namespace {

struct Ctx {
  std::string file;

  [[noreturn]] void fail(const YAML::Node& n, const std::string& key, const std::string& msg) const {
    const YAML::Mark m = n.Mark();
    const bool known = m.line >= 0 && !m.is_null();
    throw InputError(file, known ? m.line + 1 : 0, known ? m.column + 1 : 0, key, msg);
  }

  // A mapping whose keys are names among `allowed`, each given once: yaml-cpp keeps every entry
  // of a repeated key and reads the first, so the second would be silently ignored.
  void keys(const YAML::Node& map, const std::string& where,
            std::initializer_list<const char*> allowed) const {
    if (!map.IsMap()) fail(map, where, "expected a mapping");
    std::set<std::string> seen;
    for (const auto& kv : map) {
      if (!kv.first.IsScalar()) fail(kv.first, where, "expected a key name, found a list or mapping");
      const std::string k = kv.first.Scalar();
      const std::string path = where.empty() ? k : where + "." + k;
      if (std::none_of(allowed.begin(), allowed.end(), [&](const char* a) { return k == a; }))
        fail(kv.first, path, "unknown key");
      if (!seen.insert(k).second) fail(kv.first, path, "duplicate key");
    }
  }

  YAML::Node need(const YAML::Node& map, const char* key, const std::string& where) const {
    const YAML::Node n = map[key];
    if (!n) fail(map, where.empty() ? key : where + "." + key, "missing");
    return n;
  }

  std::string str(const YAML::Node& n, const std::string& key) const {
    if (!n.IsScalar()) fail(n, key, "expected a scalar");
    return n.Scalar();
  }

  // Decimal or 0x-prefixed hexadecimal integer in [lo, hi].
  long long integer(const YAML::Node& n, const std::string& key, long long lo, long long hi) const {
    const std::string s = str(n, key);
    int base = 10;
    std::size_t start = 0;
    if (s.size() > 2 && s[0] == '0' && (s[1] == 'x' || s[1] == 'X')) base = 16, start = 2;
    long long v = 0;
    const char* end = s.data() + s.size();
    const auto [ptr, ec] = std::from_chars(s.data() + start, end, v, base);
    if (ec != std::errc() || ptr != end) fail(n, key, "expected an integer, got '" + s + "'");
    if (v < lo || v > hi)
      fail(n, key, "out of range [" + std::to_string(lo) + ", " + std::to_string(hi) + "]: " + s);
    return v;
  }

  double number(const YAML::Node& n, const std::string& key) const {
    const std::string s = str(n, key);
    double v = 0.0;
    const char* end = s.data() + s.size();
    const auto [ptr, ec] = std::from_chars(s.data(), end, v);
    if (ec != std::errc() || ptr != end || !std::isfinite(v))
      fail(n, key, "expected a finite number, got '" + s + "'");
    return v;
  }

  Eigen::Vector3d vec3(const YAML::Node& n, const std::string& key) const {
    if (!n.IsSequence() || n.size() != 3) fail(n, key, "expected [x, y, z]");
    return {number(n[0], key), number(n[1], key), number(n[2], key)};
  }
};

FieldType parse_type(const Ctx& c, const YAML::Node& n, const std::string& key) {
  static constexpr std::pair<const char*, FieldType> kTypes[] = {
      {"u8", FieldType::U8},       {"i8", FieldType::I8},       {"u16le", FieldType::U16LE},
      {"i16le", FieldType::I16LE}, {"u16be", FieldType::U16BE}, {"i16be", FieldType::I16BE},
      {"u32le", FieldType::U32LE}, {"i32le", FieldType::I32LE}, {"f32le", FieldType::F32LE}};
  const std::string s = c.str(n, key);
  for (const auto& [name, t] : kTypes)
    if (s == name) return t;
  c.fail(n, key, "unknown type '" + s + "' (u8 i8 u16le i16le u16be i16be u32le i32le f32le)");
}

Axis parse_axis(const Ctx& c, const YAML::Node& n, const std::string& key, bool output) {
  static constexpr std::pair<const char*, Axis> kAxes[] = {
      {"x", Axis::X},   {"y", Axis::Y},   {"z", Axis::Z},   {"rx", Axis::RX},           {"ry", Axis::RY},
      {"rz", Axis::RZ}, {"qw", Axis::QW}, {"qx", Axis::QX}, {"qy", Axis::QY},           {"qz", Axis::QZ},
      {"fx", Axis::FX}, {"fy", Axis::FY}, {"fz", Axis::FZ}, {"buttons", Axis::Buttons}, {"ja", Axis::JA},
      {"jb", Axis::JB}, {"jc", Axis::JC}, {"ia", Axis::IA}, {"ib", Axis::IB},           {"ic", Axis::IC}};
  const std::string s = c.str(n, key);
  for (const auto& [name, a] : kAxes) {
    if (s != name) continue;
    const bool is_output = (a >= Axis::FX && a <= Axis::FZ) || (a >= Axis::IA && a <= Axis::IC);
    if (is_output != output)
      c.fail(
          n, key,
          output ? "output reports carry fx, fy, fz (or ia, ib, ic) only" : "'" + s + "' is an output axis");
    return a;
  }
  c.fail(n, key, "unknown axis '" + s + "'");
}

// A field already read: what it maps, for the checks that nothing is mapped twice.
struct Mapped {
  Axis axis;
  std::uint64_t bits;  // buttons: the bits of the mask it sets
  std::string where;   // its key path
};

ReportLayout parse_layout(const Ctx& c, const YAML::Node& n, const std::string& where, bool output,
                          std::vector<Mapped>& mapped) {
  c.keys(n, where, {"id", "length", "fields"});
  ReportLayout r;
  if (n["id"]) r.id = static_cast<std::uint8_t>(c.integer(n["id"], where + ".id", 0, 255));
  r.length = static_cast<std::size_t>(c.integer(c.need(n, "length", where), where + ".length", 1, 1024));
  const YAML::Node fields = c.need(n, "fields", where);
  if (!fields.IsSequence() || fields.size() == 0)
    c.fail(fields, where + ".fields", "expected a non-empty list");
  for (std::size_t i = 0; i < fields.size(); ++i) {
    const YAML::Node f = fields[i];
    const std::string fw = where + ".fields[" + std::to_string(i) + "]";
    c.keys(f, fw, {"axis", "offset", "type", "scale", "deadband", "shift"});
    ReportField rf;
    rf.axis = parse_axis(c, c.need(f, "axis", fw), fw + ".axis", output);
    rf.offset = static_cast<std::size_t>(c.integer(c.need(f, "offset", fw), fw + ".offset", 0, 1023));
    rf.type = parse_type(c, c.need(f, "type", fw), fw + ".type");
    if (f["scale"]) rf.scale = c.number(f["scale"], fw + ".scale");
    if (rf.scale == 0.0) c.fail(f["scale"], fw + ".scale", "must not be 0");
    if (f["deadband"]) rf.deadband = c.number(f["deadband"], fw + ".deadband");
    if (rf.deadband < 0.0) c.fail(f["deadband"], fw + ".deadband", "must be >= 0");
    if (f["shift"]) rf.shift = static_cast<int>(c.integer(f["shift"], fw + ".shift", 0, 31));
    const bool unsigned_type = rf.type == FieldType::U8 || rf.type == FieldType::U16LE ||
                               rf.type == FieldType::U16BE || rf.type == FieldType::U32LE;
    if (rf.axis == Axis::Buttons && (!unsigned_type || f["scale"] || f["deadband"]))
      c.fail(f, fw, "buttons are an unsigned integer field without scale or dead band");
    if (rf.offset + field_size(rf.type) > r.length)
      c.fail(f["offset"], fw + ".offset", "field ends past the report length " + std::to_string(r.length));
    if (r.id && rf.offset == 0) c.fail(f["offset"], fw + ".offset", "byte 0 is the report id");
    // Two fields on the same bytes would decode one value as two (or encode one over the other).
    const auto bytes = [](const ReportField& x) {
      return std::to_string(x.offset) + "-" + std::to_string(x.offset + field_size(x.type) - 1);
    };
    for (std::size_t j = 0; j < r.fields.size(); ++j) {
      const ReportField& o = r.fields[j];
      if (rf.offset < o.offset + field_size(o.type) && o.offset < rf.offset + field_size(rf.type))
        c.fail(f["offset"], fw + ".offset",
               "bytes " + bytes(rf) + " overlap those of " + where + ".fields[" + std::to_string(j) +
                   "] (bytes " + bytes(o) + ")");
    }
    // An axis read from two places would take whichever report came last; buttons may be spread
    // over several fields, each its own bits of the 32-bit mask.
    if (rf.axis == Axis::Buttons) {
      const std::size_t nbits = 8 * field_size(rf.type);
      const YAML::Node at = f["shift"] ? f["shift"] : f["offset"];
      if (rf.shift + nbits > 32)
        c.fail(at, fw + ".shift",
               "bits " + std::to_string(rf.shift) + "-" + std::to_string(rf.shift + nbits - 1) +
                   " of the buttons go past bit 31");
      const std::uint64_t bits = ((std::uint64_t{1} << nbits) - 1) << rf.shift;
      for (const Mapped& m : mapped)
        if (m.axis == Axis::Buttons && (m.bits & bits))
          c.fail(at, fw + ".shift", "buttons bits overlap those of " + m.where);
      mapped.push_back({rf.axis, bits, fw});
    } else {
      for (const Mapped& m : mapped)
        if (m.axis == rf.axis)
          c.fail(f["axis"], fw + ".axis",
                 "axis '" + f["axis"].Scalar() + "' is already mapped by " + m.where);
      mapped.push_back({rf.axis, 0, fw});
    }
    r.fields.push_back(rf);
  }
  return r;
}

template <class T>
T load_le(const std::uint8_t* p) {
  T v{};
  std::memcpy(&v, p, sizeof(T));
  if constexpr (std::endian::native == std::endian::big) {
    auto* b = reinterpret_cast<std::uint8_t*>(&v);
    std::reverse(b, b + sizeof(T));
  }
  return v;
}

template <class T>
T load_be(const std::uint8_t* p) {
  T v{};
  std::memcpy(&v, p, sizeof(T));
  if constexpr (std::endian::native == std::endian::little) {
    auto* b = reinterpret_cast<std::uint8_t*>(&v);
    std::reverse(b, b + sizeof(T));
  }
  return v;
}

double read_raw(FieldType t, const std::uint8_t* p) {
  switch (t) {
    case FieldType::U8:
      return p[0];
    case FieldType::I8:
      return static_cast<std::int8_t>(p[0]);
    case FieldType::U16LE:
      return load_le<std::uint16_t>(p);
    case FieldType::I16LE:
      return load_le<std::int16_t>(p);
    case FieldType::U16BE:
      return load_be<std::uint16_t>(p);
    case FieldType::I16BE:
      return load_be<std::int16_t>(p);
    case FieldType::U32LE:
      return load_le<std::uint32_t>(p);
    case FieldType::I32LE:
      return load_le<std::int32_t>(p);
    case FieldType::F32LE:
      return load_le<float>(p);
  }
  return 0.0;
}

template <class T>
void store_le(std::uint8_t* p, T v) {
  if constexpr (std::endian::native == std::endian::big) {
    auto* b = reinterpret_cast<std::uint8_t*>(&v);
    std::reverse(b, b + sizeof(T));
  }
  std::memcpy(p, &v, sizeof(T));
}

template <class T>
void store_be(std::uint8_t* p, T v) {
  if constexpr (std::endian::native == std::endian::little) {
    auto* b = reinterpret_cast<std::uint8_t*>(&v);
    std::reverse(b, b + sizeof(T));
  }
  std::memcpy(p, &v, sizeof(T));
}

template <class T>
T saturate(double v) {
  const double lo = static_cast<double>(std::numeric_limits<T>::lowest());
  const double hi = static_cast<double>(std::numeric_limits<T>::max());
  return static_cast<T>(std::clamp(std::round(v), lo, hi));
}

void write_raw(FieldType t, std::uint8_t* p, double v) {
  switch (t) {
    case FieldType::U8:
      p[0] = saturate<std::uint8_t>(v);
      return;
    case FieldType::I8:
      p[0] = static_cast<std::uint8_t>(saturate<std::int8_t>(v));
      return;
    case FieldType::U16LE:
      return store_le(p, saturate<std::uint16_t>(v));
    case FieldType::I16LE:
      return store_le(p, saturate<std::int16_t>(v));
    case FieldType::U16BE:
      return store_be(p, saturate<std::uint16_t>(v));
    case FieldType::I16BE:
      return store_be(p, saturate<std::int16_t>(v));
    case FieldType::U32LE:
      return store_le(p, saturate<std::uint32_t>(v));
    case FieldType::I32LE:
      return store_le(p, saturate<std::int32_t>(v));
    case FieldType::F32LE:
      return store_le(p, static_cast<float>(v));
  }
}

}  // namespace

std::size_t field_size(FieldType t) {
  switch (t) {
    case FieldType::U8:
    case FieldType::I8:
      return 1;
    case FieldType::U16LE:
    case FieldType::I16LE:
    case FieldType::U16BE:
    case FieldType::I16BE:
      return 2;
    case FieldType::U32LE:
    case FieldType::I32LE:
    case FieldType::F32LE:
      return 4;
  }
  return 0;
}

bool DeviceProfile::matches(std::uint16_t vendor_id, std::uint16_t product_id) const {
  return std::any_of(match.begin(), match.end(), [&](const DeviceMatch& m) {
    return m.vendor_id == vendor_id && m.product_id == product_id;
  });
}

const ReportLayout* DeviceProfile::input_layout(std::uint8_t id) const {
  for (const ReportLayout& r : input_reports)
    if (!r.id || *r.id == id) return &r;
  return nullptr;
}

std::size_t DeviceProfile::max_input_length() const {
  std::size_t n = 0;
  for (const ReportLayout& r : input_reports) n = std::max(n, r.length);
  return n;
}

namespace {

// The value axes (x..jc) the input reports map.
struct MappedAxes {
  std::array<bool, kValueAxes> on{};
  explicit MappedAxes(const DeviceProfile& p) {
    for (const ReportLayout& r : p.input_reports)
      for (const ReportField& f : r.fields)
        if (f.axis < Axis::Buttons) on[static_cast<std::size_t>(f.axis)] = true;
  }
  // Whether any, or all, of the axes lo..hi are mapped.
  [[nodiscard]] bool any(Axis lo, Axis hi) const { return count(lo, hi) > 0; }
  [[nodiscard]] bool all(Axis lo, Axis hi) const {
    return count(lo, hi) == static_cast<std::size_t>(hi) - static_cast<std::size_t>(lo) + 1;
  }
  [[nodiscard]] std::size_t count(Axis lo, Axis hi) const {
    return static_cast<std::size_t>(std::count(on.begin() + static_cast<std::ptrdiff_t>(lo),
                                               on.begin() + static_cast<std::ptrdiff_t>(hi) + 1, true));
  }
};

// A linkage device reads its joint angles (ja, jb, jc) and nothing else of the pose; other devices
// read no joint angles.
void check_linkage_axes(const Ctx& c, const YAML::Node& root, const DeviceProfile& p,
                        const MappedAxes& mapped) {
  const YAML::Node in = root["input_reports"];
  if (p.motion != Motion::Linkage) {
    if (mapped.any(Axis::JA, Axis::JC))
      c.fail(in, "input_reports", "joint angles ja, jb, jc are for motion: linkage");
    if (root["linkage"]) c.fail(root["linkage"], "linkage", "only for motion: linkage");
    return;
  }
  if (mapped.any(Axis::X, Axis::QZ))
    c.fail(in, "input_reports", "a linkage device reads joint angles (ja, jb, jc), not x..qz");
  if (!mapped.all(Axis::JA, Axis::JC))
    c.fail(in, "input_reports", "a linkage device needs all of ja, jb, jc");
}

Linkage parse_linkage(const Ctx& c, const YAML::Node& root) {
  const YAML::Node n = c.need(root, "linkage", "");
  c.keys(n, "linkage", {"lengths", "origin", "ratio", "torque_constant", "max_current"});
  Linkage l;
  const Eigen::Vector3d lengths = c.vec3(c.need(n, "lengths", "linkage"), "linkage.lengths");
  if ((lengths.array() < 0.0).any() || lengths[1] <= 0.0 || lengths[2] <= 0.0)
    c.fail(n["lengths"], "linkage.lengths", "arm and forearm must be > 0, the base >= 0");
  l.base = lengths[0];
  l.arm = lengths[1];
  l.forearm = lengths[2];
  if (n["origin"]) l.origin = c.vec3(n["origin"], "linkage.origin");
  const Eigen::Vector3d ratio = c.vec3(c.need(n, "ratio", "linkage"), "linkage.ratio");
  if ((ratio.array() == 0.0).any()) c.fail(n["ratio"], "linkage.ratio", "must not be 0");
  const Eigen::Vector3d kt = c.vec3(c.need(n, "torque_constant", "linkage"), "linkage.torque_constant");
  if ((kt.array() <= 0.0).any()) c.fail(n["torque_constant"], "linkage.torque_constant", "must be > 0");
  for (std::size_t i = 0; i < 3; ++i) {
    l.ratio[i] = ratio[static_cast<Eigen::Index>(i)];
    l.torque_constant[i] = kt[static_cast<Eigen::Index>(i)];
  }
  l.max_current = c.number(c.need(n, "max_current", "linkage"), "linkage.max_current");
  if (!(l.max_current > 0.0)) c.fail(n["max_current"], "linkage.max_current", "must be > 0");
  return l;
}

}  // namespace

DeviceProfile parse_device_profile(const std::string& yaml_text, const std::string& file) {
  const Ctx c{file};
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::ParserException& e) {
    throw InputError(file, e.mark.line + 1, e.mark.column + 1, "", e.msg);
  }
  c.keys(root, "",
         {"name", "transport", "match", "motion", "workspace", "home", "input_reports", "output_report",
          "max_force", "max_force_rate", "usb", "linkage"});
  DeviceProfile p;
  p.file = file;
  p.name = c.str(c.need(root, "name", ""), "name");

  const std::string tr = c.str(c.need(root, "transport", ""), "transport");
  if (tr == "hid")
    p.transport = Transport::Hid;
  else if (tr == "usb")
    p.transport = Transport::Usb;
  else
    c.fail(root["transport"], "transport", "expected hid or usb, got '" + tr + "'");

  const YAML::Node match = c.need(root, "match", "");
  if (!match.IsSequence() || match.size() == 0) c.fail(match, "match", "expected a non-empty list");
  for (std::size_t i = 0; i < match.size(); ++i) {
    const std::string w = "match[" + std::to_string(i) + "]";
    c.keys(match[i], w, {"vendor_id", "product_id"});
    p.match.push_back(
        {static_cast<std::uint16_t>(c.integer(c.need(match[i], "vendor_id", w), w + ".vendor_id", 0, 0xffff)),
         static_cast<std::uint16_t>(
             c.integer(c.need(match[i], "product_id", w), w + ".product_id", 0, 0xffff))});
  }

  const std::string mo = c.str(c.need(root, "motion", ""), "motion");
  if (mo == "rate")
    p.motion = Motion::Rate;
  else if (mo == "absolute")
    p.motion = Motion::Absolute;
  else if (mo == "linkage")
    p.motion = Motion::Linkage;
  else
    c.fail(root["motion"], "motion", "expected rate, absolute or linkage, got '" + mo + "'");

  const YAML::Node ws = c.need(root, "workspace", "");
  c.keys(ws, "workspace", {"min", "max"});
  p.workspace_min = c.vec3(c.need(ws, "min", "workspace"), "workspace.min");
  p.workspace_max = c.vec3(c.need(ws, "max", "workspace"), "workspace.max");
  if ((p.workspace_min.array() >= p.workspace_max.array()).any())
    c.fail(ws, "workspace", "min must be below max on every axis");
  p.home = 0.5 * (p.workspace_min + p.workspace_max);
  if (root["home"]) {
    p.home = c.vec3(root["home"], "home");
    if ((p.home.array() < p.workspace_min.array()).any() || (p.home.array() > p.workspace_max.array()).any())
      c.fail(root["home"], "home", "outside the workspace");
  }

  const YAML::Node in = c.need(root, "input_reports", "");
  if (!in.IsSequence() || in.size() == 0) c.fail(in, "input_reports", "expected a non-empty list");
  std::set<int> ids;
  std::vector<Mapped> mapped;
  for (std::size_t i = 0; i < in.size(); ++i) {
    const std::string w = "input_reports[" + std::to_string(i) + "]";
    ReportLayout r = parse_layout(c, in[i], w, false, mapped);
    if (!r.id && in.size() > 1) c.fail(in[i], w + ".id", "needed when there are several input reports");
    if (r.id && !ids.insert(*r.id).second) c.fail(in[i]["id"], w + ".id", "duplicate report id");
    p.input_reports.push_back(std::move(r));
  }
  const MappedAxes axes(p);
  const bool has_q = axes.any(Axis::QW, Axis::QZ);
  if (has_q && !axes.all(Axis::QW, Axis::QZ))
    c.fail(in, "input_reports", "an orientation needs all of qw, qx, qy, qz");
  if (p.motion == Motion::Rate && has_q) c.fail(in, "input_reports", "a rate device has no qw..qz axes");
  if (p.motion == Motion::Absolute && axes.any(Axis::RX, Axis::RZ))
    c.fail(in, "input_reports", "an absolute device has no rx, ry, rz rate axes");
  check_linkage_axes(c, root, p, axes);

  if (root["output_report"]) {
    std::vector<Mapped> forces;
    p.output_report = parse_layout(c, root["output_report"], "output_report", true, forces);
    if (p.output_report->id.has_value() != p.numbered_reports())
      c.fail(root["output_report"], "output_report.id", "numbered like the input reports");
  }
  if (root["max_force"]) p.max_force = c.number(root["max_force"], "max_force");
  if (root["max_force_rate"]) p.max_force_rate = c.number(root["max_force_rate"], "max_force_rate");
  if (p.max_force < 0.0) c.fail(root["max_force"], "max_force", "must be >= 0");
  if (p.max_force_rate < 0.0) c.fail(root["max_force_rate"], "max_force_rate", "must be >= 0");
  if (p.output_report && (p.max_force <= 0.0 || p.max_force_rate <= 0.0))
    c.fail(root["output_report"], "output_report", "needs max_force and max_force_rate > 0");

  if (p.motion == Motion::Linkage) {
    p.linkage = parse_linkage(c, root);
    // A joint's angle is its field's scale times the motor's counts, and a motor's torque is the
    // joint's times the ratio: two signs for one direction. Were they to differ, the motor would
    // push its joint the wrong way, and a contact would feed itself.
    for (const ReportLayout& r : p.input_reports)
      for (const ReportField& f : r.fields) {
        if (f.axis < Axis::JA || f.axis > Axis::JC) continue;
        const auto k = static_cast<std::size_t>(f.axis) - static_cast<std::size_t>(Axis::JA);
        if ((f.scale > 0) != (p.linkage->ratio[k] > 0))
          c.fail(root["linkage"]["ratio"], "linkage.ratio",
                 std::string("the sign of joint ") + "abc"[k] +
                     "'s ratio differs from that of its field's scale");
      }
  }
  if (p.output_report) {
    // A linkage device takes motor currents (all three), the others a force.
    const bool linkage = p.motion == Motion::Linkage;
    std::array<bool, 3> currents{};
    for (const ReportField& f : p.output_report->fields) {
      const bool current = f.axis >= Axis::IA && f.axis <= Axis::IC;
      if (current != linkage)
        c.fail(root["output_report"], "output_report.fields",
               linkage ? "a linkage device takes motor currents ia, ib, ic, not a force"
                       : "motor currents ia, ib, ic are for motion: linkage");
      if (current) currents[static_cast<std::size_t>(f.axis) - static_cast<std::size_t>(Axis::IA)] = true;
    }
    if (linkage && !(currents[0] && currents[1] && currents[2]))
      c.fail(root["output_report"], "output_report.fields", "a linkage device needs all of ia, ib, ic");
  }

  if (root["usb"]) {
    const YAML::Node u = root["usb"];
    if (p.transport != Transport::Usb) c.fail(u, "usb", "only for transport: usb");
    c.keys(u, "usb", {"interface", "in_endpoint", "out_endpoint", "transfer"});
    if (u["interface"])
      p.usb.interface = static_cast<int>(c.integer(u["interface"], "usb.interface", 0, 255));
    if (u["in_endpoint"])
      p.usb.in_endpoint =
          static_cast<std::uint8_t>(c.integer(u["in_endpoint"], "usb.in_endpoint", 0x81, 0x8f));
    if (u["out_endpoint"])
      p.usb.out_endpoint =
          static_cast<std::uint8_t>(c.integer(u["out_endpoint"], "usb.out_endpoint", 0x01, 0x0f));
    if (u["transfer"]) {
      const std::string t = c.str(u["transfer"], "usb.transfer");
      if (t != "interrupt" && t != "bulk")
        c.fail(u["transfer"], "usb.transfer", "expected interrupt or bulk");
      p.usb.bulk = t == "bulk";
    }
  }
  if (p.transport == Transport::Usb && p.output_report && p.usb.out_endpoint == 0)
    c.fail(root["output_report"], "usb.out_endpoint", "an output report needs an out endpoint");
  return p;
}

DeviceProfile load_device_profile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, 0, 0, "", "cannot open");
  std::ostringstream ss;
  ss << in.rdbuf();
  return parse_device_profile(ss.str(), path);
}

std::vector<DeviceProfile> load_device_profiles(const std::string& dir) {
  namespace fs = std::filesystem;
  std::error_code ec;
  std::vector<std::string> files;
  for (const auto& e : fs::directory_iterator(dir, ec))
    if (e.is_regular_file() && e.path().extension() == ".yaml") files.push_back(e.path().string());
  if (ec) throw InputError(dir, 0, 0, "", "cannot list: " + ec.message());
  std::sort(files.begin(), files.end());
  std::vector<DeviceProfile> out;
  for (const std::string& f : files) out.push_back(load_device_profile(f));
  return out;
}

ParseResult parse_report(const DeviceProfile& p, std::span<const std::uint8_t> report,
                         ReportValues& out) noexcept {
  out = ReportValues{};
  if (report.empty()) return ParseResult::Short;
  const ReportLayout* layout = p.input_layout(report[0]);
  if (!layout) return ParseResult::Malformed;
  if (report.size() < layout->length) return ParseResult::Short;
  for (const ReportField& f : layout->fields) {
    const double raw = read_raw(f.type, report.data() + f.offset);
    if (!std::isfinite(raw)) return ParseResult::Malformed;
    if (f.axis == Axis::Buttons) {
      const std::uint64_t field_mask = ((std::uint64_t{1} << (8 * field_size(f.type))) - 1) << f.shift;
      out.buttons_mask |= static_cast<std::uint32_t>(field_mask);
      out.buttons |= static_cast<std::uint32_t>((static_cast<std::uint64_t>(raw) << f.shift) & field_mask);
      continue;
    }
    const auto i = static_cast<std::size_t>(f.axis);
    out.axis[i] = std::abs(raw) <= f.deadband ? 0.0 : raw * f.scale;
    out.has[i] = true;
  }
  return ParseResult::Ok;
}

std::size_t encode_force(const DeviceProfile& p, const Eigen::Vector3d& force, const Eigen::Vector3d& joints,
                         std::span<std::uint8_t> report) noexcept {
  if (!p.output_report || report.size() < p.output_report->length) return 0;
  const ReportLayout& r = *p.output_report;
  std::fill(report.begin(), report.begin() + static_cast<std::ptrdiff_t>(r.length), std::uint8_t{0});
  if (r.id) report[0] = *r.id;
  const Eigen::Vector3d amps = p.linkage ? p.linkage->currents(joints, force) : Eigen::Vector3d::Zero();
  for (const ReportField& f : r.fields) {
    double v = 0.0;  // a field of neither kind (a profile made in code) writes 0
    if (f.axis >= Axis::FX && f.axis <= Axis::FZ)
      v = force[static_cast<int>(f.axis) - static_cast<int>(Axis::FX)];
    else if (f.axis >= Axis::IA && f.axis <= Axis::IC)
      v = amps[static_cast<int>(f.axis) - static_cast<int>(Axis::IA)];
    write_raw(f.type, report.data() + f.offset, std::isfinite(v) ? v / f.scale : 0.0);
  }
  return r.length;
}

}  // namespace scalpel
