#include <doctest/doctest.h>

#include <cmath>
#include <limits>

#include "fem/material.hpp"
#include "fem/tissue.hpp"
#include "mesh/generators.hpp"

using namespace scalpel;

TEST_CASE("validate_material names the bad field") {
  CHECK_FALSE(validate_material(Material{}).has_value());
  const auto field_of = [](Material m) { return validate_material(m).value_or(MaterialError{}).field; };
  Material m;
  m.young = -5;
  CHECK(field_of(m) == "young");
  CHECK(validate_material(m)->message.find("-5") != std::string::npos);
  m = {};
  m.poisson = 0.5;
  CHECK(field_of(m) == "poisson");
  m.poisson = 0.7;
  CHECK(field_of(m) == "poisson");
  m = {};
  m.density = 0;
  CHECK(field_of(m) == "density");
  m = {};
  m.damping_mass = -1;
  CHECK(field_of(m) == "damping_mass");
  m = {};
  m.damping_stiffness = std::numeric_limits<double>::quiet_NaN();
  CHECK(field_of(m) == "damping_stiffness");
  m = {};
  m.prestress = 0;
  CHECK(field_of(m) == "prestress");
  m = {};
  m.young = std::numeric_limits<double>::infinity();
  CHECK(field_of(m) == "young");
}

TEST_CASE("a tissue model rejects a bad material by region and field") {
  TetMesh mesh = make_box({.cells = {1, 1, 1}});
  Material bad;
  bad.poisson = 0.5;
  try {
    TissueModel model(mesh, {Material{}, bad});
    FAIL("expected std::invalid_argument");
  } catch (const std::invalid_argument& e) {
    CHECK(std::string(e.what()).find("materials[1].poisson") != std::string::npos);
  }
  CHECK_THROWS_AS(TissueModel(mesh, {}), std::out_of_range);  // region 0 has no material
}
