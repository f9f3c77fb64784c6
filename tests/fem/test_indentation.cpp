#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "fem/tissue.hpp"
#include "mesh/generators.hpp"
#include "mesh/io/mesh_io.hpp"

using namespace scalpel;

namespace {

// A rigid punch pressed into a block of tissue, at rest.
struct Punch {
  double force = 0;   // [N] pushing the punch back out (+z), as the punch's nodes press on it
  double energy = 0;  // [J] elastic, at equilibrium
  Vec3 load = Vec3::Zero();
};

// Holds the nodes of `mesh` that `held` picks, presses those `in_punch` picks by delta along -z,
// and solves to rest: two implicit Euler steps far longer than the block's slowest period.
template <class Held, class InPunch>
Punch press_nodes(TetMesh& mesh, const Material& mat, double delta, Held held, InPunch in_punch) {
  TissueSettings settings;
  settings.gravity = Vec3::Zero();
  settings.tolerance = 1e-10;
  settings.max_iterations = 4000;
  TissueModel model(mesh, {mat}, settings);
  std::vector<NodeId> punch;
  for (const NodeId n : mesh.nodes()) {
    const Vec3 p = mesh.rest(n);
    if (held(p)) model.set_fixed(n);
    if (in_punch(p)) {
      punch.push_back(n);
      model.set_fixed(n);  // a fixed node keeps the position the caller gives it
      mesh.positions()[n.index] = p - Vec3(0, 0, delta);
    }
  }
  for (int k = 0; k < 2; ++k) model.step(1000.0);
  Punch out;
  out.load = model.load_on_holder(punch);
  out.force = out.load.z();
  out.energy = model.elastic_energy();
  return out;
}

// A rigid flat square punch of half-width b pressed by delta into a block [-L/2, L/2]^2 x [-H, 0]
// held at its base and sides: the top nodes within b of the axis stick to the punch.
Punch press(double b, double delta, double L, double H, int cells_xy, int cells_z, const Material& mat) {
  BoxSpec spec;
  spec.min = Vec3(-L / 2, -L / 2, -H);
  spec.max = Vec3(L / 2, L / 2, 0);
  spec.cells = {cells_xy, cells_xy, cells_z};
  TetMesh mesh = make_box(spec);
  return press_nodes(
      mesh, mat, delta,
      [&](const Vec3& p) {
        return std::abs(std::abs(p.x()) - L / 2) < 1e-9 || std::abs(std::abs(p.y()) - L / 2) < 1e-9 ||
               std::abs(p.z() + H) < 1e-9;
      },
      [&](const Vec3& p) {
        return std::abs(p.z()) < 1e-9 && std::max(std::abs(p.x()), std::abs(p.y())) <= b + 1e-9;
      });
}

// A rigid flat circular punch of radius a pressed by delta into the graded cylinder of
// tests/data/punch.geo (radius and depth `extent` a), held at its base and rim: the top nodes within
// a of the axis stick to the punch.
Punch press_disk(const std::string& file, double a, double extent, double delta, const Material& mat) {
  TetMesh mesh = read_gmsh(file);
  return press_nodes(
      mesh, mat, delta,
      [&](const Vec3& p) {
        return std::abs(p.z() + extent * a) < 1e-9 || std::hypot(p.x(), p.y()) > extent * a * (1 - 1e-6);
      },
      [&](const Vec3& p) { return std::abs(p.z()) < 1e-9 && std::hypot(p.x(), p.y()) <= a * (1 + 1e-9); });
}

}  // namespace

TEST_CASE(
    "a rigid circular punch on a half-space: the load on it within 10 % of the analytical one, "
    "converging from above" *
    doctest::test_suite("slow")) {
  // The skin's Young's modulus, and a Poisson ratio at which linear tetrahedra do not lock (the check
  // is of the load on the held nodes, not of near-incompressibility).
  Material mat;
  mat.young = 10e3;
  mat.poisson = 0.3;
  mat.density = 1000;
  mat.prestress = 1.0;
  const double a = 0.005, extent = 80, delta = 1e-6;  // as tests/data/punch.geo; a small, linear press
  // The punch holds its nodes every way (bonded): Mossakovskii's load (Spence 1968),
  // F = 4 G a delta ln(3 - 4 nu) / (1 - 2 nu), 2.9 % above Sneddon's frictionless 2 a E delta / (1 - nu^2).
  const double nu = mat.poisson, G = mat.young / (2 * (1 + nu));
  const double analytical = 4 * G * a * delta * std::log(3 - 4 * nu) / (1 - 2 * nu);
  const Vec3 fine = press_disk(SCALPEL_TEST_PUNCH_FINE, a, extent, delta, mat).load;
  const Vec3 coarse = press_disk(SCALPEL_TEST_PUNCH_COARSE, a, extent, delta, mat).load;
  MESSAGE("punch load / analytical: fine ", fine.z() / analytical, ", coarse ", coarse.z() / analytical);
  CHECK(fine.z() == doctest::Approx(analytical).epsilon(0.10));
  // Linear tetrahedra are too stiff, and the punch's rim is singular: the load comes down to the
  // analytical one as the mesh is refined.
  CHECK(coarse.z() > fine.z());
  CHECK(fine.z() > analytical);
  // Axially symmetric: no sideways load.
  CHECK(std::hypot(fine.x(), fine.y()) < 0.01 * fine.z());
}

TEST_CASE("the load tissue nodes press on what holds them is the work of holding them (Clapeyron)") {
  Material mat;
  mat.young = 10e3;
  mat.poisson = 0.45;
  mat.density = 1000;
  mat.prestress = 1.0;
  const double delta = 1e-5;  // [m]: small, so the response is linear
  const Punch p = press(0.005, delta, 0.04, 0.02, 12, 6, mat);
  // Pressed down, the tissue pushes the punch back up; the cubes' diagonals (every one split the
  // same way) couple a little shear into it.
  CHECK(p.force > 0);
  CHECK(std::hypot(p.load.x(), p.load.y()) < 0.1 * p.force);
  // Linear elasticity: the energy stored is half the load times the displacement.
  CHECK(0.5 * p.force * delta == doctest::Approx(p.energy).epsilon(2e-3));
  // And the load grows with the press as a linear spring does.
  const Punch twice = press(0.005, 2 * delta, 0.04, 0.02, 12, 6, mat);
  CHECK(twice.force == doctest::Approx(2 * p.force).epsilon(2e-3));
}
