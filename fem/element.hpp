// Element kernels of the tissue models (docs/tissue.md).
//
// Co-rotational linear FEM on a linear tetrahedron: Müller & Gross, "Interactive Virtual
// Materials", GI 2004, section 4. With F = sum_a x_a b_a^T the deformation gradient (b_a the
// gradients of the barycentric coordinates over the rest shape [1/m]) and F = R S its polar
// decomposition, the element is linear elastic in the rotated frame:
//   eps = sym(R^T F) - I,  sigma = 2 mu eps + lambda tr(eps) I  [Pa],
//   energy W = V (mu eps:eps + lambda/2 tr(eps)^2)  [J],
//   force f_a = -V R sigma b_a  [N]  (= -dW/dx_a exactly, since R^T F is symmetric),
//   stiffness K_ab = R K0_ab R^T + [c_a] M [c_b]^T,
//   R K0_ab R^T = V (lambda c_a c_b^T + mu c_b c_a^T + mu (c_a . c_b) I),
// with c_a = R b_a and [c] the cross-product matrix. R K0 R^T alone is the stiffness with R held
// fixed over the step; it misses the derivative of R, which is as large as the stress. Under
// prestress that part is the tension's stiffness against rotation (a string's, a drum's), and an
// implicit step without it alternates between two mirrored shapes instead of settling.
// The consistent tangent (Teran, Sifakis, Irving, Fedkiw, "Robust quasistatic finite elements and
// flesh simulation", SCA 2005, section 5; eigen-form as in Smith, De Goes, Kim, "Analytic
// eigensystems for isotropic distortion energies", TOG 38(1), 2019): the energy depends on the
// principal stretches s_i of S = R^T F only, so its Hessian in F splits into the stretch block and,
// per pair (i, j) of principal axes, a flip mode and a twist mode. R K0 R^T is exact on the
// stretch block and the flip modes (2 mu) below the strain limit. The twist mode about axis k, the
// unit matrix T_k = R [v_k] / sqrt(2) with v_k the third principal axis, has the eigenvalue
//   rho_k = (sigma_i + sigma_j) / (s_i + s_j)   (sigma the principal stresses),
// zero in R K0 R^T. Its part of the Hessian is V sum_k rho_k (T_k : dF)^2, and T_k : dF =
// sum_a dx_a . (n_k x c_a) / sqrt(2) with n_k = R v_k, so
//   M = V/2 sum_k max(rho_k, 0) n_k n_k^T.
// rho_k < 0 (compression across the pair) would make K indefinite; it is clamped to 0 (the
// projection of Teran et al.), which over-estimates the stiffness there: that only damps, and CG
// keeps a positive definite matrix. Elements beyond the strain limit keep R K0 R^T on the stretch
// block and flip modes (an over-estimate) and take the twist of their held stress.
// R is found by the iterative rotation extraction of Müller, Bender, Chentanez, Macklin, "A Robust
// Method to Extract the Rotational Part of Deformations", MIG 2016, warm-started from the last R,
// with the full Newton step where it is safe (element.cpp): quadratic instead of linear convergence.
// The evaluation is written once for one element and for four in SIMD lanes, with the same bits
// (fem/corotational_lanes.hpp).
//
// Mass-spring variant: a spring on each of the six edges of every tetrahedron (an edge shared by n
// tetrahedra carries n springs, so the stiffness follows the volume around it) plus a volume term:
//   W = sum_e k_e/2 (l_e - L_e)^2 + kappa'/(2 V) (vol(x) - V)^2,
//   k_e = s E V / L_e^2 [N/m], with s and kappa' [Pa] calibrated below (mass_spring_moduli).
// What it is for: speed (no rotation to extract) and robustness where the cutter leaves extreme
// elements and strains (every spring and the volume term are defined for any shape, inverted ones
// included). It is not for quantitative stress: it is anisotropic on any mesh, and on the generated
// one its shear modulus along the axes is about a third of the material's (table below).
// Calibration. Under a homogeneous small strain eps a spring stores k_e/2 (L_e n.eps.n)^2 =
// s E V/2 (n.eps.n)^2 (n its direction): its share depends on its direction only, and the volume
// term stores kappa' V/2 tr(eps)^2. Springs are central forces, so their elasticity tensor obeys
// the Cauchy relations; spread evenly over all directions they would give Young's modulus s E and
// Poisson's ratio 1/4. The generated meshes (mesh/generators.cpp, 6 tetrahedra per cell) are
// not: the Kuhn split of a cube has, per unit volume, the weights 1/2 on each axis, 1/3 on each of
// the face diagonals (1,1,0), (0,1,1), (1,0,1) and 1/2 on the body diagonal (1,1,1), i.e. the energy
// density s E [1/2 sum_i eps_ii^2 + 1/3 sum_f (n_f.eps.n_f)^2 + 1/2 (n_b.eps.n_b)^2]. Inverting
// that tensor: under uniaxial stress along a cube axis the springs alone have Young's modulus
// 30/29 s E and Poisson's ratio 1/29 (and shear with it: the lattice is trigonal about (1,1,1)).
// The volume term adds kappa' to every normal-normal entry; with k = kappa' / (s E), by
// Sherman-Morrison,
//   E_axis = s E (30 + 81 k) / (29 + 54 k),  nu_axis = (1 + 27 k) / (29 + 54 k),
// and E_axis = E, nu_axis = nu solve to
//   s = 1 / (1 + nu),  kappa' = E (29 nu - 1) / (27 (1 + nu) (1 - 2 nu)),
// which also makes the lattice's bulk modulus E / (3 (1 - 2 nu)) exactly. For nu < 1/29 kappa'
// would be negative (a term that favours a change of volume, making the element indefinite): it is
// clamped to 0 with s = 29/30 (continuous at 1/29), so the axes keep Young's modulus E and Poisson's
// ratio is 1/29 whatever the material asks. volume_springs = false (TissueSettings) drops the volume
// term and keeps s: E_axis = 30 E / (29 (1 + nu)), nu_axis = 1/29.
// Departure from elasticity, homogenised on cubic cells (exact for the infinite lattice; the patch
// test in tests/fem/test_tissue.cpp measures the same within 1 %): E_x, nu_x under uniaxial stress
// along an axis, G_xy under shear stress sigma_xy, E_d under uniaxial stress along d; over E or G
// of the material. Before: k_e = E V / L_e^2 and kappa' = E / (3 (1 - 2 nu)).
//   nu    | before: E_x   nu_x   G_xy  E_111 E_1-10 | after: E_x   nu_x   G_xy  E_111 E_1-10
//   0.30  |         1.32  0.318  0.47  1.48  0.48   |        1.00  0.300  0.36  1.13  0.36
//   0.40  |         1.39  0.387  0.52  1.49  0.50   |        1.00  0.400  0.37  1.06  0.36
//   0.45  |         1.44  0.435  0.54  1.49  0.52   |        1.00  0.450  0.37  1.03  0.36
// So the axes are right, the body diagonal about right, and the shear along the axes and the
// stretch across the missing face diagonals (1,-1,0) three times too compliant; no choice of s and
// kappa' fixes that (both scale the shear alike), it would take per-edge constants. On the skin
// scenarios' flat cells (2.7 x 2.7 x 1 mm) E_x, E_z stay within 3 % and nu within 0.03 of the
// material's, but G_xz falls to 0.13 G. The cutter's sub-tetrahedra have other directions again.
// The solver's stiffness clamps the transverse spring term to tension (compressed springs would
// make it indefinite) and keeps only the Gauss-Newton part of the volume term. That part,
// kappa'/V g g^T with g = d vol / d x the current face areas, grows with the fourth power of an
// in-plane stretch: an element the cutter made tens of micrometres across at the crack tip,
// stretched twenty-fold and flattened as the wound opens, makes its nodes a thousand times
// stiffer than their neighbours, which slows the solve (README, "Not yet": the step right after a
// cut).
//
// Prestress (docs/tissue.md): the rest shape is scaled by 1/lambda0, i.e. b_a -> lambda0 b_a,
// V -> V / lambda0^3, L_e -> L_e / lambda0; the mesh's rest positions are left alone.
//
// Slivers: an element whose rest quality q = 6 sqrt(2) V / l_rms^3 (1 for the regular
// tetrahedron, -> 0 for slivers) is below q_min has its moduli scaled by q / q_min. A sliver's
// stiffness grows like 1/q; the scaling bounds it by that of a q_min element of the same size, so
// a cut cannot make the system arbitrarily ill-conditioned. Mass stays exact. Below kInertQuality
// an element carries mass only: its gradients would turn position round-off into strain.
//
// Strain limit: linear elasticity means nothing far beyond 100 % strain. In a cutting simulation the
// elements there are mostly ones the cutter made in deformed tissue (a sub-tetrahedron whose rest
// shape is a sliver but whose nodes have moved apart, or one born inverted; about 1 % of the
// elements after the default scenario's incision), where the stress is large and the linearisation of
// one step is far from the element's response over it. So the energy is continued linearly (Huber) past
// |strain| = kStrainLimit: each principal strain of the co-rotational element, its volumetric strain, each
// spring's strain and the mass-spring volume term keep the force they have at the limit. Energy and force
// stay exact derivatives. The co-rotational solver keeps the full stretch and flip stiffness there (an
// over-estimate, which only damps) and the twist stiffness of the held stress. The mass-spring Gauss-Newton
// stiffness grows with the stretch (the volume term's as its fourth power), so a held spring or volume term
// is weighted by held / strain: the secant stiffness, the weight of iteratively reweighted least squares for
// Huber's loss (Holland & Welsch, "Robust regression using iteratively reweighted least-squares", Commun.
// Statist. A6, 1977), in proportion to the held force. Unweighted, 28 steps of a 3 mm deep incision into 20
// thousand tetrahedra hit the iteration cap (tests/sim/test_simulation.cpp); weighted, none.
#pragma once

