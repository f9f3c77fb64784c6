#include <doctest/doctest.h>

#include <cmath>

#include "fem/tissue.hpp"
#include "mesh/generators.hpp"

using namespace scalpel;

namespace {

// A rigid flat square punch of half-width b pressed by delta into a block [-L/2, L/2]^2 x [-H, 0]
// held at its base and sides: the top nodes within b of the axis stick to the punch.
struct Punch {
  double force = 0;   // [N] along the punch's motion (-z), as the punch's nodes press on it
  double energy = 0;  // [J] elastic, at equilibrium
  Vec3 load = Vec3::Zero();
};

Punch press(double b, double delta, double L, double H, int cells_xy, int cells_z, const Material& mat) {
  BoxSpec spec;
  spec.min = Vec3(-L / 2, -L / 2, -H);
  spec.max = Vec3(L / 2, L / 2, 0);
  spec.cells = {cells_xy, cells_xy, cells_z};
  TetMesh mesh = make_box(spec);
  TissueSettings settings;
  settings.gravity = Vec3::Zero();
  settings.tolerance = 1e-10;
  settings.max_iterations = 2000;
  TissueModel model(mesh, {mat}, settings);
  std::vector<NodeId> punch;
  for (const NodeId n : mesh.nodes()) {
    const Vec3 p = mesh.rest(n);
    const bool held = std::abs(std::abs(p.x()) - L / 2) < 1e-9 || std::abs(std::abs(p.y()) - L / 2) < 1e-9 ||
                      std::abs(p.z() + H) < 1e-9;
    if (held) model.set_fixed(n);
    if (std::abs(p.z()) < 1e-9 && std::max(std::abs(p.x()), std::abs(p.y())) <= b + 1e-9) {
      punch.push_back(n);
      model.set_fixed(n);  // a fixed node keeps the position the caller gives it
      mesh.positions()[n.index] = p - Vec3(0, 0, delta);
    }
  }
  // Implicit Euler steps far longer than the block's slowest period: each is close to a static solve.
  for (int k = 0; k < 12; ++k) model.step(10.0);
  Punch out;
  out.load = model.load_on_holder(punch);
  out.force = out.load.z();
  out.energy = model.elastic_energy();
  return out;
}

}  // namespace

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
