// Prestressed tissue that settles, and a wound that gapes as elasticity says (docs/tissue.md).
#include <doctest/doctest.h>

#include <cmath>
#include <filesystem>
#include <memory>
#include <vector>

#include <Eigen/Sparse>

#include "sim/replay.hpp"
#include "sim/scenario.hpp"
#include "sim/simulation.hpp"

using namespace scalpel;

namespace {

// A free membrane 60 x 60 x 2 mm fixed at its sides, prestressed in every direction by lambda0.
// 41 cells a side keep the grid planes off y = 0, where the cut runs.
std::string membrane(double prestress, double rate, bool gravity, int cells = 41, double young = 1e5) {
  return R"(
name: membrane
mesh:
  generator: slab
  size: [0.060, 0.060]
  cells: [)" +
         std::to_string(cells) + ", " + std::to_string(cells) + R"(]
  layers:
    - {name: skin, thickness: 0.002, cells: 1}
materials:
  skin: {young: )" +
         std::to_string(young) + R"(, poisson: 0.45, density: 1100, prestress: )" +
         std::to_string(prestress) + R"(}
tissue:
  model: corotational
  rate: )" +
         std::to_string(rate) +
         R"(
  solver: {tolerance: 1.0e-6, max_iterations: 400}
  gravity: )" +
         (gravity ? "[0, 0, -9.81]" : "[0, 0, 0]") +
         R"(
fixed:
  - {side: x_min}
  - {side: x_max}
  - {side: y_min}
  - {side: y_max}
tool:
  blade: {back: [0, 0, 0.004], tip: [0, 0, 0], edge: [1, 0, 0]}
  cutting_resistance: 0
)";
}

std::filesystem::path bundled(const char* name) {
  return std::filesystem::path(SCALPEL_SOURCE_DIR) / "config" / name;
}

// Frames of 1/60 s with the tool held far away, until `seconds`; returns the kinetic energy after
// each tissue step and fills `last` with the displacement change of each node over the last step.
std::vector<double> settle(Simulation& sim, double seconds, double& last_move) {
  ForceChannel forces;
  sim.on_sample(ToolSample{.position = Vec3(0, 0, 0.1)});
  std::vector<double> kinetic;
  std::vector<Vec3> before;
  const int frames = static_cast<int>(std::lround(seconds * 60));
  for (int k = 1; k <= frames; ++k) {
    if (k == frames) before = sim.mesh().positions();
    sim.end_frame(k / 60.0, forces);
    for (std::size_t s = kinetic.size(); s < sim.tissue_steps().size(); ++s) {
      REQUIRE(sim.tissue_steps()[s].status != StepStatus::NonFinite);
      kinetic.push_back(sim.tissue_steps()[s].kinetic_energy);
    }
  }
  last_move = 0;
  for (const NodeId n : sim.mesh().nodes())
    last_move = std::max(last_move, (sim.mesh().position(n) - before[n.index]).norm());
  return kinetic;
}

// Settles the scenario at its own rate and at 600 Hz: kinetic energy below 1e-9 J within 2 s, no
// alternation (the last frame moves the surface by nothing visible), and the same shape within 1 %
// of the largest displacement.
void check_settles(Scenario sc) {
  const double rate = sc.tissue.rate;
  Simulation coarse(sc);
  double move = 0;
  const std::vector<double> kinetic = settle(coarse, 2.0, move);
  const auto below = std::find_if(kinetic.begin(), kinetic.end(), [](double e) { return e < 1e-9; });
  REQUIRE(below != kinetic.end());
  const double settled_at = static_cast<double>(below - kinetic.begin() + 1) / rate;
  CHECK(kinetic.back() < 1e-9);
  CHECK(*std::max_element(below, kinetic.end()) < 1e-9);  // and it stays there
  sc.tissue.rate = 600;
  Simulation fine(sc);
  double fine_move = 0;
  settle(fine, 1.0, fine_move);
  double largest = 0, apart = 0;
  for (const NodeId n : coarse.mesh().nodes()) {
    largest = std::max(largest, (coarse.mesh().position(n) - coarse.mesh().rest(n)).norm());
    apart = std::max(apart, (coarse.mesh().position(n) - fine.mesh().position(n)).norm());
  }
  MESSAGE(sc.name << ": kinetic energy below 1e-9 J after " << settled_at << " s at " << rate
                  << " Hz, last frame moved " << move * 1e6 << " um; largest displacement " << largest * 1e3
                  << " mm, " << apart * 1e3 << " mm from the 600 Hz shape");
  CHECK(move < 1e-3 * largest);
  CHECK(apart <= 0.01 * largest);
}

}  // namespace

