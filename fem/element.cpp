#include "fem/element.hpp"

#include "fem/corotational_lanes.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>

namespace scalpel {

TetRest make_tet_rest(const std::array<Vec3, 4>& x, const Material& m, double sliver_quality) {
  TetRest r;
  Mat3 dm;
  dm << x[1] - x[0], x[2] - x[0], x[3] - x[0];
  const double vol = dm.determinant() / 6.0;
  double sum_sq = 0;
  std::array<double, 6> len{};
  for (size_t e = 0; e < 6; ++e) {
    len[e] =
        (x[static_cast<size_t>(kEdgeVertices[e][1])] - x[static_cast<size_t>(kEdgeVertices[e][0])]).norm();
    sum_sq += len[e] * len[e];
  }
  r.mass_volume = std::max(vol, 0.0);
  if (!(vol > 0) || !std::isfinite(vol) || !(sum_sq > 0)) return r;  // degenerate: inert, massless
  const double l_rms = std::sqrt(sum_sq / 6.0);
  r.quality = 6.0 * std::sqrt(2.0) * vol / (l_rms * l_rms * l_rms);
  r.stiffness_scale = sliver_quality > 0 ? std::min(1.0, r.quality / sliver_quality) : 1.0;
  // Below kInertQuality the rest gradients (~1/height) amplify the rounding noise of the positions
  // into O(1) strains: such an element carries mass only.
  if (r.quality < kInertQuality) {
    r.stiffness_scale = 0;
    return r;
  }

  // Prestress: rest shape scaled by 1/lambda0 (docs/tissue.md).
  const double l0 = m.prestress;
  const Mat3 inv = dm.inverse() * l0;  // rows are b_1..b_3 of the prestressed rest shape
  for (int a = 1; a < 4; ++a) r.grad.col(a) = inv.row(a - 1).transpose();
  r.grad.col(0) = -(r.grad.col(1) + r.grad.col(2) + r.grad.col(3));
  r.volume = vol / (l0 * l0 * l0);

  const Lame lame = lame_parameters(m);
  r.mu = lame.mu * r.stiffness_scale;
  r.lambda = lame.lambda * r.stiffness_scale;
  // Calibrated to Young's modulus and Poisson's ratio on the generated mesh (element.hpp).
  const MassSpringModuli ms = mass_spring_moduli(m);
  for (size_t e = 0; e < 6; ++e) {
    r.rest_length[e] = len[e] / l0;
    r.spring_k[e] =
        r.stiffness_scale * ms.spring * m.young * r.volume / (r.rest_length[e] * r.rest_length[e]);
  }
  r.volume_k = r.stiffness_scale * ms.volume / r.volume;
  return r;
}

// Müller, Bender, Chentanez, Macklin 2016, Algorithm 1, with a Newton step where it is safe (see
// element.hpp): in the frame of R, with G = R^T F = S + W (symmetric + skew) and a the axial vector
// of W, the correction phi making exp(-[phi]) G symmetric solves, to first order,
//   (tr(S) I - S) phi = 2 a.
// Algorithm 1 replaces tr(S) I - S by |tr(G)| I (a damped step: linear convergence, rate 1/3 even
// for an isotropic stretch); the full solve converges quadratically. It is used when tr(S) I - S is
// positive definite (any two principal stretches sum to more than zero: no inversion), else the
// damped step keeps the iteration safe. A Newton step of w rad leaves about w^3 / 3 (measured for
// strains up to 0.9): one below 1 mrad ends the iteration 5e-10 rad from R. Warm-started from the
// last step, where a moving tissue's elements turn by up to a few mrad, that is one step for most.
void extract_rotation(const Mat3& f, Eigen::Quaterniond& q, int max_iterations) {
  lanes::M3<double> m;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) m.a[i][j] = f(i, j);
  double wxyz[4] = {q.w(), q.x(), q.y(), q.z()};
  lanes::scalar::extract_rotation(m, wxyz, max_iterations);
  q = Eigen::Quaterniond(wxyz[0], wxyz[1], wxyz[2], wxyz[3]);
}

