#include "mesh/volume.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace scalpel {

Vec3 ScalarVolume::far_corner() const {
  Vec3 c = origin;
  for (int a = 0; a < 3; ++a) c[a] += spacing[a] * static_cast<double>(size[static_cast<std::size_t>(a)] - 1);
  return c;
}

double ScalarVolume::sample(const Vec3& x) const {
  std::array<std::size_t, 3> i0{};
  std::array<double, 3> t{};
  for (std::size_t a = 0; a < 3; ++a) {
    const double last = static_cast<double>(size[a] - 1);
    const double u = std::clamp(
        (x[static_cast<int>(a)] - origin[static_cast<int>(a)]) / spacing[static_cast<int>(a)], 0.0, last);
    // The cell below u, the last cell for u on the far face.
    const double cell = std::min(std::floor(u), last - 1.0);
    i0[a] = static_cast<std::size_t>(cell);
    t[a] = u - cell;
  }
  double v = 0.0;
  for (int c = 0; c < 8; ++c) {
    const std::size_t di = c & 1, dj = (c >> 1) & 1, dk = (c >> 2) & 1;
    const double w = (di ? t[0] : 1.0 - t[0]) * (dj ? t[1] : 1.0 - t[1]) * (dk ? t[2] : 1.0 - t[2]);
    if (w != 0.0) v += w * at(i0[0] + di, i0[1] + dj, i0[2] + dk);
  }
  return v;
}

std::array<double, 2> ScalarVolume::range() const {
  if (values.empty()) return {0.0, 0.0};
  const auto [lo, hi] = std::minmax_element(values.begin(), values.end());
  return {*lo, *hi};
}

double ScalarVolume::distance_outside(const Vec3& x) const {
  const Vec3 hi = far_corner();
  return (origin - x).cwiseMax(x - hi).cwiseMax(0.0).norm();
}

ScalarVolume strata_volume(const StrataSpec& spec) {
  ScalarVolume v;
  v.size = spec.samples;
  v.origin = Vec3(-spec.size.x() / 2, -spec.size.y() / 2, -spec.size.z());
  for (int a = 0; a < 3; ++a)
    v.spacing[a] = spec.size[a] / static_cast<double>(v.size[static_cast<std::size_t>(a)] - 1);
  const double pi = std::acos(-1.0);
  const double dip = spec.fault_dip_deg * pi / 180.0;
  v.values.resize(v.size[0] * v.size[1] * v.size[2]);
  std::size_t i = 0;
  for (std::size_t k = 0; k < v.size[2]; ++k)
    for (std::size_t j = 0; j < v.size[1]; ++j)
      for (std::size_t l = 0; l < v.size[0]; ++l, ++i) {
        const Vec3 x = v.origin + Vec3(static_cast<double>(l), static_cast<double>(j), static_cast<double>(k))
                                      .cwiseProduct(v.spacing);
        // The depth of the stratum through x: the anticline lifts the strata near the centre line
        // (x = 0), gently along y; beyond the fault plane (x - fault_x > -z / tan(dip)) they drop.
        const double crest =
            std::cos(pi * x.x() / spec.size.x()) * std::cos(0.5 * pi * x.y() / spec.size.y());
        double depth = x.z() - spec.fold * crest;
        if (x.x() - spec.fault_x > -x.z() / std::tan(dip)) depth += spec.fault_throw;
        // Bands of one sign a wavelength apart, their strength varying from stratum to stratum.
        const double phase = 2.0 * pi * depth / spec.wavelength;
        const double strength = 0.65 + 0.35 * std::sin(phase / 3.7 + 0.4);
        v.values[i] = static_cast<float>(strength * std::sin(phase));
      }
  return v;
}

int sample_volume_onto(TetMesh& mesh, const ScalarVolume& volume, const std::string& name) {
  const int id = mesh.add_field(name);
  for (const NodeId n : mesh.nodes()) mesh.set_field(id, n, volume.sample(mesh.rest(n)));
  return id;
}

}  // namespace scalpel
