#include "geometry/winding_number.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "geometry/triangle_bvh.h"
#include "mesh/boundary_surface.h"
#include "mesh/lattice.h"
#include "testing/test_surfaces.h"

namespace aqs {
namespace {

TEST(TriangleSolidAngleTest, KnownAngles) {
  const Eigen::Vector3d ex(1, 0, 0), ey(0, 1, 0), ez(0, 0, 1);
  // An octant: 4 pi / 8, positive from behind the right-hand normal (1,1,1) direction.
  EXPECT_NEAR(TriangleSolidAngle(Eigen::Vector3d::Zero(), ex, ey, ez), M_PI / 2, 1e-14);
  EXPECT_NEAR(TriangleSolidAngle(Eigen::Vector3d::Zero(), ex, ez, ey), -M_PI / 2, 1e-14);
  // In the plane of the triangle, and a degenerate triangle: 0.
  EXPECT_EQ(TriangleSolidAngle(Eigen::Vector3d(3, 3, 0), Eigen::Vector3d::Zero(), ex, ey), 0.0);
  EXPECT_EQ(TriangleSolidAngle(ez, Eigen::Vector3d::Zero(), ex, 2 * ex), 0.0);
  // Far away: about area / r^2.
  const double r = 1e3;
  EXPECT_NEAR(TriangleSolidAngle(Eigen::Vector3d(0, 0, -r), Eigen::Vector3d::Zero(), ex, ey),
              0.5 / (r * r), 1e-5 * 0.5 / (r * r));
  // Just below the middle of a large triangle: nearly a hemisphere.
  EXPECT_NEAR(TriangleSolidAngle(Eigen::Vector3d(1, 1, -1e-9), Eigen::Vector3d(-1e4, -1e4, 0),
                                 Eigen::Vector3d(1e4, -1e4, 0), Eigen::Vector3d(0, 1e4, 0)),
              2 * M_PI, 1e-3);
}

// Points at the given distances from the origin in random directions.
Eigen::Matrix3Xd RandomPointsAtRadii(int count, double min_radius, double max_radius,
                                     std::mt19937* rng) {
  std::normal_distribution<double> normal;
  std::uniform_real_distribution<double> uniform(min_radius, max_radius);
  Eigen::Matrix3Xd points(3, count);
  for (int i = 0; i < count; ++i) {
    const Eigen::Vector3d direction =
        Eigen::Vector3d(normal(*rng), normal(*rng), normal(*rng)).normalized();
    points.col(i) = uniform(*rng) * direction;
  }
  return points;
}

TEST(WindingNumberTest, ClosedIcosphereIsOneInsideZeroOutside) {
  const SurfaceMesh sphere = testing::Icosphere(3, 1.0);
  ASSERT_GT(testing::EnclosedVolume(sphere.vertices, sphere.triangles), 0);
  std::mt19937 rng(1);
  const Eigen::Matrix3Xd inside = RandomPointsAtRadii(200, 0.0, 0.9, &rng);
  const Eigen::Matrix3Xd outside = RandomPointsAtRadii(200, 1.1, 5.0, &rng);
  const FastWindingNumber fast(sphere.vertices, sphere.triangles);
  const Eigen::VectorXd exact_in =
      ExactWindingNumbers(sphere.vertices, sphere.triangles, inside, 2);
  const Eigen::VectorXd exact_out =
      ExactWindingNumbers(sphere.vertices, sphere.triangles, outside, 2);
  const Eigen::VectorXd fast_in = fast.WindingNumbers(inside, 2);
  const Eigen::VectorXd fast_out = fast.WindingNumbers(outside, 2);
  EXPECT_LT((exact_in.array() - 1).abs().maxCoeff(), 1e-10);
  EXPECT_LT(exact_out.array().abs().maxCoeff(), 1e-10);
  // The default far field (beta 2, second order) is within a few 1e-3 (see
  // FastMatchesExactAwayFromTheSurface).
  EXPECT_LT((fast_in.array() - 1).abs().maxCoeff(), 1e-2);
  EXPECT_LT(fast_out.array().abs().maxCoeff(), 1e-2);
  EXPECT_NEAR(ExactWindingNumber(sphere.vertices, sphere.triangles, inside.col(0)), exact_in(0),
              1e-15);
  // Reversed orientation: -1 inside.
  Eigen::Matrix3Xi reversed = sphere.triangles;
  reversed.row(1).swap(reversed.row(2));
  EXPECT_NEAR(FastWindingNumber(sphere.vertices, reversed).WindingNumber(Eigen::Vector3d::Zero()),
              -1.0, 1e-2);
}

TEST(WindingNumberTest, LatticeBoundarySurface) {
  for (LatticeType type : {LatticeType::kKuhn, LatticeType::kBcc}) {
    LatticeOptions options;
    options.type = type;
    options.nx = 3;
    options.ny = 2;
    options.nz = 4;
    options.spacing = 0.5;
    options.origin = Eigen::Vector3d(-1, 0.25, 2);
    const TetMesh lattice = MakeLatticeMesh(options);
    const SurfaceMesh surface =
        BoundaryToSurface(ExtractBoundarySurface(lattice), lattice.vertices);
    Eigen::Matrix3Xd centroids(3, lattice.num_tets());
    for (int t = 0; t < lattice.num_tets(); ++t) {
      centroids.col(t) =
          (lattice.vertices.col(lattice.tets(0, t)) + lattice.vertices.col(lattice.tets(1, t)) +
           lattice.vertices.col(lattice.tets(2, t)) + lattice.vertices.col(lattice.tets(3, t))) /
          4.0;
    }
    // Outside: the box's vertices pushed out along the diagonal, and far points.
    Eigen::Matrix3Xd outside(3, 4);
    outside << -1.1, 0.6, 10, -1.1,  //
        0.1, 1.3, 0, 1.0,            //
        1.9, 4.1, 0, 3.0;
    const FastWindingNumber fast(surface.vertices, surface.triangles);
    const Eigen::VectorXd inside_w = fast.WindingNumbers(centroids, 2);
    const Eigen::VectorXd outside_w = fast.WindingNumbers(outside, 1);
    EXPECT_LT((inside_w.array() - 1).abs().maxCoeff(), 1e-2);
    EXPECT_LT(outside_w.array().abs().maxCoeff(), 1e-2);
    const Eigen::VectorXd exact =
        ExactWindingNumbers(surface.vertices, surface.triangles, centroids, 2);
    EXPECT_LT((exact.array() - 1).abs().maxCoeff(), 1e-10);
  }
}

TEST(WindingNumberTest, SphereWithHolesStillSeparatesInsideAndOutside) {
  const SurfaceMesh sphere = testing::Icosphere(3, 1.0);
  // Remove a few triangles in different places (about 1% of the surface).
  const Eigen::Matrix3Xi open =
      testing::RemoveTriangles(sphere.triangles, {0, 1, 2, 300, 301, 700, 1000, 1279});
  std::mt19937 rng(2);
  const Eigen::Matrix3Xd inside = RandomPointsAtRadii(300, 0.0, 0.5, &rng);
  const Eigen::Matrix3Xd outside = RandomPointsAtRadii(300, 2.0, 4.0, &rng);
  const FastWindingNumber fast(sphere.vertices, open);
  const Eigen::VectorXd inside_w = fast.WindingNumbers(inside, 2);
  const Eigen::VectorXd outside_w = fast.WindingNumbers(outside, 2);
  EXPECT_GT(inside_w.minCoeff(), 0.5);
  EXPECT_LT(outside_w.maxCoeff(), 0.5);
  EXPECT_GT(inside_w.minCoeff(), 0.9);
  EXPECT_LT(outside_w.array().abs().maxCoeff(), 0.1);
  // Across a hole the value is about 1/2: the centroid of a removed triangle.
  const Eigen::Vector3d hole = (sphere.vertices.col(sphere.triangles(0, 300)) +
                                sphere.vertices.col(sphere.triangles(1, 300)) +
                                sphere.vertices.col(sphere.triangles(2, 300))) /
                               3.0;
  EXPECT_NEAR(fast.WindingNumber(hole), 0.5, 0.05);
}

TEST(WindingNumberTest, FastMatchesExactAwayFromTheSurface) {
  // A bumpy open surface with several tree levels: a sphere with holes, radially perturbed.
  SurfaceMesh sphere = testing::Icosphere(4, 1.0);
  for (int v = 0; v < sphere.num_vertices(); ++v) {
    const Eigen::Vector3d p = sphere.vertices.col(v);
    sphere.vertices.col(v) *= 1.0 + 0.15 * std::sin(5 * p(0)) * std::cos(4 * p(1) + p(2));
  }
  std::vector<int> removed;
  for (int t = 0; t < sphere.num_triangles(); t += 97) removed.push_back(t);
  const Eigen::Matrix3Xi open = testing::RemoveTriangles(sphere.triangles, removed);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> uniform(-1.6, 1.6);
  const TriangleBvh bvh(sphere.vertices, open);
  Eigen::Matrix3Xd points(3, 1500);
  for (int i = 0; i < points.cols();) {
    const Eigen::Vector3d p(uniform(rng), uniform(rng), uniform(rng));
    if (bvh.ClosestPoint(p, 0.02).triangle >= 0) continue;  // keep 0.02 away
    points.col(i++) = p;
  }
  const Eigen::VectorXd exact = ExactWindingNumbers(sphere.vertices, open, points, 2);
  // Largest and mean error of each expansion order at beta 2 and 3.
  double largest[2][3], mean[2][3];
  for (int b = 0; b < 2; ++b) {
    for (int order = 0; order <= 2; ++order) {
      FastWindingNumberOptions options;
      options.beta = b == 0 ? 2.0 : 3.0;
      options.expansion_order = order;
      const FastWindingNumber fast(sphere.vertices, open, options);
      const Eigen::VectorXd error = (fast.WindingNumbers(points, 2) - exact).cwiseAbs();
      largest[b][order] = error.maxCoeff();
      mean[b][order] = error.mean();
      std::printf(
          "fast winding numbers at %d points, %d triangles, beta %g, order %d: largest "
          "error %.2e, mean %.2e\n",
          static_cast<int>(points.cols()), static_cast<int>(open.cols()), options.beta, order,
          largest[b][order], mean[b][order]);
    }
  }
  // Defaults (beta 2, order 2): a few 1e-3 at worst, 1e-3 on average; beta 3: 1e-3 at worst.
  EXPECT_LT(largest[0][2], 1e-2);
  EXPECT_LT(mean[0][2], 1e-3);
  EXPECT_LT(largest[1][2], 1e-3);
  // Higher orders and larger beta are more accurate.
  for (int b = 0; b < 2; ++b) EXPECT_LT(largest[b][2], 0.2 * largest[b][0]);
  for (int order = 0; order <= 2; ++order) EXPECT_LT(mean[1][order], mean[0][order]);
}

TEST(WindingNumberTest, BatchMatchesSingleAndEmptySurfaceIsZero) {
  const SurfaceMesh sphere = testing::Icosphere(2, 1.0);
  const FastWindingNumber fast(sphere.vertices, sphere.triangles);
  EXPECT_EQ(fast.num_triangles(), sphere.num_triangles());
  std::mt19937 rng(4);
  const Eigen::Matrix3Xd points = RandomPointsAtRadii(500, 0.0, 3.0, &rng);
  const Eigen::VectorXd one = fast.WindingNumbers(points, 1);
  const Eigen::VectorXd two = fast.WindingNumbers(points, 2);
  for (int i = 0; i < points.cols(); ++i) {
    EXPECT_EQ(one(i), two(i));
    EXPECT_EQ(one(i), fast.WindingNumber(points.col(i)));
  }
  const FastWindingNumber empty(Eigen::Matrix3Xd(3, 0), Eigen::Matrix3Xi(3, 0));
  EXPECT_EQ(empty.WindingNumber(Eigen::Vector3d::Zero()), 0.0);
  EXPECT_EQ(ExactWindingNumbers(Eigen::Matrix3Xd(3, 0), Eigen::Matrix3Xi(3, 0), points, 2)
                .cwiseAbs()
                .maxCoeff(),
            0.0);
}

TEST(WindingNumberTest, OptionsNameTheBadField) {
  std::string error;
  FastWindingNumberOptions options;
  EXPECT_TRUE(options.Validate(&error)) << error;
  options.expansion_order = 3;
  EXPECT_FALSE(options.Validate(&error));
  EXPECT_EQ(error.rfind("expansion_order", 0), 0u) << error;
  options = FastWindingNumberOptions();
  options.beta = 0.0;
  EXPECT_FALSE(options.Validate(&error));
  EXPECT_EQ(error.rfind("beta", 0), 0u) << error;
  options = FastWindingNumberOptions();
  options.leaf_size = 0;
  EXPECT_FALSE(options.Validate(&error));
  EXPECT_EQ(error.rfind("leaf_size", 0), 0u) << error;
}

}  // namespace
}  // namespace aqs
