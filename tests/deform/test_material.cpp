// Material map: round trips and the exact messages for bad parameters.

#include "deform/material.h"

#include <gtest/gtest.h>

#include <limits>
#include <stdexcept>
#include <string>

namespace palpa::deform {
namespace {

TEST(Material, UniformSetAndAtRoundTrip) {
  Material a;
  a.model = LocalModelKind::Viscoelastic;
  a.mass = 2e-3;
  a.damping = 0.5;
  a.stiffness = 800;
  a.alpha = 0;
  a.k2 = 300;
  a.tau = 0.25;
  MaterialArrays arrays = MaterialArrays::uniform(5, Material{});
  ASSERT_EQ(arrays.size(), 5u);
  arrays.set(3, a);
  EXPECT_EQ(arrays.at(3), a);
  EXPECT_EQ(arrays.at(2), Material{});
  EXPECT_NO_THROW(arrays.validate(5));
}

// Each bad parameter with the message that names the vertex, field and value.
struct BadMaterial {
  const char* name;
  void (*spoil)(Material&);
  const char* message;
};

const BadMaterial kBadMaterials[] = {
    {"zero mass", [](Material& m) { m.mass = 0; }, "material of vertex 2: mass must be positive and finite, got 0 kg"},
    {"negative damping", [](Material& m) { m.damping = -1; },
     "material of vertex 2: damping must be non-negative and finite, got -1 N s/m"},
    {"nan stiffness", [](Material& m) { m.stiffness = std::numeric_limits<double>::quiet_NaN(); },
     "material of vertex 2: stiffness must be positive and finite, got nan N/m"},
    {"infinite alpha", [](Material& m) { m.alpha = std::numeric_limits<double>::infinity(); },
     "material of vertex 2: alpha must be non-negative and finite, got inf 1/m"},
    {"negative k2", [](Material& m) { m.k2 = -5; }, "material of vertex 2: k2 must be non-negative and finite, got -5 N/m"},
    {"zero tau", [](Material& m) { m.tau = 0; }, "material of vertex 2: tau must be positive and finite, got 0 s"},
    {"unknown model", [](Material& m) { m.model = static_cast<LocalModelKind>(7); },
     "material of vertex 2: unknown local model 7"},
};

TEST(Material, BadParametersAreRejectedWithExactMessages) {
  for (const BadMaterial& bad : kBadMaterials) {
    SCOPED_TRACE(bad.name);
    MaterialArrays arrays = MaterialArrays::uniform(4, Material{});
    Material m;
    bad.spoil(m);
    arrays.set(2, m);
    try {
      arrays.validate(4);
      ADD_FAILURE() << "no exception";
    } catch (const std::invalid_argument& e) {
      EXPECT_EQ(std::string(e.what()), bad.message);
    }
  }
}

TEST(Material, ArraySizeMismatchIsRejected) {
  MaterialArrays arrays = MaterialArrays::uniform(5, Material{});
  arrays.damping.pop_back();
  try {
    arrays.validate(5);
    ADD_FAILURE() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()), "materials: array 'damping' has 4 entries, expected 5");
  }
  try {
    MaterialArrays::uniform(3, Material{}).validate(5);
    ADD_FAILURE() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()), "materials: array 'model' has 3 entries, expected 5");
  }
}

}  // namespace
}  // namespace palpa::deform
