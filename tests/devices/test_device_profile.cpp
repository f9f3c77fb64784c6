#include <doctest/doctest.h>

#include <filesystem>

#include "base/input_error.hpp"
#include "devices/device_profile.hpp"
#include "tests/devices/fake_transport.hpp"

using namespace scalpel;

namespace {

const std::string kProfiles = std::string(SCALPEL_SOURCE_DIR) + "/config/devices";
const std::string kData = std::string(SCALPEL_TEST_DATA_DIR) + "/hid";

DeviceProfile shipped(const std::string& stem) {
  return load_device_profile(kProfiles + "/" + stem + ".yaml");
}

double value(const ReportValues& v, Axis a) {
  return v.axis[static_cast<std::size_t>(a)];
}
bool has(const ReportValues& v, Axis a) {
  return v.has[static_cast<std::size_t>(a)];
}

const char* kMinimal = R"(name: test
transport: hid
match: [{vendor_id: 0x1234, product_id: 0x5678}]
motion: absolute
workspace: {min: [-1, -1, -1], max: [1, 1, 1]}
input_reports:
  - id: 1
    length: 13
    fields:
      - {axis: x, offset: 1, type: f32le}
      - {axis: y, offset: 5, type: f32le}
      - {axis: z, offset: 9, type: f32le}
)";

}  // namespace

TEST_CASE("every shipped device profile loads and has raw report data") {
  const std::vector<DeviceProfile> all = load_device_profiles(kProfiles);
  REQUIRE(all.size() == 4);
  for (const DeviceProfile& p : all) {
    CAPTURE(p.file);
    const std::string stem = std::filesystem::path(p.file).stem().string();
    CHECK(std::filesystem::exists(kData + "/" + stem + ".txt"));
    CHECK_FALSE(p.match.empty());
  }
}

TEST_CASE("legacy SpaceMouse reports parse into mapped rates") {
  const DeviceProfile p = shipped("spacemouse_legacy");
  CHECK(p.motion == Motion::Rate);
  CHECK(p.matches(0x046d, 0xc626));
  const auto r = test::load_reports(kData + "/spacemouse_legacy.txt");
  ReportValues v;
  REQUIRE(parse_report(p, r.at("translation"), v) == ParseResult::Ok);
  CHECK(value(v, Axis::X) == doctest::Approx(350 * 2e-4));
  CHECK(value(v, Axis::Z) == doctest::Approx(-100 * 2e-4));  // device y -> world z
  CHECK(value(v, Axis::Y) == doctest::Approx(-20 * 2e-4));   // device z (down) -> world -y
  CHECK_FALSE(has(v, Axis::RX));
  REQUIRE(parse_report(p, r.at("rotation"), v) == ParseResult::Ok);
  CHECK(value(v, Axis::RX) == doctest::Approx(-200 * 2e-3));
  CHECK(value(v, Axis::RY) == 0.0);  // 5 counts: inside the dead band
  CHECK(value(v, Axis::RZ) == 0.0);
  REQUIRE(parse_report(p, r.at("buttons"), v) == ParseResult::Ok);
  CHECK(v.buttons == 2);
  CHECK(v.buttons_mask == 0xff);
  CHECK(parse_report(p, r.at("short"), v) == ParseResult::Short);
  CHECK(parse_report(p, r.at("unknown_id"), v) == ParseResult::Malformed);
}

TEST_CASE("SpaceMouse reports carry translation and rotation in report 1") {
  const DeviceProfile p = shipped("spacemouse");
  CHECK(p.matches(0x256f, 0xc635));
  const auto r = test::load_reports(kData + "/spacemouse.txt");
  ReportValues v;
  REQUIRE(parse_report(p, r.at("motion"), v) == ParseResult::Ok);
  CHECK(value(v, Axis::X) == doctest::Approx(0.02));
  CHECK(value(v, Axis::Z) == 0.0);
  CHECK(value(v, Axis::Y) == doctest::Approx(0.01));
  CHECK(value(v, Axis::RX) == 0.0);
  CHECK(value(v, Axis::RZ) == doctest::Approx(0.6));
  CHECK(value(v, Axis::RY) == 0.0);  // -4 counts: dead band
  REQUIRE(parse_report(p, r.at("buttons"), v) == ParseResult::Ok);
  CHECK(v.buttons == 1);
  CHECK(parse_report(p, r.at("short"), v) == ParseResult::Short);
}

