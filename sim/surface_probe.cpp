#include "sim/surface_probe.hpp"

#include <algorithm>

#include <cmath>
#include <limits>

#include "mesh/closest_point.hpp"
#include "mesh/topology.hpp"

namespace scalpel {

SurfaceProbe::SurfaceProbe(const TetMesh& uncut) {
  for (const BoundaryFace& f : boundary_faces(uncut)) faces_.push_back(f.nodes);
  // Far above the rounding of the tests below (relative 1e-16 of the mesh's size) and far below
  // anything a blade resolves.
  Aabb all;
  for (std::size_t f = 0; f < faces_.size(); ++f) all.extend(tight_box(uncut.rest_positions(), f));
  margin_ = faces_.empty() ? 0.0 : 1e-9 * (all.hi - all.lo).norm();
}

void SurfaceProbe::drop_faces_of(std::span<const std::uint32_t> removed) {
  std::erase_if(faces_, [&](const std::array<std::uint32_t, 3>& f) {
    return std::any_of(f.begin(), f.end(), [&](std::uint32_t n) {
      return std::binary_search(removed.begin(), removed.end(), n);
    });
  });
  // The trees name triangles by index: rebuilt at the next fit, until then every triangle is tested.
  current_ = {};
  rest_ = {};
}

Aabb SurfaceProbe::tight_box(const std::vector<Vec3>& x, std::size_t f) const {
  Aabb b;
  for (const std::uint32_t n : faces_[f]) b.extend(x[n]);
  return b;
}

Aabb SurfaceProbe::face_box(const std::vector<Vec3>& x, std::size_t f) const {
  Aabb b = tight_box(x, f);
  b.lo.array() -= margin_;
  b.hi.array() += margin_;
  return b;
}

void SurfaceProbe::fit(const TetMesh& mesh) {
  fit(current_, mesh.positions());
  // The triangles' corners never move at rest.
  if (!rest_.fits(mesh.rest_positions()) || rest_.tree.leaf_count() != faces_.size())
    fit(rest_, mesh.rest_positions());
}

void SurfaceProbe::fit(Boxes& boxes, const std::vector<Vec3>& x) {
  if (boxes.tree.leaf_count() != faces_.size()) {
    std::vector<AabbTree::LeafInput> leaves(faces_.size());
    for (std::size_t f = 0; f < faces_.size(); ++f)
      leaves[f] = {face_box(x, f), static_cast<std::uint32_t>(f)};
    boxes.tree.build(leaves, boxes.leaves);
  } else {
    for (std::size_t f = 0; f < faces_.size(); ++f)
      boxes.tree.set_leaf_box_only(boxes.leaves[f], face_box(x, f));
    boxes.tree.refit_internal(order_);
  }
  boxes.positions = &x;
}

bool SurfaceProbe::stale(const std::vector<Vec3>& x) const {
  const Boxes* b = boxes_for(x);
  if (!b) return false;  // every triangle is tested
  for (std::size_t f = 0; f < faces_.size(); ++f)
    if (!b->tree.node(b->leaves[f]).box.contains(tight_box(x, f))) return true;
  return false;
}

const SurfaceProbe::Boxes* SurfaceProbe::boxes_for(const std::vector<Vec3>& x) const {
  if (faces_.empty()) return nullptr;
  if (current_.fits(x)) return &current_;
  if (rest_.fits(x)) return &rest_;
  return nullptr;
}

namespace {

// Moller-Trumbore, edges inclusive, so a ray through an edge or a vertex still meets the surface:
// the ray's parameter where it meets triangle abc, if it does at t >= 0.
std::optional<double> ray_meets(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& from,
                                const Vec3& dir) {
  const Vec3 e1 = b - a, e2 = c - a;
  const Vec3 pv = dir.cross(e2);
  const double det = e1.dot(pv);
  if (det == 0.0) return std::nullopt;
  const Vec3 tv = from - a;
  const double u = tv.dot(pv) / det;
  if (u < 0.0 || u > 1.0) return std::nullopt;
  const Vec3 qv = tv.cross(e1);
  const double v = dir.dot(qv) / det;
  if (v < 0.0 || u + v > 1.0) return std::nullopt;
  const double t = e2.dot(qv) / det;
  if (t < 0.0) return std::nullopt;
  return t;
}

// Whether the ray from `from` along `dir` meets box b at a parameter in [0, t_max] (slabs).
bool ray_meets_box(const Aabb& b, const Vec3& from, const Vec3& dir, double t_max) {
  double lo = 0.0, hi = t_max;
  for (int k = 0; k < 3; ++k) {
    if (dir[k] == 0.0) {
      if (from[k] < b.lo[k] || from[k] > b.hi[k]) return false;
      continue;
    }
    double t1 = (b.lo[k] - from[k]) / dir[k], t2 = (b.hi[k] - from[k]) / dir[k];
    if (t1 > t2) std::swap(t1, t2);
    lo = std::max(lo, t1);
    hi = std::min(hi, t2);
    if (lo > hi) return false;
  }
  return true;
}

// The squared distance from p to box b: no more than to anything in it.
double distance2(const Aabb& b, const Vec3& p) {
  return (b.lo - p).cwiseMax(p - b.hi).cwiseMax(0.0).squaredNorm();
}

}  // namespace

std::optional<SurfaceProbe::Crossing> SurfaceProbe::first_crossing(const std::vector<Vec3>& x,
                                                                   const Vec3& tip, const Vec3& back) const {
  Crossing best;
  best.length = (back - tip).norm();
  if (!(best.length > 0.0)) return std::nullopt;
  const Vec3 dir = (back - tip) / best.length;
  best.dir = dir;
  // The nearest crossing, and among crossings at the same distance the first triangle in order.
  const auto test = [&](std::size_t f) {
    const auto& face = faces_[f];
    const Vec3 &a = x[face[0]], &b = x[face[1]], &c = x[face[2]];
    const auto t = ray_meets(a, b, c, tip, dir);
    if (!t || *t > best.t || (*t == best.t && f > best.index)) return;
    best.t = *t;
    best.normal = (b - a).cross(c - a);
    best.face = face;
    best.index = f;
  };
  if (const Boxes* boxes = boxes_for(x))
    boxes->tree.query([&](const Aabb& box) { return ray_meets_box(box, tip, dir, best.t); },
                      [&](std::uint32_t f) { test(f); }, stack_);
  else
    for (std::size_t f = 0; f < faces_.size(); ++f) test(f);
  return best;
}

std::optional<SurfaceHit> SurfaceProbe::above(const std::vector<Vec3>& x, const Vec3& tip,
                                              const Vec3& back) const {
  // The nearest crossing of the surface either way: the tip is under the surface when the ray first
  // leaves the tissue, not when it first enters it (a tip above a fold of the organ).
  const auto c = first_crossing(x, tip, back);
  if (!c || !c->leaving()) return std::nullopt;
  const Vec3 normal = c->normal.normalized();
  return SurfaceHit{c->t * c->dir.dot(normal), tip + c->t * c->dir, normal};
}

std::optional<Vec3> SurfaceProbe::deepest_in_tissue(const std::vector<Vec3>& x, const Vec3& tip,
                                                    const Vec3& back) const {
  const auto c = first_crossing(x, tip, back);
  if (!c || !std::isfinite(c->t)) return std::nullopt;
  if (c->leaving()) return tip;  // the tip is in the tissue
  if (c->t <= c->length) return Vec3(tip + c->t * c->dir);
  return std::nullopt;
}

std::optional<SurfaceHit> SurfaceProbe::entry(const std::vector<Vec3>& x, const Vec3& from,
                                              const Vec3& to) const {
  const auto c = first_crossing(x, from, to);
  if (!c || !(c->t <= c->length) || c->leaving()) return std::nullopt;
  const Vec3 normal = c->normal.normalized();
  return SurfaceHit{(c->length - c->t) * -c->dir.dot(normal), from + c->t * c->dir, normal, c->face};
}

SurfaceHit SurfaceProbe::nearest(const std::vector<Vec3>& x, const Vec3& p, const Vec3& up) const {
  SurfaceHit best;
  double best_d2 = std::numeric_limits<double>::infinity();
  std::size_t best_index = 0;
  const double up_norm = up.norm();
  // The nearest point, and among points at the same distance the first triangle's in order.
  const auto test = [&](std::size_t f) {
    const auto& face = faces_[f];
    const Vec3 &a = x[face[0]], &b = x[face[1]], &c = x[face[2]];
    const Vec3 n = (b - a).cross(c - a);
    if (!(n.squaredNorm() > 0) || !(n.dot(up) > kFacingCos * n.norm() * up_norm)) return;
    const Vec3 q = closest_point_on_triangle(p, a, b, c);
    const double d2 = (q - p).squaredNorm();
    if (d2 > best_d2 || (d2 == best_d2 && f > best_index)) return;
    best_d2 = d2;
    best_index = f;
    best = {std::sqrt(d2), q, n.normalized(), face};
  };
  if (const Boxes* boxes = boxes_for(x)) {
    // Nearer boxes first, so that the first triangles tested rule out most of the others.
    const AabbTree& tree = boxes->tree;
    stack_.assign(1, tree.root());
    while (!stack_.empty()) {
      const AabbTree::Node& n = tree.node(stack_.back());
      stack_.pop_back();
      if (distance2(n.box, p) > best_d2) continue;
      if (n.is_leaf()) {
        test(n.payload);
        continue;
      }
      const bool first_nearer =
          distance2(tree.node(n.child1).box, p) <= distance2(tree.node(n.child2).box, p);
      stack_.push_back(first_nearer ? n.child2 : n.child1);
      stack_.push_back(first_nearer ? n.child1 : n.child2);
    }
  } else
    for (std::size_t f = 0; f < faces_.size(); ++f) test(f);
  return best;
}

}  // namespace scalpel