TEST_CASE("the bundled prestressed skin settles at its 60 Hz step, to the shape a 600 Hz step reaches" *
          doctest::test_suite("slow")) {
  check_settles(load_scenario(bundled("scenarios/skin_incision.yaml")));
}

TEST_CASE("a prestressed membrane fixed at its sides settles at 60 Hz, to the shape a 600 Hz step reaches" *
          doctest::test_suite("slow")) {
  check_settles(parse_scenario(membrane(1.05, 60, true, 20), "membrane.yaml", "."));
}

namespace {

// Reference for the crack in the membrane, computed independently of the simulator: linear plane
// stress on bilinear quadrilaterals (2 x 2 Gauss points), on the quarter [0, b]^2 of a plate held at
// its edges x = b and y = b, with a crack of half-length a along y = 0. By superposition the
// prestressed plate's crack opens as an uncut one whose crack faces are pulled apart by the
// prestress sigma; symmetry: u_x = 0 on x = 0, u_y = 0 on y = 0 ahead of the crack. Returns the
// crack opening 2 u_y(x, 0) at the n + 1 nodes x = 0, a/n, ..., a (n = cells along the crack).
std::vector<double> plane_stress_crack_opening(double b, double a, int cells, double young, double poisson,
                                               double sigma) {
  const double h = b / cells;
  const int along = static_cast<int>(std::lround(a / h));
  REQUIRE(std::abs(along * h - a) < 1e-9 * a);
  const int n = cells + 1;  // nodes a side
  const auto dof = [n](int i, int j, int c) { return 2 * (j * n + i) + c; };
  // Element stiffness of a unit-thickness square (independent of its size).
  Eigen::Matrix3d d;
  d << 1, poisson, 0, poisson, 1, 0, 0, 0, (1 - poisson) / 2;
  d *= young / (1 - poisson * poisson);
  Eigen::Matrix<double, 8, 8> ke = Eigen::Matrix<double, 8, 8>::Zero();
  const double g = 1 / std::sqrt(3.0);
  const std::array<Eigen::Vector2d, 4> corner{Eigen::Vector2d(-1, -1), Eigen::Vector2d(1, -1),
                                              Eigen::Vector2d(1, 1), Eigen::Vector2d(-1, 1)};
  for (const double xi : {-g, g})
    for (const double eta : {-g, g}) {
      Eigen::Matrix<double, 3, 8> bm = Eigen::Matrix<double, 3, 8>::Zero();
      for (int k = 0; k < 4; ++k) {
        // dN/dx = dN/dxi 2/h; the Jacobian determinant h^2/4 cancels the 4/h^2 of B^T B.
        const double nx = 0.25 * corner[k].x() * (1 + eta * corner[k].y());
        const double ny = 0.25 * corner[k].y() * (1 + xi * corner[k].x());
        bm(0, 2 * k) = nx;
        bm(1, 2 * k + 1) = ny;
        bm(2, 2 * k) = ny;
        bm(2, 2 * k + 1) = nx;
      }
      ke += bm.transpose() * d * bm;
    }
  const int total = 2 * n * n;
  std::vector<std::uint8_t> fixed(static_cast<std::size_t>(total), 0);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      if (i == cells || j == cells) fixed[dof(i, j, 0)] = fixed[dof(i, j, 1)] = 1;
      if (i == 0) fixed[dof(i, j, 0)] = 1;
      if (j == 0 && i >= along) fixed[dof(i, j, 1)] = 1;
    }
  std::vector<int> index(static_cast<std::size_t>(total), -1);
  int unknowns = 0;
  for (int k = 0; k < total; ++k)
    if (!fixed[k]) index[k] = unknowns++;
  std::vector<Eigen::Triplet<double>> triplets;
  for (int j = 0; j < cells; ++j)
    for (int i = 0; i < cells; ++i) {
      const std::array<int, 4> nodes{j * n + i, j * n + i + 1, (j + 1) * n + i + 1, (j + 1) * n + i};
      for (int p = 0; p < 8; ++p)
        for (int q = 0; q < 8; ++q) {
          const int r = index[2 * nodes[p / 2] + p % 2], c = index[2 * nodes[q / 2] + q % 2];
          if (r >= 0 && c >= 0) triplets.emplace_back(r, c, ke(p, q));
        }
    }
  Eigen::SparseMatrix<double> k(unknowns, unknowns);
  k.setFromTriplets(triplets.begin(), triplets.end());
  Eigen::VectorXd f = Eigen::VectorXd::Zero(unknowns);
  // Consistent nodal loads of the traction sigma (per unit thickness) on the crack face.
  for (int i = 0; i < along; ++i)
    for (const int node : {i, i + 1})
      if (index[dof(node, 0, 1)] >= 0) f[index[dof(node, 0, 1)]] += 0.5 * sigma * h;
  const Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver(k);
  REQUIRE(solver.info() == Eigen::Success);
  const Eigen::VectorXd u = solver.solve(f);
  std::vector<double> opening;
  for (int i = 0; i <= along; ++i) {
    const int r = index[dof(i, 0, 1)];
    opening.push_back(r >= 0 ? 2 * u[r] : 0.0);
  }
  return opening;
}

}  // namespace

