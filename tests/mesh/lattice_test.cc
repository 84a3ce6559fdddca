#include "mesh/lattice.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "mesh/boundary_surface.h"
#include "mesh/tet_mesh.h"
#include "mesh_test_util.h"

namespace aqs {
namespace {

struct LatticeCase {
  LatticeType type;
  int nx, ny, nz;
};

class LatticeTest : public ::testing::TestWithParam<LatticeCase> {
 protected:
  LatticeOptions Options() const {
    LatticeOptions options;
    options.type = GetParam().type;
    options.nx = GetParam().nx;
    options.ny = GetParam().ny;
    options.nz = GetParam().nz;
    options.spacing = 0.25;
    options.origin = Eigen::Vector3d(1.5, -2.0, 0.75);
    return options;
  }
};

TEST_P(LatticeTest, CountsAndVertexIndexFormula) {
  const LatticeOptions o = Options();
  const TetMesh mesh = MakeLatticeMesh(o);
  const int num_cubes = o.nx * o.ny * o.nz;
  const int num_corners = (o.nx + 1) * (o.ny + 1) * (o.nz + 1);
  for (int k = 0; k <= o.nz; ++k) {
    for (int j = 0; j <= o.ny; ++j) {
      for (int i = 0; i <= o.nx; ++i) {
        const int index = i + (o.nx + 1) * (j + (o.ny + 1) * k);
        EXPECT_EQ(mesh.vertices.col(index), o.origin + o.spacing * Eigen::Vector3d(i, j, k));
      }
    }
  }
  if (o.type == LatticeType::kKuhn) {
    EXPECT_EQ(mesh.num_vertices(), num_corners);
    EXPECT_EQ(mesh.num_tets(), 6 * num_cubes);
  } else {
    EXPECT_EQ(mesh.num_vertices(), num_corners + num_cubes);
    for (int k = 0; k < o.nz; ++k) {
      for (int j = 0; j < o.ny; ++j) {
        for (int i = 0; i < o.nx; ++i) {
          const int index = num_corners + i + o.nx * (j + o.ny * k);
          EXPECT_EQ(mesh.vertices.col(index),
                    o.origin + o.spacing * Eigen::Vector3d(i + 0.5, j + 0.5, k + 0.5));
        }
      }
    }
    const int boundary_faces = 2 * (o.nx * o.ny + o.ny * o.nz + o.nx * o.nz);
    const int all_faces =
        (o.nx + 1) * o.ny * o.nz + o.nx * (o.ny + 1) * o.nz + o.nx * o.ny * (o.nz + 1);
    EXPECT_EQ(mesh.num_tets(), 4 * (all_faces - boundary_faces) + 2 * boundary_faces);
  }
}

TEST_P(LatticeTest, PositiveElementsFillTheBox) {
  const LatticeOptions o = Options();
  const TetMesh mesh = MakeLatticeMesh(o);
  const double h3 = o.spacing * o.spacing * o.spacing;
  // Kuhn elements all have volume h^3/6; BCC elements (interior and boundary) h^3/12.
  const double expected = o.type == LatticeType::kKuhn ? h3 / 6 : h3 / 12;
  for (int t = 0; t < mesh.num_tets(); ++t) {
    EXPECT_NEAR(SignedTetVolume(mesh, mesh.vertices, t), expected, 1e-14) << "element " << t;
  }
  EXPECT_NEAR(testing::TotalSignedVolume(mesh), o.nx * o.ny * o.nz * h3, 1e-12);
  std::string error;
  EXPECT_TRUE(ValidateTetMesh(mesh, "lattice", &error)) << error;
}

TEST_P(LatticeTest, ConformingBoundaryIsTheBoxSurface) {
  const LatticeOptions o = Options();
  const TetMesh mesh = MakeLatticeMesh(o);
  const BoundarySurface boundary = ExtractBoundarySurface(mesh);
  const Eigen::Vector3d lo = o.origin;
  const Eigen::Vector3d hi = o.origin + o.spacing * Eigen::Vector3d(o.nx, o.ny, o.nz);
  double area = 0;
  for (int t = 0; t < boundary.triangles.cols(); ++t) {
    const Eigen::Vector3d x0 = mesh.vertices.col(boundary.triangles(0, t));
    const Eigen::Vector3d x1 = mesh.vertices.col(boundary.triangles(1, t));
    const Eigen::Vector3d x2 = mesh.vertices.col(boundary.triangles(2, t));
    area += 0.5 * (x1 - x0).cross(x2 - x0).norm();
    // All three corners on one outer face of the box: no interior face is exposed.
    bool on_outer_face = false;
    for (int axis = 0; axis < 3; ++axis) {
      for (double plane : {lo[axis], hi[axis]}) {
        if (std::abs(x0[axis] - plane) < 1e-12 && std::abs(x1[axis] - plane) < 1e-12 &&
            std::abs(x2[axis] - plane) < 1e-12) {
          on_outer_face = true;
        }
      }
    }
    EXPECT_TRUE(on_outer_face) << "boundary triangle " << t << " is inside the box";
  }
  const Eigen::Vector3d size = hi - lo;
  EXPECT_NEAR(area, 2 * (size.x() * size.y() + size.y() * size.z() + size.x() * size.z()), 1e-12);
  EXPECT_EQ(boundary.triangles.cols(), 2 * 2 * (o.nx * o.ny + o.ny * o.nz + o.nx * o.nz));
}

INSTANTIATE_TEST_SUITE_P(Lattices, LatticeTest,
                         ::testing::Values(LatticeCase{LatticeType::kKuhn, 1, 1, 1},
                                           LatticeCase{LatticeType::kKuhn, 3, 2, 4},
                                           LatticeCase{LatticeType::kBcc, 1, 1, 1},
                                           LatticeCase{LatticeType::kBcc, 3, 2, 4},
                                           LatticeCase{LatticeType::kBcc, 1, 1, 3}),
                         [](const ::testing::TestParamInfo<LatticeCase>& info) {
                           return std::string(info.param.type == LatticeType::kKuhn ? "Kuhn"
                                                                                    : "Bcc") +
                                  std::to_string(info.param.nx) + "x" +
                                  std::to_string(info.param.ny) + "x" +
                                  std::to_string(info.param.nz);
                         });

TEST(LatticeDefaultsTest, DefaultIsOneUnitKuhnCube) {
  const TetMesh mesh = MakeLatticeMesh(LatticeOptions());
  EXPECT_EQ(mesh.num_vertices(), 8);
  EXPECT_EQ(mesh.num_tets(), 6);
  EXPECT_DOUBLE_EQ(testing::TotalSignedVolume(mesh), 1.0);
}

TEST(LatticeDefaultsTest, ValidateNamesTheBadField) {
  std::string error;
  EXPECT_TRUE(LatticeOptions().Validate(&error)) << error;
  LatticeOptions options;
  options.ny = 0;
  EXPECT_FALSE(options.Validate(&error));
  EXPECT_EQ(error.rfind("the lattice's cube counts must be >= 1", 0), 0u) << error;
  options = LatticeOptions();
  options.spacing = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(options.Validate(&error));
  EXPECT_EQ(error.rfind("the lattice's spacing must be finite and > 0", 0), 0u) << error;
  for (const double spacing : {1e-110, 1e200}) {  // spacing^3 is 0 or inf
    options = LatticeOptions();
    options.spacing = spacing;
    EXPECT_FALSE(options.Validate(&error)) << spacing;
    EXPECT_NE(error.find("is beyond what doubles can hold of an element's volume"),
              std::string::npos)
        << error;
  }
  for (const double spacing : {1e-100, 1e100}) {
    options = LatticeOptions();
    options.spacing = spacing;
    EXPECT_TRUE(options.Validate(&error)) << error;
  }
  options = LatticeOptions();
  options.origin.x() = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(options.Validate(&error));
  EXPECT_EQ(error, "the lattice's origin must be finite");
  options = LatticeOptions();
  options.nx = options.ny = options.nz = 1000;
  EXPECT_FALSE(options.Validate(&error));
  EXPECT_NE(error.find("cubes is too large"), std::string::npos) << error;
}

}  // namespace
}  // namespace aqs
