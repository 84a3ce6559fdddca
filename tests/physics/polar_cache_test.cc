#include "physics/polar_cache.h"

#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "diff/actuation_force_products.h"
#include "physics/boundary_conditions.h"
#include "physics/shape_target_model.h"
#include "physics/stiffness_assembly.h"
#include "sparse/stiffness_pattern.h"
#include "testing/test_meshes.h"

namespace aqs {
namespace {

// A deformed, actuated bar: random positions near rest and random symmetric targets.
struct CacheScene {
  TetMesh mesh = testing::BarMesh(4, 2, 2, 1.0);
  ShapeTargetModel model{mesh, 1.5};
  Eigen::Matrix3Xd x;
  ActuationMatrix a;
  CacheScene() {
    std::mt19937 rng(3);
    std::normal_distribution<double> normal;
    x = mesh.vertices;
    for (Eigen::Index i = 0; i < x.size(); ++i) x.data()[i] += 0.1 * normal(rng);
    a = IdentityActuations(mesh.num_tets());
    for (Eigen::Index i = 0; i < a.size(); ++i) a.data()[i] += 0.2 * normal(rng);
  }
};

TEST(PolarCacheTest, CachedEvaluationsEqualUncachedBitForBit) {
  CacheScene scene;
  const ShapeTargetModel& model = scene.model;
  const StiffnessPattern pattern(scene.mesh.tets,
                                 FixedVertexMask(testing::LeftFaceFixed(scene.mesh),
                                                 scene.mesh.num_vertices()));
  PolarCache cache;
  EXPECT_FALSE(cache.Matches(scene.x, scene.a));
  Eigen::Matrix3Xd plain_gradient, filled_gradient, read_gradient;
  const double plain = model.EnergyAndGradient(scene.x, scene.a, &plain_gradient, 2);
  const double filled = model.EnergyAndGradient(scene.x, scene.a, &filled_gradient, 2, &cache);
  ASSERT_TRUE(cache.Matches(scene.x, scene.a));
  const double read = model.EnergyAndGradient(scene.x, scene.a, &read_gradient, 2, &cache);
  EXPECT_EQ(plain, filled);
  EXPECT_EQ(plain, read);
  EXPECT_EQ((plain_gradient - filled_gradient).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ((plain_gradient - read_gradient).cwiseAbs().maxCoeff(), 0.0);
  for (StiffnessKind kind : {StiffnessKind::kExact, StiffnessKind::kProjected}) {
    std::vector<double> without, with;
    AssembleStiffness(model, pattern, scene.x, scene.a, kind, 2, &without);
    AssembleStiffness(model, pattern, scene.x, scene.a, kind, 2, &with, &cache);
    EXPECT_EQ(without, with);
  }
  const Eigen::MatrixXd directions = Eigen::MatrixXd::Random(6 * model.num_elements(), 2);
  EXPECT_EQ(ActuationForceProducts(model, pattern, scene.x, scene.a, directions, 2),
            ActuationForceProducts(model, pattern, scene.x, scene.a, directions, 2, &cache));
}

TEST(PolarCacheTest, AnyChangeOfTheStateMissesAndRefills) {
  CacheScene scene;
  PolarCache cache;
  Eigen::Matrix3Xd gradient;
  scene.model.EnergyAndGradient(scene.x, scene.a, &gradient, 1, &cache);
  ASSERT_TRUE(cache.Matches(scene.x, scene.a));
  // One bit of one coordinate, or of one actuation number.
  Eigen::Matrix3Xd moved = scene.x;
  moved(1, 7) = std::nextafter(moved(1, 7), 10.0);
  EXPECT_FALSE(cache.Matches(moved, scene.a));
  ActuationMatrix changed = scene.a;
  changed(4, changed.cols() - 1) = std::nextafter(changed(4, changed.cols() - 1), 10.0);
  EXPECT_FALSE(cache.Matches(scene.x, changed));
  // A stale cache is refilled, never read: the moved state's energy is its own.
  Eigen::Matrix3Xd plain_gradient, cached_gradient;
  const double plain = scene.model.EnergyAndGradient(moved, scene.a, &plain_gradient, 1);
  const double cached = scene.model.EnergyAndGradient(moved, scene.a, &cached_gradient, 1, &cache);
  EXPECT_EQ(plain, cached);
  EXPECT_EQ(plain_gradient, cached_gradient);
  EXPECT_TRUE(cache.Matches(moved, scene.a));
  EXPECT_FALSE(cache.Matches(scene.x, scene.a));
  // Begun but not finished: matches nothing. Cleared: likewise.
  cache.Begin(scene.x, scene.a, scene.model.num_elements());
  EXPECT_FALSE(cache.Matches(scene.x, scene.a));
  cache.Finish();
  cache.Clear();
  EXPECT_FALSE(cache.Matches(scene.x, scene.a));
}

}  // namespace
}  // namespace aqs