TEST_CASE("the 2-D reference converges to the infinite plate's crack opening 4 sigma a / E" *
          doctest::test_suite("slow")) {
  // Far edges: the opening of a Griffith crack, 4 sigma a / E at the middle (plane stress),
  // elliptical along the crack (Tada, Paris, Irwin, The Stress Analysis of Cracks Handbook, 3rd
  // ed., 2000, section 5.1).
  const double a = 0.002, sigma = 1000, young = 1e5;
  const std::vector<double> wide = plane_stress_crack_opening(0.04, a, 400, young, 0.45, sigma);
  const double griffith = 4 * sigma * a / young;
  MESSAGE("crack in a plate 20 crack lengths wide: opening " << wide[0] / griffith << " of 4 sigma a / E");
  CHECK(std::abs(wide[0] / griffith - 1) < 0.03);
  CHECK(std::abs(wide[10] / (griffith * std::sqrt(1 - 0.5 * 0.5)) - 1) < 0.03);
}

namespace {

struct CrackOpening {
  double a = 0, h = 0;            // crack half-length, cell size [m]
  WoundGape gape;                 // measured along the crack
  std::vector<double> reference;  // the 2-D reference's opening at x = 0 ... a [m]
  double reference_change = 0;    // its change at the last refinement [-]
  double infinite_plate = 0;      // 4 sigma a / E [m]
};

// A membrane 60 x 60 x 2 mm of `cells` cells a side (odd: no grid plane on y = 0), held at its
// sides, lambda0 = 1.02 (strains small enough for linear theory), no gravity. The blade, longer
// than the membrane is thick, comes down a tenth of a cell outside the grid plane x = -a (plane k
// from x_min), runs along y = 0 to just past x = a and lifts out; the tissue then settles. Crack
// tips on grid planes make the crack as long as the reference's.
CrackOpening cut_membrane(int cells, int tip_plane) {
  constexpr double kPrestress = 1.02, kYoung = 1e5, kPoisson = 0.45;
  CrackOpening out;
  out.h = 0.060 / cells;
  out.a = 0.5 * (cells - 2 * tip_plane) * out.h;
  const double a = out.a, h = out.h;
  Simulation sim(parse_scenario(membrane(kPrestress, 60, false, cells), "membrane.yaml", "."));
  ForceChannel forces;
  ToolSample s;
  double t = 0;
  int samples = 0;
  const auto sample = [&](const Vec3& p) {
    s.t += 0.001;
    s.position = p;
    sim.on_sample(s);
    if (++samples % 16 == 0) sim.end_frame(t += 0.016, forces);
  };
  const double start = -a - 0.1 * h, end = a + 0.1 * h;
  for (int k = 0; k <= 200; ++k) sample(Vec3(start, 0, 0.001 - 0.004 * k / 200));  // tip to 3 mm below
  const int run = static_cast<int>((end - start) / 2e-5);
  for (int k = 1; k <= run; ++k) sample(Vec3(start + (end - start) * k / run, 0, -0.003));
  for (int k = 1; k <= 200; ++k) sample(Vec3(end, 0, -0.003 + 0.008 * k / 200));
  for (int k = 0; k < 120 * 16; ++k) sample(Vec3(end, 0, 0.005));  // two seconds to settle
  REQUIRE(sim.tissue_steps().back().kinetic_energy < 1e-9);
  const std::vector<Vec3> path{Vec3(-a, 0, 0), Vec3(a, 0, 0)};
  out.gape = sim.wound_gape(path, 0.5 * h, 0.5 * h);
  // The reference: the prestress of the current shape, sigma = E eps0 / (1 - nu), eps0 = 1 -
  // 1/lambda0, and the 2-D solve on cells a tenth as large and finer (a multiple of h / 2, so the
  // crack ends on a node), refined until it changes by less than 1 %.
  const double sigma = kYoung * (1 - 1 / kPrestress) / (1 - kPoisson);
  out.infinite_plate = 4 * sigma * a / kYoung;
  out.reference_change = 1;
  for (int m = 2; m <= 16 && out.reference_change > 0.01; m *= 2) {
    std::vector<double> finer = plane_stress_crack_opening(0.030, a, cells * m, kYoung, kPoisson, sigma);
    if (!out.reference.empty()) out.reference_change = std::abs(finer[0] / out.reference[0] - 1);
    out.reference = std::move(finer);
  }
  return out;
}

}  // namespace

