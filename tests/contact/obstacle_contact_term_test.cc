#include "contact/obstacle_contact_term.h"

#include <memory>
#include <vector>

#include <ceres/cost_function.h>
#include <ceres/gradient_checker.h>
#include <gtest/gtest.h>

#include "testing/contact_scenes.h"
#include "testing/energy_term_checks.h"
#include "testing/finite_difference.h"
#include "testing/gradient_check.h"

namespace aqs {
namespace {

using testing::BoxSurface;
using testing::DenseStiffness;
using testing::DifferencedHessian;
using testing::Stencil;

TEST(ObstacleContactTermTest, ResidualJacobianAndEnergyGradient) {
  Eigen::Matrix3Xd v;
  Eigen::Matrix3Xi t;
  BoxSurface(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(2, 1, 1), &v, &t);
  const Obstacle box("box", v, t);
  // A point inside the box (penetrating) and one just outside within the thickness.
  const std::vector<PointStencil> points = {Stencil(0, Eigen::Vector4d(0.1, 0.2, 0.3, 0.4)),
                                            Stencil(4, Eigen::Vector4d(0.25, 0.25, 0.25, 0.25))};
  const ObstacleContactTerm term(points, Eigen::Vector2d(3.0, 2.0), 0.1, {&box});
  Eigen::Matrix3Xd x(3, 8);
  x << 0.5, 0.6, 0.4, 0.5, 1.0, 1.1, 1.0, 0.9,  //
      0.8, 0.9, 0.7, 0.85, 1.02, 1.06, 1.04, 1.05,  //
      0.4, 0.5, 0.6, 0.3, 0.5, 0.4, 0.6, 0.5;
  for (int i = 0; i < 2; ++i) {
    std::unique_ptr<ceres::CostFunction> cost(term.NewCostFunction(i));
    const double* parameters[4];
    for (int j = 0; j < 4; ++j) parameters[j] = x.col(points[i].vertex[j]).data();
    double r = 0;
    ASSERT_TRUE(cost->Evaluate(parameters, &r, nullptr));
    EXPECT_GT(r, 0.0) << "point " << i << " is in contact";
    ceres::GradientChecker::ProbeResults results;
    testing::ProbeJacobians(*cost, parameters, 1e-7, &results, testing::RiddersFrom(1e-4));
    EXPECT_LT(testing::MaxBlockError(results, 1e-10), 1e-6) << results.error_log;
  }
  auto energy = [&](const Eigen::VectorXd& flat) {
    Eigen::Matrix3Xd g = Eigen::Matrix3Xd::Zero(3, 8);
    return term.AddEnergyAndGradient(Eigen::Map<const Eigen::Matrix3Xd>(flat.data(), 3, 8), &g);
  };
  Eigen::Matrix3Xd gradient = Eigen::Matrix3Xd::Zero(3, 8);
  term.AddEnergyAndGradient(x, &gradient);
  EXPECT_LT(testing::RelativeError(
                Eigen::Map<const Eigen::VectorXd>(gradient.data(), 24),
                testing::CentralDifferenceGradient(
                    energy, Eigen::Map<const Eigen::VectorXd>(x.data(), 24), 1e-6)),
            1e-7);
  // The stiffness (Gauss-Newton part, exact here: both closest features are faces).
  Eigen::Matrix4Xi tets(4, 2);
  tets << 0, 4, 1, 5, 2, 6, 3, 7;
  EXPECT_LT(testing::RelativeError(DenseStiffness(term, x, tets), DifferencedHessian(term, x)),
            1e-6);
}

}  // namespace
}  // namespace aqs