namespace {

Mat3 to_mat3(const lanes::M3<double>& m) {
  Mat3 out;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) out(i, j) = m.a[i][j];
  return out;
}

// The element's state from an evaluation; where something is clamped, from the general case.
void finish(const TetRest& rest, const lanes::Evaluation<double>& ev, bool unclamped,
            CorotationalState& out) {
  for (int i = 0; i < 3; ++i)
    for (int a = 0; a < 4; ++a) out.c(i, a) = ev.c[i][a];
  out.lambda_volume = rest.volume * rest.lambda;
  out.mu_volume = rest.volume * rest.mu;
  if (!unclamped) {
    corotational_stress_from_principal_axes(rest, to_mat3(ev.r), to_mat3(ev.eps), out);
    return;
  }
  out.held = false;
  for (int i = 0; i < 3; ++i)
    for (int a = 0; a < 4; ++a) out.force(i, a) = ev.force[i][a];
  out.energy = ev.energy;
  out.twist = to_mat3(ev.twist);
}

}  // namespace

// Where no principal strain and not the volumetric strain reach the strain limit, every pair of
// principal stresses sums to more than zero and every pair of principal stretches to more than
// kTwistStretchFloor, nothing is clamped, and the twist matrix R (V/2) T U^-1 R^T, with
// T = tr(sigma) I - sigma and U = tr(S) I - S, has the eigenvalues and eigenvectors the general case
// gives it (sigma and S = I + eps share their eigenvectors; T's eigenvalues are sigma_i + sigma_j,
// U's s_i + s_j), with no eigen-decomposition (lanes::evaluate, fem/corotational_lanes.hpp).
void evaluate_corotational(const TetRest& rest, const std::array<Vec3, 4>& x, Eigen::Quaterniond& q,
                           CorotationalState& out) {
  lanes::Element<double> e;
  for (int i = 0; i < 3; ++i)
    for (int a = 0; a < 4; ++a) e.grad[i][a] = rest.grad(i, a);
  e.volume = rest.volume;
  e.mu = rest.mu;
  e.lambda = rest.lambda;
  for (std::size_t a = 0; a < 4; ++a)
    for (int i = 0; i < 3; ++i) e.x[a][i] = x[a][i];
  e.q[0] = q.w();
  e.q[1] = q.x();
  e.q[2] = q.y();
  e.q[3] = q.z();
  lanes::Evaluation<double> ev;
  const bool unclamped = lanes::scalar::evaluate(e, ev);
  q = Eigen::Quaterniond(e.q[0], e.q[1], e.q[2], e.q[3]);
  finish(rest, ev, unclamped, out);
}