TEST_CASE("a through-cut of a prestressed membrane opens as plane-stress elasticity says" *
          doctest::test_suite("slow")) {
  const CrackOpening c = cut_membrane(41, 8);  // 1.46 mm cells, 2a = 36.6 mm
  CHECK(c.reference_change <= 0.01);
  const double cod = c.reference[0];
  MESSAGE("crack of 2a = " << 2 * c.a * 1e3 << " mm at " << c.h * 1e3 << " mm cells: opening at the middle "
                           << c.gape.middle * 1e3 << " mm, reference " << cod * 1e3 << " mm (ratio "
                           << c.gape.middle / cod << "), infinite plate " << c.infinite_plate * 1e3 << " mm; "
                           << c.gape.surface_nodes << " surface cut nodes, " << c.gape.bridges << " closed");
  CHECK(std::abs(c.gape.middle / cod - 1) < 0.05);
  // The profile follows the reference's along the crack (the ellipse of a Griffith crack, lowered
  // by the held edges) and no tissue bridges the crack behind the cells the blade crossed.
  const auto at = [&](double x) {  // the reference opening at |x|, linearly between its nodes
    const double u = std::abs(x) / c.a * static_cast<double>(c.reference.size() - 1);
    const auto i = std::min(c.reference.size() - 2, static_cast<std::size_t>(u));
    return c.reference[i] + (u - static_cast<double>(i)) * (c.reference[i + 1] - c.reference[i]);
  };
  int checked = 0;
  double worst = 0;
  for (const WoundGape::Point& p : c.gape.profile) {
    const double x = p.s - c.a;
    if (std::abs(x) >= c.a - 2 * c.h) continue;  // the last cells: the tip of a crack on a mesh
    CAPTURE(x);
    CHECK_FALSE(p.bridge);
    worst = std::max(worst, std::abs(p.gape - at(x)) / cod);
    ++checked;
  }
  MESSAGE("profile: " << checked << " points up to two cells from the tips, within " << worst * 100
                      << " % of the middle's opening of the reference");
  CHECK(worst < 0.08);
  CHECK(checked >= 20);
}

TEST_CASE("the bundled incision gapes at the skin surface" * doctest::test_suite("slow")) {
  // The replay of the bundled scenario and log: the lips stand at least 2.5 mm apart at the middle
  // of the incision, and tissue bridges them only within a cell of where the blade enters and lifts
  // out (cells of 40/15 mm along the path).
  const Scenario sc = load_scenario(bundled("scenarios/skin_incision.yaml"));
  REQUIRE(sc.log);
  const auto out = std::filesystem::temp_directory_path() / "scalpel_test_wound";
  ReplayOptions options;
  options.out_dir = out;
  const ReplayResult r = replay(sc, *sc.log, options);
  std::filesystem::remove_all(out);
  CHECK(r.invariants_ok);
  const auto& w = r.report["tissue"]["wound_opening"];
  const double middle = w["middle"].get<double>(), length = 0.020, cell = 0.040 / 15;
  MESSAGE("bundled incision: gape " << middle * 1e3 << " mm at the middle, mean "
                                    << w["mean"].get<double>() * 1e3 << " mm, max "
                                    << w["max"].get<double>() * 1e3 << " mm, " << w["bridges"].get<int>()
                                    << " of " << w["surface_cut_nodes"].get<int>()
                                    << " surface cut nodes closed");
  CHECK(middle >= 2.5e-3);
  CHECK(w["max"].get<double>() < 6e-3);  // the prestress's release, not a tear
  std::size_t inside = 0;
  for (const auto& p : w["profile"]) {
    const double s = p[0].get<double>(), gape = p[1].get<double>();
    if (s < cell || s > length - cell) continue;
    ++inside;
    CAPTURE(s);
    CHECK(gape > 0.3e-3);
  }
  CHECK(inside >= 15);
}