TEST_CASE("generic stylus reports parse into a pose and forces encode into its output report") {
  const DeviceProfile p = shipped("generic_stylus");
  CHECK(p.motion == Motion::Absolute);
  const auto r = test::load_reports(kData + "/generic_stylus.txt");
  ReportValues v;
  REQUIRE(parse_report(p, r.at("pose"), v) == ParseResult::Ok);
  CHECK(value(v, Axis::X) == doctest::Approx(0.1));
  CHECK(value(v, Axis::Y) == doctest::Approx(-0.05));
  CHECK(value(v, Axis::Z) == doctest::Approx(0.00025));
  CHECK(value(v, Axis::QW) == doctest::Approx(std::sqrt(0.5)).epsilon(1e-4));
  CHECK(value(v, Axis::QY) == doctest::Approx(std::sqrt(0.5)).epsilon(1e-4));
  CHECK(v.buttons == 1);
  CHECK(parse_report(p, r.at("short"), v) == ParseResult::Short);

  std::array<std::uint8_t, 16> out{};
  REQUIRE(encode_force(p, Eigen::Vector3d(1.0, -0.5, 0.25), Eigen::Vector3d::Zero(), out) == 7);
  CHECK(std::vector<std::uint8_t>(out.begin(), out.begin() + 7) == r.at("force_out"));
  // Saturation at the type's range, not wrap-around.
  REQUIRE(encode_force(p, Eigen::Vector3d(100.0, 0, 0), Eigen::Vector3d::Zero(), out) == 7);
  CHECK(out[1] == 0xff);
  CHECK(out[2] == 0x7f);
}

TEST_CASE("non-finite float fields make a report malformed") {
  const DeviceProfile p = parse_device_profile(kMinimal, "mem.yaml");
  std::vector<std::uint8_t> rep(13, 0);
  rep[0] = 1;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::memcpy(rep.data() + 5, &nan, 4);
  ReportValues v;
  CHECK(parse_report(p, rep, v) == ParseResult::Malformed);
}

TEST_CASE("profile errors name the file, line and key") {
  std::string t = kMinimal;
  CHECK(test::profile_error(t + "colour: red\n") == "bad.yaml:13:1: colour: unknown key");
  std::string wrong_type = t;
  wrong_type.replace(wrong_type.find("type: f32le}\n      - {axis: y"), 11, "type: f64le");
  CHECK(test::profile_error(wrong_type).find("bad.yaml:10:") == 0);
  CHECK(test::profile_error(wrong_type).find("input_reports[0].fields[0].type: unknown type 'f64le'") !=
        std::string::npos);
  std::string past_end = t;
  past_end.replace(past_end.find("offset: 9"), 9, "offset: 11");
  CHECK(test::profile_error(past_end).find(
            "input_reports[0].fields[2].offset: field ends past the report length 13") != std::string::npos);
  std::string bad_vid = t;
  bad_vid.replace(bad_vid.find("0x1234"), 6, "0x12345");
  CHECK(test::profile_error(bad_vid).find("bad.yaml:3:") == 0);
  CHECK(test::profile_error(bad_vid).find("match[0].vendor_id: out of range") != std::string::npos);
  std::string no_motion = t;
  no_motion.replace(no_motion.find("motion: absolute\n"), 17, "");
  CHECK(test::profile_error(no_motion).find("motion: missing") != std::string::npos);
  std::string signed_buttons = t;
  signed_buttons.replace(signed_buttons.find("{axis: z, offset: 9, type: f32le}"), 33,
                         "{axis: buttons, offset: 9, type: i8}");
  CHECK(test::profile_error(signed_buttons)
            .find("bad.yaml:12:9: input_reports[0].fields[2]: buttons are an unsigned") == 0);
  CHECK(test::profile_error("name: [unclosed").find("bad.yaml:") == 0);
  CHECK_THROWS_AS((void)load_device_profile("/nonexistent/profile.yaml"), InputError);
}