#ifdef SCALPEL_LANES_HAVE_AVX2
namespace {

[[gnu::target("avx2")]] void evaluate_corotational4_avx2(const std::array<const TetRest*, 4>& rest,
                                                         const std::array<const std::array<Vec3, 4>*, 4>& x,
                                                         const std::array<Eigen::Quaterniond*, 4>& q,
                                                         const std::array<CorotationalState*, 4>& out) {
  lanes::Element<lanes::Lanes> e;
  for (int l = 0; l < 4; ++l) {
    const TetRest& r = *rest[static_cast<std::size_t>(l)];
    for (int i = 0; i < 3; ++i)
      for (int a = 0; a < 4; ++a) e.grad[i][a][l] = r.grad(i, a);
    e.volume[l] = r.volume;
    e.mu[l] = r.mu;
    e.lambda[l] = r.lambda;
    const std::array<Vec3, 4>& xl = *x[static_cast<std::size_t>(l)];
    for (std::size_t a = 0; a < 4; ++a)
      for (int i = 0; i < 3; ++i) e.x[a][i][l] = xl[a][i];
    const Eigen::Quaterniond& ql = *q[static_cast<std::size_t>(l)];
    e.q[0][l] = ql.w();
    e.q[1][l] = ql.x();
    e.q[2][l] = ql.y();
    e.q[3][l] = ql.z();
  }
  lanes::Evaluation<lanes::Lanes> ev;
  const lanes::Mask unclamped = lanes::avx2::evaluate(e, ev);
  for (int l = 0; l < 4; ++l) {
    lanes::Evaluation<double> one;
    for (int i = 0; i < 3; ++i)
      for (int a = 0; a < 4; ++a) {
        one.c[i][a] = ev.c[i][a][l];
        one.force[i][a] = ev.force[i][a][l];
      }
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        one.twist.a[i][j] = ev.twist.a[i][j][l];
        one.r.a[i][j] = ev.r.a[i][j][l];
        one.eps.a[i][j] = ev.eps.a[i][j][l];
      }
    one.energy = ev.energy[l];
    *q[static_cast<std::size_t>(l)] = Eigen::Quaterniond(e.q[0][l], e.q[1][l], e.q[2][l], e.q[3][l]);
    finish(*rest[static_cast<std::size_t>(l)], one, unclamped[l] != 0, *out[static_cast<std::size_t>(l)]);
  }
}

}  // namespace
#endif

bool evaluate_corotational4_vectorised() {
#ifdef SCALPEL_LANES_HAVE_AVX2
  static const bool avx2 = __builtin_cpu_supports("avx2");
  return avx2;
#else
  return false;
#endif
}

void evaluate_corotational4(const std::array<const TetRest*, 4>& rest,
                            const std::array<const std::array<Vec3, 4>*, 4>& x,
                            const std::array<Eigen::Quaterniond*, 4>& q,
                            const std::array<CorotationalState*, 4>& out, bool vectorised) {
#ifdef SCALPEL_LANES_HAVE_AVX2
  if (vectorised && evaluate_corotational4_vectorised()) {
    evaluate_corotational4_avx2(rest, x, q, out);
    return;
  }
#endif
  for (std::size_t l = 0; l < 4; ++l) evaluate_corotational(*rest[l], *x[l], *q[l], *out[l]);
}

void corotational_stress_from_principal_axes(const TetRest& rest, const Mat3& r, const Mat3& eps,
                                             CorotationalState& out) {
  // Strain limit (element.hpp): principal strains and the volumetric strain beyond kStrainLimit
  // keep the stress they have at the limit; the energy grows linearly there.
  Eigen::SelfAdjointEigenSolver<Mat3> es;
  es.computeDirect(eps);
  const Vec3& strain = es.eigenvalues();
  const Vec3 held = strain.cwiseMax(-kStrainLimit).cwiseMin(kStrainLimit);
  const double tr = eps.trace();
  const double tr_held = std::clamp(tr, -kStrainLimit, kStrainLimit);
  out.held = tr_held != tr || held != strain;
  Mat3 e = eps;
  if (held != strain) e.noalias() = es.eigenvectors() * held.asDiagonal() * es.eigenvectors().transpose();
  Mat3 sigma = 2.0 * rest.mu * e;
  sigma.diagonal().array() += rest.lambda * tr_held;
  out.force.noalias() = -rest.volume * (r * sigma) * rest.grad;
  out.energy = rest.volume * (rest.mu * (2.0 * e.cwiseProduct(eps).sum() - e.squaredNorm()) +
                              0.5 * rest.lambda * tr_held * (2.0 * tr - tr_held));
  // Twist modes (element.hpp): rho_k = (sigma_i + sigma_j) / (s_i + s_j) for the pair (i, j) other
  // than k, clamped at 0. Two principal stretches summing to less than kTwistStretchFloor belong to
  // a nearly collapsed element, whose tension would make rho arbitrarily large: the floor bounds it.
  const Vec3 principal = (2.0 * rest.mu) * held + Vec3::Constant(rest.lambda * tr_held);
  Vec3 alpha;
  for (int k = 0; k < 3; ++k) {
    const int i = (k + 1) % 3, j = (k + 2) % 3;
    const double stretch = std::max(2.0 + strain[i] + strain[j], kTwistStretchFloor);
    alpha[k] = 0.5 * rest.volume * std::max(0.0, (principal[i] + principal[j]) / stretch);
  }
  const Mat3 axes = r * es.eigenvectors();
  out.twist.noalias() = axes * alpha.asDiagonal() * axes.transpose();
}