#include <algorithm>
#include <array>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "fem/material.hpp"
#include "mesh/mesh.hpp"

namespace scalpel {

using Mat3 = Eigen::Matrix3d;
using Mat34 = Eigen::Matrix<double, 3, 4>;
using Vec12 = Eigen::Matrix<double, 12, 1>;
using Mat12 = Eigen::Matrix<double, 12, 12>;

inline constexpr double kInertQuality = 1e-8;
inline constexpr double kStrainLimit = 1.0;        // see "Strain limit" above [-]
inline constexpr double kTwistStretchFloor = 0.2;  // see evaluate_corotational [-]

enum class TissueKind { Corotational, MassSpring };

// Rest data of one tetrahedron, computed once when the element is born; every step reads it.
struct TetRest {
  Mat34 grad = Mat34::Zero();           // b_a, prestressed rest shape [1/m]
  double volume = 0;                    // prestressed rest volume V [m^3]
  double mass_volume = 0;               // true rest volume, for the lumped mass [m^3]
  double mu = 0, lambda = 0;            // Lamé parameters after sliver scaling [Pa]
  std::array<double, 6> rest_length{};  // L_e, prestressed [m]
  std::array<double, 6> spring_k{};     // k_e [N/m]
  double volume_k = 0;                  // kappa' / V [Pa/m^3]
  double quality = 0;                   // q of the unscaled rest shape [-]
  double stiffness_scale = 0;           // min(1, q / q_min); 0 for a degenerate element
};

// The calibration of the mass-spring model (see above): the spring factor s [-] and the volume
// term's modulus kappa' [Pa] for the material.
struct MassSpringModuli {
  double spring;  // s: k_e = s E V / L_e^2
  double volume;  // kappa'
};
[[nodiscard]] inline MassSpringModuli mass_spring_moduli(const Material& m) {
  const double nu = std::max(m.poisson, 1.0 / 29.0);  // below 1/29: kappa' = 0, s = 29/30
  return {1.0 / (1.0 + nu), m.young * (29.0 * nu - 1.0) / (27.0 * (1.0 + nu) * (1.0 - 2.0 * nu))};
}

// Rest data from the four rest vertices (positively oriented) and the region's material.
[[nodiscard]] TetRest make_tet_rest(const std::array<Vec3, 4>& rest, const Material& m,
                                    double sliver_quality);

// Rotation of the polar decomposition of F, iterated from q (Müller et al. 2016).
void extract_rotation(const Mat3& f, Eigen::Quaterniond& q, int max_iterations = 100);

// Per-step state of a co-rotational element: everything the assembly needs.
struct CorotationalState {
  Mat34 c;                          // rotated gradients c_a = R b_a [1/m]
  double lambda_volume, mu_volume;  // V lambda, V mu of the rest data, for the assembly [N m]
  Mat3 twist;                       // M of the twist modes (see above), symmetric, >= 0 [N m]
  Mat34 force;                      // f_a [N]
  double energy;                    // [J]
  bool held;                        // a strain is beyond the strain limit
};

// Evaluates the element at current positions x; q is the warm start in, the rotation out.
void evaluate_corotational(const TetRest& rest, const std::array<Vec3, 4>& x, Eigen::Quaterniond& q,
                           CorotationalState& out);

// Four elements at once, each with the bits evaluate_corotational() gives it alone: in the lanes of
// AVX2 where the processor has it and `vectorised`, else one after the other.
void evaluate_corotational4(const std::array<const TetRest*, 4>& rest,
                            const std::array<const std::array<Vec3, 4>*, 4>& x,
                            const std::array<Eigen::Quaterniond*, 4>& q,
                            const std::array<CorotationalState*, 4>& out, bool vectorised = true);
[[nodiscard]] bool evaluate_corotational4_vectorised();  // the processor has AVX2

// Its general case: `held`, `force`, `energy` and `twist` from the principal axes of the strain
// eps in the frame of the rotation r. evaluate_corotational() forms them without the axes where
// nothing is clamped (docs/tissue.md); tests compare the two.
void corotational_stress_from_principal_axes(const TetRest& rest, const Mat3& r, const Mat3& eps,
                                             CorotationalState& out);

// Adds s K_ab to k, given u = s V lambda c_a and w = s V mu c_a (s any common factor):
// s K_ab = u c_b^T + c_b w^T + (w . c_b) I. The assembly scales u and w once per row entry.
inline void add_corotational_block(Mat3& k, const Vec3& u, const Vec3& w, const Vec3& cb) {
  k.noalias() += u * cb.transpose() + cb * w.transpose();
  k.diagonal().array() += w.dot(cb);
}

// Adds the twist part [c_a] M [c_b]^T of s K_ab to k, given n = s [c_a] M: row r of n [c_b]^T is
// c_b x (row r of n).
inline void add_twist_block(Mat3& k, const Mat3& n, const Vec3& cb) {
  for (int r = 0; r < 3; ++r) k.row(r) += cb.cross(Vec3(n.row(r))).transpose();
}

// s [c_a] M, the factor add_twist_block takes for every b of row a.
[[nodiscard]] inline Mat3 twist_factor(const CorotationalState& s, int a, double scale) {
  const Vec3 ca = scale * s.c.col(a);
  Mat3 n;
  for (int col = 0; col < 3; ++col) n.col(col) = ca.cross(Vec3(s.twist.col(col)));
  return n;
}

// K_ab of the co-rotational element [N/m], from the state as the assembly reads it.
[[nodiscard]] inline Mat3 corotational_block(const CorotationalState& s, int a, int b) {
  const Vec3 ca = s.c.col(a);
  Mat3 k = Mat3::Zero();
  add_corotational_block(k, s.lambda_volume * ca, s.mu_volume * ca, s.c.col(b));
  add_twist_block(k, twist_factor(s, a, 1.0), s.c.col(b));
  return k;
}

// The spring stiffness of edge e is k_e (n n^T + t (I - n n^T)) = a a^T + d I with the unit edge
// vector n, the transverse factor t = max(0, 1 - L_e / l_e), a = sqrt(k_e (1 - t)) n, d = k_e t.
struct MassSpringState {
  std::array<Vec3, 6> axial;         // a_e [sqrt(N/m)]
  std::array<double, 6> transverse;  // d_e [N/m]
  Mat34 volume_grad;                 // d vol / d x_a [m^2]
  double volume_stiffness;           // kappa' / V times the secant weight (see "Strain limit") [Pa/m^3]
  Mat34 force;                       // [N]
  double energy;                     // [J]
  bool held;                         // a strain is beyond the strain limit
};

void evaluate_mass_spring(const TetRest& rest, const std::array<Vec3, 4>& x, MassSpringState& out);

// Local edge joining vertices a != b (index into kEdgeVertices).
inline constexpr std::array<std::array<int, 4>, 4> kEdgeOf = {
    {{-1, 0, 1, 2}, {0, -1, 3, 4}, {1, 3, -1, 5}, {2, 4, 5, -1}}};

// Adds h K_ab of the mass-spring element to *out[b] for b = 0..3 (row a) [N/m]: the volume term
// h kappa/V g_a g_b^T, minus the spring block a_e a_e^T + d_e I of edge ab off the diagonal and
// plus the three spring blocks of the edges at a on it. Each block is one fused rank-2 update, as
// in add_corotational_block: a third of the time of forming the spring block first. The state
// holds all it needs: the assembly reads no rest data.
inline void add_mass_spring_row(const MassSpringState& s, int a, double h, const std::array<Mat3*, 4>& out) {
  const Vec3 ga = (h * s.volume_stiffness) * s.volume_grad.col(a);
  Mat3 diag;
  diag.noalias() = ga * s.volume_grad.col(a).transpose();
  double transverse = 0;
  for (int b = 0; b < 4; ++b) {
    if (b == a) continue;
    const auto e = static_cast<size_t>(kEdgeOf[static_cast<size_t>(a)][static_cast<size_t>(b)]);
    const Vec3& axial = s.axial[e];
    const Vec3 h_axial = h * axial;
    const double d = h * s.transverse[e];
    diag.noalias() += h_axial * axial.transpose();
    transverse += d;
    Mat3& k = *out[static_cast<size_t>(b)];
    k.noalias() += ga * s.volume_grad.col(b).transpose() - h_axial * axial.transpose();
    k.diagonal().array() -= d;
  }
  diag.diagonal().array() += transverse;
  *out[static_cast<size_t>(a)] += diag;
}

// Full 12x12 stiffness from the same blocks the solver assembles (for tests and tools).
[[nodiscard]] Mat12 corotational_stiffness(const CorotationalState& s);
[[nodiscard]] Mat12 mass_spring_stiffness(const MassSpringState& s);

}  // namespace scalpel
