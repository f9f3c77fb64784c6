// What the trajectory tests share: a platform-independent random generator, the meshes blades are
// run through, and a rotation.
#pragma once

#include <cmath>
#include <cstdint>
#include <string>

#include "mesh/io/mesh_io.hpp"
#include "mesh/mesh.hpp"
#include "mesh/quality.hpp"

namespace scalpel::testing {

// splitmix64: a small generator whose sequence is the same on every platform.
struct Rng {
  std::uint64_t state;
  std::uint64_t next() {
    std::uint64_t z = (state += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
  }
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
  double range(double a, double b) { return a + (b - a) * uniform(); }
  Vec3 in_ball(double r) {
    for (;;) {
      const Vec3 v(range(-1, 1), range(-1, 1), range(-1, 1));
      if (v.squaredNorm() <= 1.0) return r * v;
    }
  }
  Vec3 unit() {
    for (;;) {
      const Vec3 v = in_ball(1.0);
      if (v.squaredNorm() > 1e-4) return v.normalized();
    }
  }
};

// A mesh to cut, with its bounding box and a typical edge length.
struct Scene {
  std::string name;
  std::string tag;  // how a regression file names the mesh (test_cut_fuzzer.cpp)
  TetMesh mesh;
  double volume = 0;
  Vec3 lo, hi;
  double h = 0;  // [m]
};

inline Scene gmsh_scene(const std::string& name, const char* path) {
  Scene s;
  s.name = name;
  s.mesh = read_gmsh(path);
  const MeshSummary m = summarize(s.mesh);
  s.volume = m.rest_volume;
  s.lo = m.box_min;
  s.hi = m.box_max;
  s.h = std::cbrt(6.0 * m.rest_volume / static_cast<double>(m.tets)) * 1.5;
  return s;
}

// Rotates v about the unit axis a by angle w.
inline Vec3 rotate(const Vec3& v, const Vec3& a, double w) {
  return v * std::cos(w) + a.cross(v) * std::sin(w) + a * a.dot(v) * (1 - std::cos(w));
}

}  // namespace scalpel::testing
