// NRRD volumes through Teem's nrrd library (mesh/volume.hpp). Teem reports a problem as a stack of
// messages (biff); the deepest says what was wrong. The header is scanned here only to name the line
// of the field that message is about.
#include <teem/air.h>
#include <teem/biff.h>
#include <teem/nrrd.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "base/input_error.hpp"
#include "mesh/volume.hpp"

namespace scalpel {
namespace {

struct NrrdDeleter {
  void operator()(Nrrd* n) const { nrrdNuke(n); }
};
using NrrdPtr = std::unique_ptr<Nrrd, NrrdDeleter>;

// The header's lines, up to the blank line that ends it (or the first 1000 lines).
std::vector<std::string> header_lines(const std::filesystem::path& path) {
  std::vector<std::string> lines;
  std::ifstream in(path, std::ios::binary);
  std::string line;
  while (lines.size() < 1000 && std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) break;
    lines.push_back(line);
  }
  return lines;
}

// Teem's messages, popped, as lines without the "[nrrd] function: " prefixes.
std::vector<std::string> teem_messages() {
  char* raw = biffGetDone(NRRD);
  std::vector<std::string> out;
  std::istringstream in(raw ? raw : "");
  std::free(raw);
  std::string line;
  while (std::getline(in, line)) {
    if (const auto bracket = line.find("] "); line.starts_with('[') && bracket != std::string::npos)
      line = line.substr(bracket + 2);
    if (const auto colon = line.find(": "); colon != std::string::npos && line.find(' ') > colon)
      line = line.substr(colon + 2);
    else if (!line.empty() && line.back() == ':' && line.find(' ') == std::string::npos)
      line.clear();
    if (!line.empty() && line != "trouble") out.push_back(line);
  }
  return out;
}

class Located {
 public:
  explicit Located(std::filesystem::path path) : path_(std::move(path)), lines_(header_lines(path_)) {}

  // The 1-based line of header field `field` ("sizes", "space directions"), 0 if absent.
  [[nodiscard]] int line_of(const std::string& field) const {
    for (std::size_t i = 0; i < lines_.size(); ++i)
      if (lines_[i].starts_with(field + ":")) return static_cast<int>(i) + 1;
    return 0;
  }
  [[noreturn]] void fail(const std::string& field, const std::string& message) const {
    throw InputError(path_.string(), field == "data" ? data_line() : line_of(field), 0, field, message);
  }
  // The first line of attached data: after the header and the blank line that ends it.
  [[nodiscard]] int data_line() const { return static_cast<int>(lines_.size()) + 2; }
  // Teem's failure to read, located at the field it names.
  [[noreturn]] void fail_teem() const {
    const std::vector<std::string> messages = teem_messages();
    std::string field = "data", message = messages.empty() ? "cannot be read" : messages.back();
    int line = data_line();
    for (const std::string& m : messages) {
      if (const auto at = m.find("trouble parsing "); at != std::string::npos) {
        const auto info = m.find(" info", at);
        if (info != std::string::npos) {
          field = m.substr(at + 16, info - at - 16);
          line = line_of(field);
          break;
        }
      }
      if (const auto at = m.find("field identifier from in \""); at != std::string::npos) {
        const std::string text = m.substr(at + 26, m.size() - at - 27);
        field = text.substr(0, text.find(':'));
        for (std::size_t i = 0; i < lines_.size(); ++i)
          if (lines_[i] == text) line = static_cast<int>(i) + 1;
        message = "unknown field '" + field + "'";
        break;
      }
      if (m.find("couldn't fopen") != std::string::npos || m.find("couldn't open") != std::string::npos) {
        field = "file";
        line = 0;
        message = m;
        break;
      }
    }
    throw InputError(path_.string(), line, 0, field, message);
  }

 private:
  std::filesystem::path path_;
  std::vector<std::string> lines_;
};

// Metres per unit of a "space units" entry.
double unit_scale(const Located& at, const char* unit, const std::string& field = "space units") {
  const std::string u = unit ? unit : "";
  if (u.empty() || u == "m") return 1.0;
  if (u == "mm") return 1e-3;
  at.fail(field, "unit '" + u + "' is not supported (m or mm)");
}

}  // namespace

