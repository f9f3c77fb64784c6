// A scalar volume on a regular, axis-aligned grid (volume data, paper section 7.1), its trilinear
// sampling, and the per-node field a mesh carries from it. The mesh samples the volume once, at its
// nodes' rest positions; from then on the cutter carries the field to every node it creates by the
// interpolation weights it records (TetMesh::add_interpolated_node), so a cut face shows the
// volume's value wherever it opens (to the accuracy of linear interpolation over the original mesh).
#pragma once

#include <array>
#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include "mesh/mesh.hpp"

namespace scalpel {

struct ScalarVolume {
  std::array<std::size_t, 3> size{};  // samples per axis, each >= 2
  Vec3 origin = Vec3::Zero();         // [m] position of sample (0, 0, 0)
  Vec3 spacing = Vec3::Ones();        // [m] between samples, per axis, > 0
  std::vector<float> values;          // x fastest, then y, then z
  std::filesystem::path file;         // where it was read from (empty if built in memory)

  [[nodiscard]] float at(std::size_t i, std::size_t j, std::size_t k) const {
    return values[(k * size[1] + j) * size[0] + i];
  }
  // Position of the last sample [m].
  [[nodiscard]] Vec3 far_corner() const;
  // Trilinear interpolation at x [m]; outside the grid, the value at the nearest point of it.
  [[nodiscard]] double sample(const Vec3& x) const;
  // The smallest and largest sample value.
  [[nodiscard]] std::array<double, 2> range() const;
  // How far x lies outside the grid's box [m]; 0 inside.
  [[nodiscard]] double distance_outside(const Vec3& x) const;
};

// Reads a NRRD volume (attached or detached data; raw, ASCII or gzip encoding; any scalar type)
// through Teem's nrrd library. It must be 3-dimensional with scalar samples, and its space
// directions, when given, axis-aligned with positive steps; "space units" of "mm" scale to metres
// (anything else but "m" is refused). Without a space, the axes' spacings (1 when none is given)
// and, where an axis has a minimum, the first sample's position by its centering (else 0); per-axis
// "units" of "mm" scale these. Every problem is an InputError naming the file, the header line and
// the field; a problem in the data names the first line of data (after the blank line).
[[nodiscard]] ScalarVolume read_nrrd_volume(const std::filesystem::path& path);

// Writes `volume` as an attached, gzip-encoded NRRD of floats with its grid in metres.
void write_nrrd_volume(const ScalarVolume& volume, const std::filesystem::path& path);

// A layered "seismic" data set for the volume data scenario: strata folded into an anticline and
// offset by a normal fault, the value a reflection amplitude in [-1, 1] (bands of alternating sign
// that follow the strata), on a grid over [-size/2, size/2] in x and y and [-size.z(), 0] in z.
struct StrataSpec {
  Vec3 size = Vec3(0.06, 0.06, 0.04);  // [m]
  std::array<std::size_t, 3> samples{49, 49, 33};
  double wavelength = 0.010;    // [m] between bands of one sign
  double fold = 0.006;          // [m] height of the anticline's crest over its flanks
  double fault_dip_deg = 60.0;  // the fault plane from horizontal, dipping towards +x
  double fault_x = 0.008;       // [m] where the fault meets the top (y = 0)
  double fault_throw = 0.004;   // [m] the hanging wall (x beyond the fault) moved down
};
[[nodiscard]] ScalarVolume strata_volume(const StrataSpec& spec = {});

// Adds (or overwrites) the mesh field `name` with the volume's value at every node's rest position;
// returns the field's id.
int sample_volume_onto(TetMesh& mesh, const ScalarVolume& volume, const std::string& name);

}  // namespace scalpel