TEST_CASE("a profile that maps a key, a byte, an axis or a button twice is refused where it does") {
  const std::string t = kMinimal;
  const auto with = [&](const std::string& from, const std::string& to) {
    std::string s = t;
    s.replace(s.find(from), from.size(), to);
    return s;
  };
  // yaml-cpp keeps both entries of a repeated key and reads the first: the second was ignored.
  CHECK(test::profile_error(t + "name: other\n") == "bad.yaml:13:1: name: duplicate key");
  CHECK(test::profile_error(with("{axis: y, offset: 5,", "{axis: y, offset: 5, offset: 6,")) ==
        "bad.yaml:11:30: input_reports[0].fields[1].offset: duplicate key");
  // A key that is a list or a mapping threw yaml-cpp's conversion error: exit 3, no file named.
  CHECK(test::profile_error("? [vendor_id, product_id]\n: 1\n") ==
        "bad.yaml:1:3: expected a key name, found a list or mapping");
  CHECK(test::profile_error(with("workspace: {min:", "workspace: {{a: 1}: 2, min:")) ==
        "bad.yaml:5:13: workspace: expected a key name, found a list or mapping");
  // Two fields on one byte decoded it twice.
  CHECK(test::profile_error(with("{axis: z, offset: 9, type: f32le}", "{axis: z, offset: 7, type: f32le}")) ==
        "bad.yaml:12:27: input_reports[0].fields[2].offset: bytes 7-10 overlap those of "
        "input_reports[0].fields[1] (bytes 5-8)");
  // An axis mapped twice took whichever report came last.
  CHECK(test::profile_error(with("{axis: z,", "{axis: x,")) ==
        "bad.yaml:12:16: input_reports[0].fields[2].axis: axis 'x' is already mapped by "
        "input_reports[0].fields[0]");
  const std::string two_reports =
      t + "  - id: 2\n    length: 5\n    fields: [{axis: y, offset: 1, type: f32le}]\n";
  CHECK(test::profile_error(two_reports) ==
        "bad.yaml:15:21: input_reports[1].fields[0].axis: axis 'y' is already mapped by "
        "input_reports[0].fields[1]");
  const std::string forces = t +
                             "output_report:\n  id: 2\n  length: 5\n  fields:\n"
                             "    - {axis: fx, offset: 1, type: i16le}\n"
                             "    - {axis: fx, offset: 3, type: i16le}\n"
                             "max_force: 1\nmax_force_rate: 1\n";
  CHECK(test::profile_error(forces) ==
        "bad.yaml:18:14: output_report.fields[1].axis: axis 'fx' is already mapped by "
        "output_report.fields[0]");
  // Buttons may be spread over fields, each its own bits of the 32-bit mask.
  const std::string buttons = t +
                              "  - id: 3\n    length: 4\n    fields:\n"
                              "      - {axis: buttons, offset: 1, type: u8}\n"
                              "      - {axis: buttons, offset: 2, type: u8, shift: 8}\n";
  const DeviceProfile p = parse_device_profile(
      buttons + "      - {axis: buttons, offset: 3, type: u8, shift: 16}\n", "good.yaml");
  REQUIRE(p.input_reports.size() == 2);
  CHECK(p.input_reports[1].fields.size() == 3);
  CHECK(test::profile_error(buttons + "      - {axis: buttons, offset: 3, type: u8, shift: 4}\n") ==
        "bad.yaml:18:53: input_reports[1].fields[2].shift: buttons bits overlap those of "
        "input_reports[1].fields[0]");
  CHECK(test::profile_error(buttons + "      - {axis: buttons, offset: 3, type: u8, shift: 28}\n") ==
        "bad.yaml:18:53: input_reports[1].fields[2].shift: bits 28-35 of the buttons go past bit 31");
}