ScalarVolume read_nrrd_volume(const std::filesystem::path& path) {
  const Located at(path);
  if (!std::filesystem::is_regular_file(path)) throw InputError(path.string(), 0, 0, "file", "no such file");
  NrrdPtr nrrd(nrrdNew());
  if (nrrdLoad(nrrd.get(), path.string().c_str(), nullptr) != 0) at.fail_teem();
  if (nrrd->dim != 3) at.fail("dimension", std::to_string(nrrd->dim) + " axes; a volume has 3 (x, y, z)");
  ScalarVolume v;
  v.file = path;
  for (std::size_t a = 0; a < 3; ++a) {
    v.size[a] = nrrd->axis[a].size;
    if (v.size[a] < 2)
      at.fail("sizes", "axis " + std::to_string(a) + " has " + std::to_string(v.size[a]) +
                           " sample; a volume needs at least 2 along each axis");
  }
  if (nrrd->spaceDim != 0) {
    if (nrrd->spaceDim != 3) at.fail("space", "a volume needs a 3-dimensional space");
    for (int a = 0; a < 3; ++a) {
      const double scale = unit_scale(at, nrrd->spaceUnits[a]);
      const double* d = nrrd->axis[a].spaceDirection;
      if (!std::isfinite(d[0]) || !std::isfinite(d[1]) || !std::isfinite(d[2]))
        at.fail(at.line_of("space directions") > 0 ? "space directions" : "space",
                "axis " + std::to_string(a) + " has no space direction: a volume in a space needs all three");
      for (int c = 0; c < 3; ++c)
        if (c != a && d[c] != 0.0)
          at.fail("space directions", "axis " + std::to_string(a) +
                                          " is not along the space's axis of that number: volumes must be "
                                          "axis-aligned, x varying fastest");
      if (!(d[a] > 0.0) || !std::isfinite(d[a]))
        at.fail("space directions", "axis " + std::to_string(a) + " needs a positive, finite step");
      v.spacing[a] = scale * d[a];
      const double o = nrrd->spaceOrigin[a];
      v.origin[a] = std::isfinite(o) ? scale * o : 0.0;
    }
  } else {
    for (unsigned a = 0; a < 3; ++a) {
      const int i = static_cast<int>(a);
      const double scale = at.line_of("units") > 0 ? unit_scale(at, nrrd->axis[a].units, "units") : 1.0;
      const double s = nrrd->axis[a].spacing;
      if (std::isfinite(s) && !(s > 0.0))
        at.fail("spacings", "axis " + std::to_string(a) + " needs a positive spacing");
      v.spacing[i] = scale * (std::isfinite(s) ? s : 1.0);
      // With an axis minimum, sample 0 lies there (node centering, or none given) or half a spacing
      // beyond it (cell centering); without, at 0.
      const double m = nrrd->axis[a].min;
      const double first =
          !std::isfinite(m) ? 0.0
                            : m + (nrrd->axis[a].center == nrrdCenterCell ? 0.5 * v.spacing[i] / scale : 0.0);
      v.origin[i] = scale * (std::isfinite(first) ? first : 0.0);
    }
  }
  NrrdPtr floats(nrrdNew());
  if (nrrdConvert(floats.get(), nrrd.get(), nrrdTypeFloat) != 0) at.fail_teem();
  const std::size_t count = v.size[0] * v.size[1] * v.size[2];
  const auto* data = static_cast<const float*>(floats->data);
  v.values.assign(data, data + count);
  for (std::size_t i = 0; i < count; ++i)
    if (!std::isfinite(v.values[i]))
      at.fail("data", "sample " + std::to_string(i) + " is not a finite number");
  return v;
}

void write_nrrd_volume(const ScalarVolume& volume, const std::filesystem::path& path) {
  if (volume.values.size() != volume.size[0] * volume.size[1] * volume.size[2])
    throw std::invalid_argument("write_nrrd_volume: " + std::to_string(volume.values.size()) +
                                " values for a grid of " + std::to_string(volume.size[0]) + " x " +
                                std::to_string(volume.size[1]) + " x " + std::to_string(volume.size[2]));
  Nrrd* nrrd = nrrdNew();
  // Teem does not write through the pointer it wraps.
  auto* data = const_cast<float*>(volume.values.data());
  auto fail = [&] {
    const std::vector<std::string> messages = teem_messages();
    nrrdNix(nrrd);
    throw std::runtime_error("cannot write " + path.string() + ": " +
                             (messages.empty() ? std::string("unknown error") : messages.back()));
  };
  if (nrrdWrap_va(nrrd, data, nrrdTypeFloat, 3u, volume.size[0], volume.size[1], volume.size[2]) != 0) fail();
  if (nrrdSpaceSet(nrrd, nrrdSpace3DRightHanded) != 0) fail();
  double origin[NRRD_SPACE_DIM_MAX] = {volume.origin.x(), volume.origin.y(), volume.origin.z()};
  if (nrrdSpaceOriginSet(nrrd, origin) != 0) fail();
  double dx[NRRD_SPACE_DIM_MAX] = {volume.spacing.x(), 0, 0};
  double dy[NRRD_SPACE_DIM_MAX] = {0, volume.spacing.y(), 0};
  double dz[NRRD_SPACE_DIM_MAX] = {0, 0, volume.spacing.z()};
  nrrdAxisInfoSet_va(nrrd, nrrdAxisInfoSpaceDirection, dx, dy, dz);
  for (int a = 0; a < 3; ++a) nrrd->spaceUnits[a] = airStrdup("m");
  NrrdIoState* io = nrrdIoStateNew();
  io->encoding = nrrdEncodingGzip;
  const int rc = nrrdSave(path.string().c_str(), nrrd, io);
  nrrdIoStateNix(io);
  if (rc != 0) fail();
  nrrdNix(nrrd);  // frees the header (the space units too), not the data it wraps
}

}  // namespace scalpel
