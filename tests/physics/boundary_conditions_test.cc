#include "physics/boundary_conditions.h"

#include <cmath>

#include <gtest/gtest.h>

namespace aqs {
namespace {

// Each kind of bad entry is refused with a message naming the source and the entry.
TEST(BoundaryConditionsTest, ValidationNamesTheSourceAndTheEntry) {
  BoundaryConditions bc;
  bc.vertices = {4, 0, 2};
  std::string error;
  EXPECT_TRUE(ValidateBoundaryConditions(bc, 5, "fixed.txt", &error)) << error;
  bc.positions = Eigen::Matrix3Xd::Ones(3, 3);
  EXPECT_TRUE(ValidateBoundaryConditions(bc, 5, "fixed.txt", &error)) << error;

  BoundaryConditions out_of_range = bc;
  out_of_range.vertices[1] = 5;
  EXPECT_FALSE(ValidateBoundaryConditions(out_of_range, 5, "fixed.txt", &error));
  EXPECT_EQ(error, "fixed.txt: fixed vertex entry 1 is 5, outside the mesh's vertex range [0, 5)");
  out_of_range.vertices[1] = -1;
  EXPECT_FALSE(ValidateBoundaryConditions(out_of_range, 5, "fixed.txt", &error));

  BoundaryConditions repeated = bc;
  repeated.vertices[2] = 4;
  EXPECT_FALSE(ValidateBoundaryConditions(repeated, 5, "fixed.txt", &error));
  EXPECT_EQ(error, "fixed.txt: vertex 4 is listed twice (entries 0 and 2)");

  BoundaryConditions short_positions = bc;
  short_positions.positions = Eigen::Matrix3Xd::Ones(3, 2);
  EXPECT_FALSE(ValidateBoundaryConditions(short_positions, 5, "fixed.txt", &error));
  EXPECT_EQ(error, "fixed.txt: 2 prescribed positions for 3 fixed vertices");

  BoundaryConditions not_finite = bc;
  not_finite.positions(1, 2) = std::nan("");
  EXPECT_FALSE(ValidateBoundaryConditions(not_finite, 5, "fixed.txt", &error));
  EXPECT_EQ(error, "fixed.txt: prescribed position of vertex 2 is not finite");
}

TEST(BoundaryConditionsTest, MaskMarksTheFixedVertices) {
  BoundaryConditions bc;
  bc.vertices = {3, 0};
  EXPECT_EQ(FixedVertexMask(bc, 5), std::vector<bool>({true, false, false, true, false}));
  EXPECT_EQ(FixedVertexMask(BoundaryConditions(), 2), std::vector<bool>({false, false}));
}

}  // namespace
}  // namespace aqs
