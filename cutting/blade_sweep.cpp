#include "cutting/blade_sweep.hpp"

#include <algorithm>
#include <cmath>
#include <tuple>

#include <gmp.h>

#include "mesh/predicates.hpp"

namespace scalpel {

namespace {

// Exact sign of component `axis` of (b-a) x (q-p). Only reached when an orient3d is exactly zero.
int exact_cross_of_differences_sign(const Vec3& a, const Vec3& b, const Vec3& p, const Vec3& q, int axis) {
  const int i = (axis + 1) % 3, j = (axis + 2) % 3;
  mpq_t ui, uj, vi, vj, tmp, l, r;
  mpq_inits(ui, uj, vi, vj, tmp, l, r, nullptr);
  auto diff = [&](mpq_t out, double x, double y) {  // out = x - y, exactly
    mpq_set_d(out, x);
    mpq_set_d(tmp, y);
    mpq_sub(out, out, tmp);
  };
  diff(ui, b[i], a[i]);
  diff(uj, b[j], a[j]);
  diff(vi, q[i], p[i]);
  diff(vj, q[j], p[j]);
  mpq_mul(l, ui, vj);
  mpq_mul(r, uj, vi);
  mpq_sub(l, l, r);
  const int s = mpq_sgn(l);
  mpq_clears(ui, uj, vi, vj, tmp, l, r, nullptr);
  return s;
}

// Floating-point determinant det[b-a, c-a, d-a] (the magnitude behind orient3d's sign).
double orient_value(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  return (b - a).dot((c - a).cross(d - a));
}

bool triangle_has_area(const Vec3& p, const Vec3& q, const Vec3& r) {
  return orient2d_projected(p, q, r, 0) != 0 || orient2d_projected(p, q, r, 1) != 0 ||
         orient2d_projected(p, q, r, 2) != 0;
}

// Barycentric weights from three values that the exact predicates found to have one sign; float
// rounding may flip a tiny one, so negatives of the wrong sign are clamped.
Vec3 normalised_weights(double w0, double w1, double w2) {
  if (w0 + w1 + w2 < 0) {
    w0 = -w0;
    w1 = -w1;
    w2 = -w2;
  }
  w0 = std::max(w0, 0.0);
  w1 = std::max(w1, 0.0);
  w2 = std::max(w2, 0.0);
  const double sum = w0 + w1 + w2;
  if (!(sum > 0)) return Vec3::Constant(1.0 / 3.0);  // unreachable for a non-degenerate crossing
  return Vec3(w0, w1, w2) / sum;
}

// Parameter of the plane crossing from the two signed distances (same exact signs as the predicates).
double crossing_param(double d0, double d1) {
  const double den = d0 - d1;
  if (den == 0) return 0.5;
  return std::clamp(d0 / den, 0.0, 1.0);
}

Vec3 project_on_line(const Vec3& p, const Vec3& t, const Vec3& x) {
  const Vec3 d = t - p;
  const double l2 = d.squaredNorm();
  if (!(l2 > 0)) return p;
  return p + ((x - p).dot(d) / l2) * d;
}

// Separating-axis test of a box (centre c, half extents h) against a triangle (Akenine-Moeller's
// 13 axes). Conservative: `true` unless an axis separates them.
bool box_touches_triangle(const Vec3& c, const Vec3& h, const Vec3& v0, const Vec3& v1, const Vec3& v2) {
  const Vec3 a0 = v0 - c, a1 = v1 - c, a2 = v2 - c;
  auto separated = [&](const Vec3& axis) {
    const double p0 = axis.dot(a0), p1 = axis.dot(a1), p2 = axis.dot(a2);
    const double r = h.dot(axis.cwiseAbs());
    return std::min({p0, p1, p2}) > r || std::max({p0, p1, p2}) < -r;
  };
  for (int k = 0; k < 3; ++k) {
    if (std::min({a0[k], a1[k], a2[k]}) > h[k] || std::max({a0[k], a1[k], a2[k]}) < -h[k]) return false;
  }
  const Vec3 e[3] = {a1 - a0, a2 - a1, a0 - a2};
  if (separated(e[0].cross(e[1]))) return false;
  for (int k = 0; k < 3; ++k) {
    const Vec3 unit = Vec3::Unit(k);
    for (const Vec3& edge : e) {
      if (separated(unit.cross(edge))) return false;
    }
  }
  return true;
}

}  // namespace

int perturbed_orient_blade_triangle_mesh_point(const Vec3& p, const Vec3& q, const Vec3& r, const Vec3& a) {
  if (const int d = orient3d(p, q, r, a); d != 0) return d;
  for (int axis = 0; axis < 3; ++axis) {  // g = (q-p) x (r-p)
    if (const int s = orient2d_projected(p, q, r, axis); s != 0) return s;
  }
  return 0;
}

int perturbed_orient_mesh_triangle_blade_point(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& x) {
  if (const int d = orient3d(a, b, c, x); d != 0) return d;
  for (int axis = 0; axis < 3; ++axis) {  // g = -((b-a) x (c-a))
    if (const int s = orient2d_projected(a, b, c, axis); s != 0) return -s;
  }
  return 0;
}

int perturbed_orient_mesh_edge_blade_edge(const Vec3& a, const Vec3& b, const Vec3& p, const Vec3& q) {
  if (const int d = orient3d(a, b, p, q); d != 0) return d;
  for (int axis = 0; axis < 3; ++axis) {  // g = (b-a) x (q-p)
    if (const int s = exact_cross_of_differences_sign(a, b, p, q, axis); s != 0) return s;
  }
  return 0;
}

bool mesh_segment_crosses_blade_triangle(const Vec3& a, const Vec3& b, const Vec3& p, const Vec3& q,
                                         const Vec3& r, SegmentTriangleHit* hit) {
  const int sa = perturbed_orient_blade_triangle_mesh_point(p, q, r, a);
  const int sb = perturbed_orient_blade_triangle_mesh_point(p, q, r, b);
  if (sa == 0 || sb == 0 || sa == sb) return false;
  const int e0 = perturbed_orient_mesh_edge_blade_edge(a, b, q, r);  // weight of p
  if (e0 == 0) return false;
  if (perturbed_orient_mesh_edge_blade_edge(a, b, r, p) != e0) return false;  // weight of q
  if (perturbed_orient_mesh_edge_blade_edge(a, b, p, q) != e0) return false;  // weight of r
  if (hit != nullptr) {
    const Vec3 n = (q - p).cross(r - p);
    hit->segment_param = crossing_param(n.dot(a - p), n.dot(b - p));
    hit->triangle_bary =
        normalised_weights(orient_value(a, b, q, r), orient_value(a, b, r, p), orient_value(a, b, p, q));
    hit->side0 = sa;
  }
  return true;
}

bool blade_segment_crosses_mesh_triangle(const Vec3& x0, const Vec3& x1, const Vec3& a, const Vec3& b,
                                         const Vec3& c, SegmentTriangleHit* hit) {
  const int s0 = perturbed_orient_mesh_triangle_blade_point(a, b, c, x0);
  const int s1 = perturbed_orient_mesh_triangle_blade_point(a, b, c, x1);
  if (s0 == 0 || s1 == 0 || s0 == s1) return false;
  // orient3d(x0, x1, u, v) == orient3d(u, v, x0, x1) (an even permutation).
  const int e0 = perturbed_orient_mesh_edge_blade_edge(b, c, x0, x1);  // weight of a
  if (e0 == 0) return false;
  if (perturbed_orient_mesh_edge_blade_edge(c, a, x0, x1) != e0) return false;  // weight of b
  if (perturbed_orient_mesh_edge_blade_edge(a, b, x0, x1) != e0) return false;  // weight of c
  if (hit != nullptr) {
    const Vec3 n = (b - a).cross(c - a);
    hit->segment_param = crossing_param(n.dot(x0 - a), n.dot(x1 - a));
    hit->triangle_bary = normalised_weights(orient_value(x0, x1, b, c), orient_value(x0, x1, c, a),
                                            orient_value(x0, x1, a, b));
    hit->side0 = s0;
  }
  return true;
}

// ---- BladeSweep ----------------------------------------------------------------------------------

BladeSweep::BladeSweep(const TetMesh& mesh, Options options) : mesh_(mesh), options_(options) {
  rebuild();
}

Aabb BladeSweep::tight_box(std::uint32_t tet) const {
  const auto& v = mesh_.tet_vertex_indices(tet);
  const auto& x = mesh_.positions();
  Aabb b;
  for (std::uint32_t n : v) b.extend(x[n]);
  return b;
}

Aabb BladeSweep::fat_box(std::uint32_t tet) const {
  Aabb b = tight_box(tet);
  const double margin = options_.fat_fraction * (b.hi - b.lo).maxCoeff();
  b.lo.array() -= margin;
  b.hi.array() += margin;
  return b;
}

void BladeSweep::rebuild() {
  std::vector<AabbTree::LeafInput> leaves;
  leaves.reserve(mesh_.tet_count());
  for (std::uint32_t t = 0; t < mesh_.tet_capacity(); ++t) {
    if (mesh_.tet_slot_alive(t)) leaves.push_back({fat_box(t), t});
  }
  std::vector<std::int32_t> ids;
  tree_.build(leaves, ids);
  leaf_of_tet_.assign(mesh_.tet_capacity(), AabbTree::kNullNode);
  for (std::size_t i = 0; i < leaves.size(); ++i) leaf_of_tet_[leaves[i].payload] = ids[i];
}

void BladeSweep::on_tet_added(std::uint32_t tet) {
  if (tet >= leaf_of_tet_.size()) {
    if (leaf_of_tet_.capacity() <= tet)
      leaf_of_tet_.reserve(std::max<std::size_t>(tet + 1, mesh_.tet_capacity()) * 9 / 8);
    leaf_of_tet_.resize(std::max<std::size_t>(tet + 1, mesh_.tet_capacity()), AabbTree::kNullNode);
  }
  if (leaf_of_tet_[tet] != AabbTree::kNullNode) tree_.remove(leaf_of_tet_[tet]);
  leaf_of_tet_[tet] = tree_.insert(fat_box(tet), tet);
}

void BladeSweep::on_tet_removed(std::uint32_t tet) {
  if (tet >= leaf_of_tet_.size() || leaf_of_tet_[tet] == AabbTree::kNullNode) return;
  tree_.remove(leaf_of_tet_[tet]);
  leaf_of_tet_[tet] = AabbTree::kNullNode;
}

std::size_t BladeSweep::refit() {
  // Few escaped leaves: walk up from each (O(depth) per leaf, stops early). Many: one bottom-up
  // pass over the whole tree, O(n).
  const std::size_t walk_limit = tree_.leaf_count() / 16;
  std::size_t moved = 0;
  stack_.clear();
  for (std::uint32_t t = 0; t < leaf_of_tet_.size(); ++t) {
    const std::int32_t leaf = leaf_of_tet_[t];
    if (leaf == AabbTree::kNullNode || !mesh_.tet_slot_alive(t)) continue;
    if (tree_.node(leaf).box.contains(tight_box(t))) continue;
    tree_.set_leaf_box_only(leaf, fat_box(t));
    if (++moved <= walk_limit) stack_.push_back(leaf);
  }
  if (moved > walk_limit) {
    tree_.refit_internal(stack_);
  } else {
    for (const std::int32_t leaf : stack_) tree_.set_leaf_box(leaf, tree_.node(leaf).box);
  }
  return moved;
}

void BladeSweep::gather_candidates(const std::array<Vec3, 4>& quad) {
  candidates_.clear();
  if (!options_.use_tree) {
    for (std::uint32_t t = 0; t < mesh_.tet_capacity(); ++t) {
      if (mesh_.tet_slot_alive(t)) candidates_.push_back(t);
    }
    return;
  }
  if (tree_.root() == AabbTree::kNullNode) return;
  Aabb qbox;
  for (const Vec3& x : quad) qbox.extend(x);
  const Aabb& root = tree_.node(tree_.root()).box;
  const double scale = std::max({root.lo.cwiseAbs().maxCoeff(), root.hi.cwiseAbs().maxCoeff(),
                                 qbox.lo.cwiseAbs().maxCoeff(), qbox.hi.cwiseAbs().maxCoeff()});
  // Boxes are enlarged far beyond the rounding of the separating-axis arithmetic, so a culled box
  // never touches the swept triangles exactly.
  const double tol = 1e-9 * scale + 1e-300;
  qbox.lo.array() -= tol;
  qbox.hi.array() += tol;
  tree_.query(
      [&](const Aabb& box) {
        if (!box.overlaps(qbox)) return false;
        const Vec3 c = 0.5 * (box.lo + box.hi);
        const Vec3 h = (0.5 * (box.hi - box.lo)).array() + tol;
        return box_touches_triangle(c, h, quad[0], quad[1], quad[2]) ||
               box_touches_triangle(c, h, quad[0], quad[2], quad[3]);
      },
      [&](std::uint32_t tet) {
        if (mesh_.tet_slot_alive(tet)) candidates_.push_back(tet);
      },
      stack_);
}

void BladeSweep::sweep(const BladePose& prev, const BladePose& curr, SweepResult& out) {
  out.clear();
  touched_.clear();
  // Quad corners in the order (P_k, T_k, T_k+1, P_k+1): tri 0 = (0,1,2), tri 1 = (0,2,3).
  const std::array<Vec3, 4> quad = {prev.back, prev.tip, curr.tip, curr.back};
  gather_candidates(quad);
  cut_edges(prev, curr, quad, out);
  cross_faces(prev, curr, out);
  hold_blade_ends(curr);

  std::sort(touched_.begin(), touched_.end());
  touched_.erase(std::unique(touched_.begin(), touched_.end()), touched_.end());
  out.tets.assign(touched_.begin(), touched_.end());

  std::sort(out.edges.begin(), out.edges.end(), [](const EdgeCut& l, const EdgeCut& r) {
    return std::tie(l.u, l.a, l.b) < std::tie(r.u, r.a, r.b);
  });
  auto by_u = [](const FacePierce& l, const FacePierce& r) {
    return std::tie(l.u, l.tet, l.local_face) < std::tie(r.u, r.tet, r.local_face);
  };
  std::sort(out.pierces.begin(), out.pierces.end(), by_u);
  std::sort(out.back_pierces.begin(), out.back_pierces.end(), by_u);
  std::sort(out.crossings.begin(), out.crossings.end(), [](const FaceCrossing& l, const FaceCrossing& r) {
    return std::tie(l.s, l.tet, l.local_face) < std::tie(r.s, r.tet, r.local_face);
  });
}

// Edge cuts: each edge once, however many candidate tetrahedra share it.
void BladeSweep::cut_edges(const BladePose& prev, const BladePose& curr, const std::array<Vec3, 4>& quad,
                           SweepResult& out) {
  const Vec3& p0 = prev.back;
  const Vec3& t0 = prev.tip;
  const Vec3& t1 = curr.tip;
  const Vec3& p1 = curr.back;
  const bool tri_ok[2] = {triangle_has_area(p0, t0, t1), triangle_has_area(p0, t1, p1)};
  const auto& x = mesh_.positions();
  edge_entries_.clear();
  for (std::uint32_t tet : candidates_) {
    const auto& v = mesh_.tet_vertex_indices(tet);
    for (const auto& e : kEdgeVertices) {
      const std::uint32_t a = v[static_cast<std::size_t>(e[0])], b = v[static_cast<std::size_t>(e[1])];
      edge_entries_.push_back({std::min(a, b), std::max(a, b), tet});
    }
  }
  std::sort(edge_entries_.begin(), edge_entries_.end(), [](const EdgeEntry& l, const EdgeEntry& r) {
    return std::tie(l.a, l.b, l.tet) < std::tie(r.a, r.b, r.tet);
  });
  const bool use_direction = prev.cutting_direction != Vec3::Zero() || curr.cutting_direction != Vec3::Zero();
  for (std::size_t i = 0; i < edge_entries_.size();) {
    std::size_t j = i + 1;
    while (j < edge_entries_.size() && edge_entries_[j].a == edge_entries_[i].a &&
           edge_entries_[j].b == edge_entries_[i].b)
      ++j;
    const std::uint32_t a = edge_entries_[i].a, b = edge_entries_[i].b;
    bool cut = false;
    for (int k = 0; k < 2; ++k) {
      if (!tri_ok[k]) continue;
      const Vec3& q1 = quad[k == 0 ? 1u : 2u];
      const Vec3& q2 = quad[k == 0 ? 2u : 3u];
      SegmentTriangleHit hit;
      if (!mesh_segment_crosses_blade_triangle(x[a], x[b], p0, q1, q2, &hit)) continue;
      EdgeCut c;
      c.a = a;
      c.b = b;
      c.t = hit.segment_param;
      c.point = x[a] + c.t * (x[b] - x[a]);
      // Linear map of each triangle to the parameter square (header).
      const Vec3& w = hit.triangle_bary;
      if (k == 0) {
        c.s = w[1] + w[2];
        c.u = w[2];
      } else {
        c.s = w[1];
        c.u = w[1] + w[2];
      }
      // Eq. 1 (section 5): direction of the blade's motion at the crossing.
      const Vec3 v_tool = use_direction
                              ? Vec3((1 - c.u) * prev.cutting_direction + c.u * curr.cutting_direction)
                              : Vec3((1 - c.s) * (p1 - p0) + c.s * (t1 - t0));
      const Vec3 p_prev = project_on_line(p0, t0, c.point);
      const Vec3 p_curr = project_on_line(p1, t1, c.point);
      c.forward = (p_curr - p_prev).dot(v_tool) > 0;
      out.edges.push_back(c);
      cut = true;
    }
    if (cut) {
      for (std::size_t k = i; k < j; ++k) touched_.push_back(edge_entries_[k].tet);
    }
    i = j;
  }
}

// Faces: pierces of the tip and back paths, crossings of both blade positions.
void BladeSweep::cross_faces(const BladePose& prev, const BladePose& curr, SweepResult& out) {
  const Vec3& p0 = prev.back;
  const Vec3& t0 = prev.tip;
  const Vec3& t1 = curr.tip;
  const Vec3& p1 = curr.back;
  const auto& x = mesh_.positions();
  face_entries_.clear();
  for (std::uint32_t tet : candidates_) {
    for (int f = 0; f < 4; ++f) {
      const auto outward = face_vertex_indices(mesh_, tet, f);
      std::array<std::uint32_t, 3> s = outward;
      std::sort(s.begin(), s.end());
      // The ascending order is a rotation of the outward one iff it is an even permutation.
      const bool even = (outward[0] == s[0] && outward[1] == s[1]) ||
                        (outward[1] == s[0] && outward[2] == s[1]) ||
                        (outward[2] == s[0] && outward[0] == s[1]);
      face_entries_.push_back({s, tet, f, even});
    }
  }
  std::sort(face_entries_.begin(), face_entries_.end(), [](const FaceEntry& l, const FaceEntry& r) {
    return std::tie(l.nodes, l.tet, l.local_face) < std::tie(r.nodes, r.tet, r.local_face);
  });
  for (std::size_t i = 0; i < face_entries_.size();) {
    std::size_t j = i + 1;
    while (j < face_entries_.size() && face_entries_[j].nodes == face_entries_[i].nodes) ++j;
    const auto& n = face_entries_[i].nodes;
    const Vec3 &xa = x[n[0]], &xb = x[n[1]], &xc = x[n[2]];
    bool hit_any = false;
    auto record = [&](const Vec3& s0, const Vec3& s1, std::vector<FacePierce>& list) {
      SegmentTriangleHit hit;
      if (!blade_segment_crosses_mesh_triangle(s0, s1, xa, xb, xc, &hit)) return;
      hit_any = true;
      const Vec3 point = hit.triangle_bary[0] * xa + hit.triangle_bary[1] * xb + hit.triangle_bary[2] * xc;
      for (std::size_t k = i; k < j; ++k) {
        const FaceEntry& fe = face_entries_[k];
        // side0 > 0: the path starts on the side the ascending normal points to.
        const int outside = fe.same_orientation ? hit.side0 : -hit.side0;
        list.push_back({fe.tet, fe.local_face, n, point, hit.triangle_bary, hit.segment_param, outside > 0});
      }
    };
    record(t0, t1, out.pierces);
    record(p0, p1, out.back_pierces);
    {
      SegmentTriangleHit hit;
      if (blade_segment_crosses_mesh_triangle(p1, t1, xa, xb, xc, &hit)) {
        hit_any = true;
        const Vec3 point = hit.triangle_bary[0] * xa + hit.triangle_bary[1] * xb + hit.triangle_bary[2] * xc;
        for (std::size_t k = i; k < j; ++k) {
          out.crossings.push_back({face_entries_[k].tet, face_entries_[k].local_face, n, point,
                                   hit.triangle_bary, hit.segment_param});
        }
      }
    }
    if (!hit_any) hit_any = blade_segment_crosses_mesh_triangle(p0, t0, xa, xb, xc);
    if (hit_any) {
      for (std::size_t k = i; k < j; ++k) touched_.push_back(face_entries_[k].tet);
    }
    i = j;
  }
}

// Tetrahedra holding the current blade's end points.
void BladeSweep::hold_blade_ends(const BladePose& curr) {
  const Vec3& t1 = curr.tip;
  const Vec3& p1 = curr.back;
  const auto& x = mesh_.positions();
  for (std::uint32_t tet : candidates_) {
    auto inside = [&](const Vec3& point) {
      for (int f = 0; f < 4; ++f) {
        const auto fv = face_vertex_indices(mesh_, tet, f);
        if (perturbed_orient_mesh_triangle_blade_point(x[fv[0]], x[fv[1]], x[fv[2]], point) >= 0)
          return false;
      }
      return true;
    };
    if (inside(t1) || inside(p1)) touched_.push_back(tet);
  }
}

}  // namespace scalpel
