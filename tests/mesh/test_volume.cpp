#include <doctest/doctest.h>

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include "base/input_error.hpp"
#include "mesh/generators.hpp"
#include "mesh/volume.hpp"

using namespace scalpel;
namespace fs = std::filesystem;

namespace {

fs::path temp_file(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("scalpel_volume_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  return dir / name;
}

// f(x) = 3 + 100 x - 40 y + 250 z on a 5 x 4 x 3 grid: trilinear interpolation reproduces it exactly.
ScalarVolume linear_volume() {
  ScalarVolume v;
  v.size = {5, 4, 3};
  v.origin = Vec3(-0.01, -0.005, -0.004);
  v.spacing = Vec3(0.005, 0.004, 0.002);
  for (std::size_t k = 0; k < 3; ++k)
    for (std::size_t j = 0; j < 4; ++j)
      for (std::size_t i = 0; i < 5; ++i) {
        const Vec3 x = v.origin + Vec3(double(i), double(j), double(k)).cwiseProduct(v.spacing);
        v.values.push_back(static_cast<float>(3.0 + 100.0 * x.x() - 40.0 * x.y() + 250.0 * x.z()));
      }
  return v;
}

double linear(const Vec3& x) {
  return 3.0 + 100.0 * x.x() - 40.0 * x.y() + 250.0 * x.z();
}

// A NRRD header with `replace` substituted for the line starting with `key` (or appended lines).
std::string header(const std::string& key = "", const std::string& replace = "") {
  std::string h =
      "NRRD0004\n"                                               // 1
      "type: float\n"                                            // 2
      "dimension: 3\n"                                           // 3
      "space: 3D-right-handed\n"                                 // 4
      "sizes: 2 2 2\n"                                           // 5
      "space directions: (0.001,0,0) (0,0.001,0) (0,0,0.001)\n"  // 6
      "space origin: (0,0,0)\n"                                  // 7
      "space units: \"m\" \"m\" \"m\"\n"                         // 8
      "encoding: ascii\n";                                       // 9
  if (!key.empty()) {
    const auto at = h.find(key + ":");
    REQUIRE(at != std::string::npos);
    const auto end = h.find('\n', at);
    h.replace(at, end - at, replace);
  }
  return h + "\n";
}

void write(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

}  // namespace

TEST_CASE("a scalar volume interpolates trilinearly inside its grid and takes the nearest value outside") {
  const ScalarVolume v = linear_volume();
  for (const Vec3& x : {Vec3(0.0, 0.0, 0.0), Vec3(0.0073, -0.0049, -0.0031), Vec3(-0.01, 0.007, 0.0),
                        Vec3(0.01, 0.007, -0.004)})
    CHECK(v.sample(x) == doctest::Approx(linear(x)).epsilon(1e-6));
  // Beyond the grid: clamped onto its box.
  CHECK(v.sample(Vec3(0.02, 0.0, 0.0)) == doctest::Approx(linear(Vec3(0.01, 0.0, 0.0))).epsilon(1e-6));
  CHECK(v.sample(Vec3(0.0, -1.0, 1.0)) == doctest::Approx(linear(Vec3(0.0, -0.005, 0.0))).epsilon(1e-6));
  CHECK(v.distance_outside(Vec3(0.0, 0.0, 0.0)) == 0.0);
  CHECK(v.distance_outside(Vec3(0.013, 0.0, 0.004)) == doctest::Approx(0.005));
  const auto r = v.range();
  CHECK(r[0] == doctest::Approx(linear(Vec3(-0.01, 0.007, -0.004))).epsilon(1e-6));
  CHECK(r[1] == doctest::Approx(linear(Vec3(0.01, -0.005, 0.0))).epsilon(1e-6));
}

TEST_CASE("a volume written as NRRD reads back with its grid and values") {
  const ScalarVolume v = linear_volume();
  const fs::path path = temp_file("linear.nrrd");
  write_nrrd_volume(v, path);
  const ScalarVolume back = read_nrrd_volume(path);
  CHECK(back.size == v.size);
  CHECK((back.origin - v.origin).norm() < 1e-15);
  CHECK((back.spacing - v.spacing).norm() < 1e-15);
  CHECK(back.values == v.values);
}

TEST_CASE("a NRRD volume may keep its data in a separate raw file, in millimetres, of any scalar type") {
  const fs::path raw = temp_file("ramp.raw");
  {
    std::ofstream out(raw, std::ios::binary);
    for (std::uint16_t i = 0; i < 12; ++i) out.write(reinterpret_cast<const char*>(&i), 2);
  }
  const fs::path nhdr = temp_file("ramp.nhdr");
  write(nhdr,
        "NRRD0004\ntype: ushort\ndimension: 3\nspace: right-anterior-superior\nsizes: 3 2 2\n"
        "space directions: (2,0,0) (0,1,0) (0,0,0.5)\nspace origin: (-2,0,1)\nspace units: \"mm\" \"mm\" "
        "\"mm\"\n"
        "endian: little\nencoding: raw\ndata file: ramp.raw\n\n");
  const ScalarVolume v = read_nrrd_volume(nhdr);
  CHECK(v.size == std::array<std::size_t, 3>{3, 2, 2});
  CHECK((v.origin - Vec3(-0.002, 0.0, 0.001)).norm() < 1e-15);
  CHECK((v.spacing - Vec3(0.002, 0.001, 0.0005)).norm() < 1e-15);
  CHECK(v.at(2, 1, 1) == 11.0f);
  CHECK(v.sample(Vec3(0.001, 0.0005, 0.00125)) == doctest::Approx(1.5 + 3 * 0.5 + 6 * 0.5).epsilon(1e-12));
}

TEST_CASE("a bad NRRD volume names the file, the header line and the field") {
  struct Case {
    std::string key, replace;
    int line;
    std::string field, message;
  };
  const Case cases[] = {
      {"type", "type: flaot", 2, "type", "flaot"},
      {"sizes", "sizes: 2 x 2", 5, "sizes", "size"},
      {"space directions", "space directions: (0.001,0.001,0) (0,0.001,0) (0,0,0.001)", 6, "space directions",
       "axis-aligned"},
      {"space directions", "space directions: (-0.001,0,0) (0,0.001,0) (0,0,0.001)", 6, "space directions",
       "positive"},
      {"space units", "space units: \"cm\" \"cm\" \"cm\"", 8, "space units", "cm"},
      {"encoding", "encodinq: ascii", 9, "encodinq", "unknown field"},
  };
  for (const Case& c : cases) {
    CAPTURE(c.replace);
    const fs::path path = temp_file("bad.nrrd");
    std::string text = header(c.key, c.replace);
    write(path, text + "1 2 3 4 5 6 7 8\n");
    try {
      (void)read_nrrd_volume(path);
      FAIL("no error");
    } catch (const InputError& e) {
      CHECK(e.file() == path.string());
      CHECK(e.line() == c.line);
      CHECK(e.field() == c.field);
      CHECK(std::string(e.what()).find(c.message) != std::string::npos);
    }
  }
  // A picture, not a volume.
  const fs::path flat = temp_file("flat.nrrd");
  write(flat, "NRRD0004\ntype: float\ndimension: 2\nsizes: 2 2\nencoding: ascii\n\n1 2 3 4\n");
  try {
    (void)read_nrrd_volume(flat);
    FAIL("no error");
  } catch (const InputError& e) {
    CHECK(e.line() == 3);
    CHECK(e.field() == "dimension");
  }
  // Too few samples: the data, after the header.
  const fs::path shortfile = temp_file("short.nrrd");
  write(shortfile, header() + "1 2 3\n");
  try {
    (void)read_nrrd_volume(shortfile);
    FAIL("no error");
  } catch (const InputError& e) {
    CHECK(e.line() == 11);  // after the header's 9 lines and the blank one
    CHECK(e.field() == "data");
  }
  // Not a number.
  const fs::path nanfile = temp_file("nan.nrrd");
  write(nanfile, header() + "1 2 3 4 5 6 7 nan\n");
  try {
    (void)read_nrrd_volume(nanfile);
    FAIL("no error");
  } catch (const InputError& e) {
    CHECK(e.line() == 11);
    CHECK(e.field() == "data");
    CHECK(std::string(e.what()).find("sample 7") != std::string::npos);
  }
  CHECK_THROWS_WITH_AS((void)read_nrrd_volume(temp_file("missing.nrrd")), doctest::Contains("no such file"),
                       InputError);
}

TEST_CASE("a mesh samples a volume at its nodes' rest positions") {
  BoxSpec spec;
  spec.min = Vec3(-0.01, -0.005, -0.004);
  spec.max = Vec3(0.01, 0.007, 0.0);
  spec.cells = {3, 2, 2};
  TetMesh mesh = make_box(spec);
  const int id = sample_volume_onto(mesh, linear_volume(), "value");
  CHECK(mesh.field_names()[static_cast<std::size_t>(id)] == "value");
  for (const NodeId n : mesh.nodes())
    CHECK(mesh.field(id, n) == doctest::Approx(linear(mesh.rest(n))).epsilon(1e-6));
}

TEST_CASE("the layered seismic data set: values in [-1, 1] that follow the strata, offset across the fault") {
  const StrataSpec spec;
  const ScalarVolume v = strata_volume(spec);
  CHECK(v.values.size() == spec.samples[0] * spec.samples[1] * spec.samples[2]);
  const auto r = v.range();
  CHECK(r[0] >= -1.0);
  CHECK(r[1] <= 1.0);
  CHECK(r[1] - r[0] > 1.5);
  // Along a stratum (constant depth below the crest line, away from the fault) the value holds;
  // across the fault at the same height it does not.
  const double z = -0.02;
  CHECK(v.sample(Vec3(0.0, -0.001, z)) == doctest::Approx(v.sample(Vec3(0.0, 0.001, z))).epsilon(0.02));
  const double fault_at_z = spec.fault_x - z / std::tan(spec.fault_dip_deg * std::acos(-1.0) / 180.0);
  const double left = v.sample(Vec3(fault_at_z - 0.0015, 0.0, z)),
               right = v.sample(Vec3(fault_at_z + 0.0015, 0.0, z));
  CHECK(std::abs(left - right) > 0.2);
}

TEST_CASE("a NRRD volume without a space takes its axes' spacings, minimums, centering and units") {
  const fs::path path = temp_file("axes.nrrd");
  write(path,
        "NRRD0004\ntype: float\ndimension: 3\nsizes: 2 2 2\nspacings: 0.5 1 2\naxis mins: 10 20 30\n"
        "centers: cell cell node\nunits: \"mm\" \"mm\" \"mm\"\nencoding: ascii\n\n1 2 3 4 5 6 7 8\n");
  const ScalarVolume v = read_nrrd_volume(path);
  CHECK((v.spacing - Vec3(0.0005, 0.001, 0.002)).norm() < 1e-15);
  // Cell-centred: the first sample half a spacing beyond the minimum; node-centred: at it.
  CHECK((v.origin - Vec3(0.01025, 0.0205, 0.030)).norm() < 1e-15);
  const fs::path bad = temp_file("axes_bad.nrrd");
  write(bad,
        "NRRD0004\ntype: float\ndimension: 3\nsizes: 2 2 2\nspacings: 1 1 1\nunits: \"cm\" \"cm\" \"cm\"\n"
        "encoding: ascii\n\n1 2 3 4 5 6 7 8\n");
  CHECK_THROWS_WITH_AS((void)read_nrrd_volume(bad), doctest::Contains("units"), InputError);
}
