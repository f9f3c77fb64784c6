#include <doctest/doctest.h>

#include <cstring>
#include <random>
#include <string>

#include "fem/row_kernel.hpp"

using namespace scalpel;

namespace {

// An element state as evaluate_corotational() leaves it, from a random tetrahedron under a random
// deformation (the twist matrix included), so the entries have the magnitudes of a real step.
CorotationalState random_state(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-0.3, 0.3);
  std::array<Vec3, 4> rest{Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)};
  for (Vec3& p : rest) p = 0.01 * (p + Vec3(u(rng), u(rng), u(rng)));
  Mat3 d;
  d << rest[1] - rest[0], rest[2] - rest[0], rest[3] - rest[0];
  if (d.determinant() < 0) std::swap(rest[2], rest[3]);
  Material m;
  m.prestress = 1.1;
  const TetRest r = make_tet_rest(rest, m, 0.05);
  Mat3 a = Mat3::Identity();
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) a(i, j) += u(rng);
  std::array<Vec3, 4> x;
  for (std::size_t i = 0; i < 4; ++i) x[i] = a * rest[i];
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  CorotationalState s;
  evaluate_corotational(r, x, q, s);
  return s;
}

bool same_bits(const Mat3& a, const Mat3& b) {
  return std::memcmp(a.data(), b.data(), sizeof(Mat3)) == 0;
}

}  // namespace

TEST_CASE("row kernel: every instruction set adds the blocks of the scalar functions, bit for bit") {
  std::mt19937 rng(20261129);
  std::uniform_real_distribution<double> u(-1e3, 1e3);
  std::vector<RowIsa> isas{RowIsa::Portable};
  if (avx2_available()) isas.push_back(RowIsa::Avx2);
  const std::string tested = avx2_available() ? "yes" : "no, this processor lacks it";
  MESSAGE("AVX2 kernel tested: " << tested);
  int twisted = 0;
  for (int trial = 0; trial < 400; ++trial) {
    const CorotationalState s = random_state(rng);
    if (s.twist.norm() > 0) ++twisted;
    const double h = 1e-4 * (1 + trial % 7);
    for (int a = 0; a < 4; ++a) {
      // Blocks already holding sums, as in a row part-way through its entries.
      std::array<Mat3, 4> start;
      for (Mat3& k : start) k = Mat3::NullaryExpr([&] { return u(rng); });
      std::array<Mat3, 4> expected = start;
      const Vec3 ca = s.c.col(a);
      const Mat3 n = twist_factor(s, a, h);
      for (int b = 0; b < 4; ++b) {
        Mat3& k = expected[static_cast<std::size_t>(b)];
        add_corotational_block(k, (h * s.lambda_volume) * ca, (h * s.mu_volume) * ca, s.c.col(b));
        add_twist_block(k, n, s.c.col(b));
      }
      for (RowIsa isa : isas) {
        std::array<Mat3, 4> got = start;
        corotational_row_kernel(isa)(s, a, h, {&got[0], &got[1], &got[2], &got[3]});
        for (std::size_t b = 0; b < 4; ++b) {
          INFO("trial " << trial << " row " << a << " block " << b << " isa " << static_cast<int>(isa));
          REQUIRE(same_bits(got[b], expected[b]));
        }
      }
    }
  }
  CHECK(twisted > 300);  // the twist part was exercised
}

TEST_CASE("row kernel: the blocks of an element's rows make its stiffness") {
  std::mt19937 rng(7);
  const CorotationalState s = random_state(rng);
  std::array<std::array<Mat3, 4>, 4> k{};
  for (auto& row : k)
    for (Mat3& b : row) b.setZero();
  for (int a = 0; a < 4; ++a) {
    auto& row = k[static_cast<std::size_t>(a)];
    corotational_row_kernel()(s, a, 1.0, {&row[0], &row[1], &row[2], &row[3]});
  }
  const Mat12 full = corotational_stiffness(s);
  for (int a = 0; a < 4; ++a)
    for (int b = 0; b < 4; ++b)
      CHECK(same_bits(k[static_cast<std::size_t>(a)][static_cast<std::size_t>(b)],
                      full.block<3, 3>(3 * a, 3 * b)));
}