void evaluate_mass_spring(const TetRest& rest, const std::array<Vec3, 4>& x, MassSpringState& out) {
  out.force.setZero();
  out.held = false;
  double energy = 0;
  for (size_t e = 0; e < 6; ++e) {
    const int i = kEdgeVertices[e][0], j = kEdgeVertices[e][1];
    const Vec3 d = x[static_cast<size_t>(j)] - x[static_cast<size_t>(i)];
    const double l = d.norm();
    const double stretch = l - rest.rest_length[e];
    // The strain limit of the co-rotational element, on the spring's strain.
    const double limit = kStrainLimit * rest.rest_length[e];
    const double held = std::clamp(stretch, -limit, limit);
    out.held = out.held || held != stretch;
    const Vec3 n = l > 0 ? Vec3(d / l) : Vec3::UnitX();
    const double t = l > 0 ? std::max(0.0, 1.0 - rest.rest_length[e] / l) : 0.0;
    const double w = held == stretch ? 1.0 : held / stretch;  // secant weight (element.hpp)
    out.axial[e] = std::sqrt(w * rest.spring_k[e] * (1.0 - t)) * n;
    out.transverse[e] = w * rest.spring_k[e] * t;
    const Vec3 fs = rest.spring_k[e] * held * n;
    out.force.col(i) += fs;
    out.force.col(j) -= fs;
    energy += rest.spring_k[e] * held * (stretch - 0.5 * held);
  }
  const Vec3 e1 = x[1] - x[0], e2 = x[2] - x[0], e3 = x[3] - x[0];
  out.volume_grad.col(1) = e2.cross(e3) / 6.0;
  out.volume_grad.col(2) = e3.cross(e1) / 6.0;
  out.volume_grad.col(3) = e1.cross(e2) / 6.0;
  out.volume_grad.col(0) = -(out.volume_grad.col(1) + out.volume_grad.col(2) + out.volume_grad.col(3));
  const double dv = e1.dot(e2.cross(e3)) / 6.0 - rest.volume;
  const double held = std::clamp(dv, -kStrainLimit * rest.volume, kStrainLimit * rest.volume);
  out.held = out.held || held != dv;
  out.volume_stiffness = rest.volume_k * (held == dv ? 1.0 : held / dv);
  out.force -= rest.volume_k * held * out.volume_grad;
  out.energy = energy + rest.volume_k * held * (dv - 0.5 * held);
}

namespace {

template <class Block>
Mat12 full_matrix(Block block) {
  Mat12 k;
  for (int a = 0; a < 4; ++a)
    for (int b = 0; b < 4; ++b) k.block<3, 3>(3 * a, 3 * b) = block(a, b);
  return k;
}

}  // namespace

Mat12 corotational_stiffness(const CorotationalState& s) {
  return full_matrix([&](int a, int b) { return corotational_block(s, a, b); });
}

Mat12 mass_spring_stiffness(const MassSpringState& s) {
  std::array<Mat3, 4> row;
  Mat12 k;
  for (int a = 0; a < 4; ++a) {
    for (Mat3& b : row) b.setZero();
    add_mass_spring_row(s, a, 1.0, {&row[0], &row[1], &row[2], &row[3]});
    for (int b = 0; b < 4; ++b) k.block<3, 3>(3 * a, 3 * b) = row[static_cast<size_t>(b)];
  }
  return k;
}

}  // namespace scalpel
