#include "cutting/cut_state.hpp"

#include <algorithm>
#include <vector>

#include "mesh/mesh.hpp"

namespace scalpel {

const std::array<Perm4, 24>& Perm4::all() {
  static const std::array<Perm4, 24> perms = [] {
    std::array<Perm4, 24> out{};
    std::array<std::uint8_t, 4> labels{0, 1, 2, 3};
    int i = 0;
    do out[static_cast<size_t>(i++)].p = labels;
    while (std::next_permutation(labels.begin(), labels.end()));
    return out;
  }();
  return perms;
}

Perm4 Perm4::compose(const Perm4& then) const {
  Perm4 r;
  for (int i = 0; i < 4; ++i) r.p[static_cast<size_t>(i)] = then.p[p[static_cast<size_t>(i)]];
  return r;
}

Perm4 Perm4::inverse() const {
  Perm4 r;
  for (std::uint8_t i = 0; i < 4; ++i) r.p[p[i]] = i;
  return r;
}

bool Perm4::odd() const {
  int inversions = 0;
  for (int i = 0; i < 4; ++i)
    for (int j = i + 1; j < 4; ++j)
      inversions += p[static_cast<size_t>(i)] > p[static_cast<size_t>(j)] ? 1 : 0;
  return inversions % 2 == 1;
}

int edge_index(int a, int b) {
  if (a > b) std::swap(a, b);
  for (int e = 0; e < 6; ++e)
    if (kEdgeVertices[static_cast<size_t>(e)][0] == a && kEdgeVertices[static_cast<size_t>(e)][1] == b)
      return e;
  return -1;
}

CutTopology permute(const CutTopology& t, const Perm4& perm) {
  CutTopology r;
  for (int e = 0; e < 6; ++e) {
    const auto& ev = kEdgeVertices[static_cast<size_t>(e)];
    const int image = edge_index(perm.p[static_cast<size_t>(ev[0])], perm.p[static_cast<size_t>(ev[1])]);
    if (t.edges & (1u << image)) r.edges |= static_cast<std::uint8_t>(1u << e);
  }
  // Face f is opposite vertex f, so faces permute like vertices.
  for (int f = 0; f < 4; ++f) {
    const int image = perm.p[static_cast<size_t>(f)];
    if (t.faces & (1u << image)) r.faces |= static_cast<std::uint8_t>(1u << f);
    if (t.entries & (1u << image)) r.entries |= static_cast<std::uint8_t>(1u << f);
  }
  return r;
}

namespace {

std::uint32_t encode(const CutTopology& t) {
  return (std::uint32_t{t.edges} << 8) | (std::uint32_t{t.faces} << 4) | t.entries;
}

}  // namespace

namespace {

CanonicalState search_canonical(const CutTopology& t) {
  CanonicalState best{permute(t, Perm4::all()[0]), Perm4::all()[0]};
  for (const Perm4& p : Perm4::all()) {
    const CutTopology image = permute(t, p);
    if (encode(image) < encode(best.reference)) best = {image, p};
  }
  return best;
}

}  // namespace

// All 2^14 topologies are canonicalized once, on first use (a few milliseconds): the cut step
// looks its states up.
CanonicalState canonicalize(const CutTopology& t) {
  static const std::vector<CanonicalState> table = [] {
    std::vector<CanonicalState> all(1u << 14);
    for (std::uint32_t code = 0; code < all.size(); ++code)
      all[code] = search_canonical({static_cast<std::uint8_t>(code >> 8),
                                    static_cast<std::uint8_t>((code >> 4) & 15u),
                                    static_cast<std::uint8_t>(code & 15u)});
    return all;
  }();
  return table[encode(t)];
}

EdgeClass edge_class(std::uint8_t mask) {
  const int n = __builtin_popcount(mask);
  auto vertex_degree = [mask](int v) {
    int d = 0;
    for (int e = 0; e < 6; ++e)
      if ((mask & (1u << e)) &&
          (kEdgeVertices[static_cast<size_t>(e)][0] == v || kEdgeVertices[static_cast<size_t>(e)][1] == v))
        ++d;
    return d;
  };
  std::array<int, 4> deg{};
  for (int v = 0; v < 4; ++v) deg[static_cast<size_t>(v)] = vertex_degree(v);
  const int max_deg = *std::max_element(deg.begin(), deg.end());
  const int touched = static_cast<int>(std::count_if(deg.begin(), deg.end(), [](int d) { return d > 0; }));
  switch (n) {
    case 0:
      return EdgeClass::None;
    case 1:
      return EdgeClass::One;
    case 2:
      return max_deg == 2 ? EdgeClass::TwoAdjacent : EdgeClass::TwoOpposite;
    case 3:
      if (max_deg == 3) return EdgeClass::ThreeAroundVertex;
      return touched == 3 ? EdgeClass::ThreeOnFace : EdgeClass::ThreePath;
    case 4:
      return max_deg == 2 ? EdgeClass::FourLoop : EdgeClass::FourNotLoop;
    case 5:
      return EdgeClass::Five;
    default:
      return EdgeClass::Six;
  }
}

const char* edge_class_name(EdgeClass c) {
  static constexpr const char* kNames[] = {"none",
                                           "one edge",
                                           "two adjacent",
                                           "two opposite",
                                           "three around a vertex",
                                           "three on a face",
                                           "three as a path",
                                           "four as a loop",
                                           "four not a loop",
                                           "five",
                                           "six"};
  return kNames[static_cast<int>(c)];
}

}  // namespace scalpel
