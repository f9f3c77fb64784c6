// The cut engine's internal types and helpers, shared by the files that implement its paper sections
// (cut_engine.cpp: the step, section 3; units.cpp; cut_nodes.cpp; subdivision.cpp; crack.cpp;
// virtual_nodes.cpp; continuation.cpp; seals.cpp; docs/README.md). Not part of the library's
// interface.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <vector>

#include "cutting/cut_engine.hpp"

namespace scalpel {

namespace cut_internal {

using Key3 = std::array<std::uint32_t, 3>;

inline Key3 sorted_key(std::uint32_t a, std::uint32_t b, std::uint32_t c) {
  Key3 k{a, b, c};
  std::sort(k.begin(), k.end());
  return k;
}

inline Key3 edge_key(std::uint32_t a, std::uint32_t b) {
  return {std::min(a, b), std::max(a, b), kInvalidIndex};
}

// Barycentric coordinates of p in triangle (a, b, c), p assumed near its plane.
inline Vec3 barycentric(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 n = (b - a).cross(c - a);
  const double nn = n.squaredNorm();
  if (nn == 0.0) return Vec3::Constant(1.0 / 3.0);
  const double la = (b - p).cross(c - p).dot(n) / nn;
  const double lb = (c - p).cross(a - p).dot(n) / nn;
  return {la, lb, 1.0 - la - lb};
}

// Pulls barycentric weights into the interior: every weight at least `floor` (a sliver guard).
inline Vec3 clamp_interior(Vec3 w, double floor) {
  w = w.cwiseMax(0.0);
  const double sum = w.sum();
  w = sum > 0 ? Vec3(w / sum) : Vec3::Constant(1.0 / 3.0);
  const double lo = w.minCoeff();
  if (lo >= floor) return w;
  // Blend toward the centroid just enough: (1-s) lo + s/3 = floor.
  const double s = (floor - lo) / (1.0 / 3.0 - lo);
  return (1.0 - s) * w + Vec3::Constant(s / 3.0);
}

// Normal of the surface the blade sweeps from `prev` to `pose` at blade parameter s (0 back, 1 tip):
// the blade's direction times its motion there.
inline Vec3 swept_normal(const BladePose& prev, const BladePose& pose, double s) {
  return (pose.tip - pose.back).cross((1.0 - s) * (pose.back - prev.back) + s * (pose.tip - prev.tip));
}

// The vertices of a tetrahedron but vertex `f`: its face f, in vertex order (not oriented).
template <class T>
std::array<T, 3> face_without(const std::array<T, 4>& tet, int f) {
  std::array<T, 3> out{};
  for (int i = 0, j = 0; i < 4; ++i)
    if (i != f) out[static_cast<size_t>(j++)] = tet[static_cast<size_t>(i)];
  return out;
}

// Parents of a node interpolated on a cut node's key edge (key[2] = kInvalidIndex) or face, at
// weights w.
inline NodeParents key_parents(const TetMesh& mesh, const std::array<std::uint32_t, 3>& key, const Vec3& w) {
  NodeParents p;
  p.count = key[2] == kInvalidIndex ? 2 : 3;
  for (int i = 0; i < p.count; ++i) {
    p.parents[static_cast<size_t>(i)] = mesh.node_handle(key[static_cast<size_t>(i)]);
    p.weights[static_cast<size_t>(i)] = w[i];
  }
  return p;
}

inline double triangle_area(const Vec3& a, const Vec3& b, const Vec3& c) {
  return 0.5 * (b - a).cross(c - a).norm();
}

inline int index_of(const std::array<std::uint64_t, 4>& t, std::uint64_t g) {
  for (int i = 0; i < 4; ++i)
    if (t[static_cast<size_t>(i)] == g) return i;
  return -1;
}

inline bool contains(const std::array<std::uint64_t, 4>& t, std::uint64_t g) {
  return index_of(t, g) >= 0;
}

// Stellar split of the sub-tetrahedron holding face {x, y, z} at a point inside that face: the
// three copies replace one face vertex each by m, so each keeps a positive volume (its volume is
// the barycentric weight of the replaced vertex times the parent's).
inline void split_face(std::vector<std::array<std::uint64_t, 4>>& subs, std::uint64_t x, std::uint64_t y,
                       std::uint64_t z, std::uint64_t m) {
  for (size_t s = 0; s < subs.size(); ++s) {
    const auto t = subs[s];
    if (!contains(t, x) || !contains(t, y) || !contains(t, z)) continue;
    bool first = true;
    for (int i = 0; i < 4; ++i) {
      const auto v = t[static_cast<size_t>(i)];
      if (v != x && v != y && v != z) continue;
      auto child = t;
      child[static_cast<size_t>(i)] = m;
      if (first) {
        subs[s] = child;
        first = false;
      } else {
        subs.push_back(child);
      }
    }
    return;
  }
  throw std::logic_error("CutEngine: face to split not found in the subdivision");
}

// Stellar split of every sub-tetrahedron holding edge {p, q} at a point inside it.
inline void split_edge(std::vector<std::array<std::uint64_t, 4>>& subs, std::uint64_t p, std::uint64_t q,
                       std::uint64_t x) {
  const size_t n = subs.size();
  for (size_t s = 0; s < n; ++s) {
    const int ip = index_of(subs[s], p), iq = index_of(subs[s], q);
    if (ip < 0 || iq < 0) continue;
    auto other = subs[s];
    subs[s][static_cast<size_t>(ip)] = x;
    other[static_cast<size_t>(iq)] = x;
    subs.push_back(other);
  }
}

// Barycentric weights of p in tetrahedron x by volumes: w_i is the volume with p in place of
// corner i over the whole; none for a tetrahedron of no positive volume.
inline std::optional<std::array<double, 4>> volume_weights(const Vec3& p, const std::array<Vec3, 4>& x) {
  const double whole = signed_volume(x[0], x[1], x[2], x[3]);
  if (!(whole > 0.0)) return std::nullopt;
  return std::array<double, 4>{
      signed_volume(p, x[1], x[2], x[3]) / whole, signed_volume(x[0], p, x[2], x[3]) / whole,
      signed_volume(x[0], x[1], p, x[3]) / whole, signed_volume(x[0], x[1], x[2], p) / whole};
}

// The tetrahedra of `m` holding a face or an edge (key {a, b, kInvalidIndex}): f(slot) for each,
// in no particular order.
template <class F>
void for_tets_around(const TetMesh& m, const Key3& key, F&& f) {
  for (const std::uint32_t t : m.node_tets(m.node_handle(key[0]))) {
    const auto& v = m.tet_vertex_indices(t);
    bool all = true;
    for (std::size_t i = 1; i < 3; ++i)
      if (key[i] != kInvalidIndex) all &= std::find(v.begin(), v.end(), key[i]) != v.end();
    if (all) f(t);
  }
}

}  // namespace cut_internal

template <class F>
void CutEngine::for_coarse_tets_around(const std::array<std::uint32_t, 3>& key, F&& f) const {
  cut_internal::for_tets_around(units_.mesh(), key, f);
}

}  // namespace scalpel
