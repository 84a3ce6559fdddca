#include "fit/latent_fit.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <random>
#include <sstream>

#include <ceres/cost_function.h>
#include <ceres/gradient_checker.h>
#include <ceres/manifold.h>
#include <Eigen/Eigenvalues>
#include <gtest/gtest.h>

#include "fit/bone_parameters.h"
#include "fit/fit_target.h"
#include "fit/point_cloud_matching.h"
#include "geometry/embedding.h"
#include "geometry/triangle_bvh.h"
#include "prepare/volumetric_targets.h"
#include "testing/finite_difference.h"
#include "testing/fit_fixtures.h"
#include "testing/gradient_check.h"
#include "testing/synthetic_muscles.h"
#include "train/pretrain.h"
#include "train/trainer.h"

namespace aqs {
namespace {

ActiveModel TrainedModel(bool with_bone) { return testing::PretrainedBarForFits(with_bone); }

// The correspondence cost's Jacobians (latent and bone blocks) against Ridders'
// differences of re-solved equilibria: point-to-point, point-to-plane with normals as
// scans use, and with unequal weights; at a training latent with a small bone motion,
// and off the training latents with a large one (0.7 rad, translations of 0.1); and,
// without bones fitted, the latent block alone.
TEST(LatentFitTest, CostJacobianPassesGradientChecker) {
  const ActiveModel model = TrainedModel(true);
  // Targets: a few vertices at some positions (their values do not matter for the check).
  std::vector<int> vertices = {3, 20, 41, 57, 77};
  Eigen::Matrix3Xd positions = model.neutral.vertices(Eigen::all, vertices);
  const FitTarget target = VertexTarget(vertices, positions);
  FitTarget plane_target = target;
  plane_target.normals = Eigen::Matrix3Xd::Random(3, 5).colwise().normalized();
  plane_target.tangential_weight = 0.2;
  FitTarget weighted_target = plane_target;
  weighted_target.weights.resize(5);
  weighted_target.weights << 0.2, 1.0, 3.0, 0.5, 1.7;
  struct State {
    std::string name;
    Eigen::VectorXd z;
    std::vector<double> bone;
  };
  std::mt19937 rng(71);
  std::normal_distribution<double> normal(0.0, 0.3);
  Eigen::VectorXd off_training = model.latents.col(model.num_poses() - 1);
  for (Eigen::Index i = 0; i < off_training.size(); ++i) off_training[i] += normal(rng);
  const std::vector<State> states = {
      {"training latent, small bone motion", model.latents.col(2),
       {0.05, -0.03, 0.02, 0.01, 0.02, -0.01}},
      {"off the training latents, large bone motion", off_training,
       {0.5, -0.4, 0.3, 0.1, 0.0, -0.05}}};
  for (const bool fit_bones : {true, false}) {
    LatentFitOptions options;
    options.solver.relative_force_tolerance = 1e-12;  // Newton reaches round-off
    options.fit_bones = fit_bones;
    LatentFitter fitter(model, options);
    const int blocks = fit_bones ? 2 : 1;
    for (const State& state : states) {
      if (!fit_bones && state.name != states[0].name) continue;
      for (const FitTarget* checked :
           std::vector<const FitTarget*>{&target, &plane_target, &weighted_target}) {
        SCOPED_TRACE(state.name + (fit_bones ? "" : ", bones not fitted") + ", target " +
                     std::to_string(checked == &target ? 0 : checked == &plane_target ? 1 : 2));
        std::unique_ptr<ceres::CostFunction> cost(fitter.NewCostFunction(*checked));
        ASSERT_EQ(static_cast<int>(cost->parameter_block_sizes().size()), blocks);
        std::vector<double> bone = state.bone;
        const double* parameters[2] = {state.z.data(), bone.data()};
        ceres::NumericDiffOptions numeric_options;
        numeric_options.ridders_relative_initial_step_size = 1e-3;
        const std::vector<const ceres::Manifold*>* no_manifolds = nullptr;
        ceres::GradientChecker checker(cost.get(), no_manifolds, numeric_options);
        ceres::GradientChecker::ProbeResults results;
        checker.Probe(parameters, 1e-6, &results);
        // Entry-wise relative errors flag exact zeros (rigid translations leave some
        // residual components unchanged): compare each block relative to its largest
        // entry instead.
        ASSERT_EQ(static_cast<int>(results.jacobians.size()), blocks);
        for (int block = 0; block < blocks; ++block) {
          EXPECT_LT(
              testing::RelativeError(results.jacobians[block], results.numeric_jacobians[block]),
              1e-6)
              << "block " << block << "\n"
              << results.error_log;
        }
      }
    }
  }
}

TEST(LatentFitTest, CloudCostJacobianPassesGradientChecker) {
  // The re-matched robust closest-point distances of a scan, with points off a deformed
  // surface in every regime of the residual: outside within the robust scale s = 0.03,
  // on the surface (u = n), inside (the sign flips), beyond s, beyond max_distance (a
  // constant residual: zero rows), and off convex edges and corners of the bar (closest
  // point on an edge or a vertex).
  const ActiveModel model = TrainedModel(true);
  LatentFitOptions options;
  options.solver.relative_force_tolerance = 1e-12;
  LatentFitter fitter(model, options);
  // The surface at the probed parameters, so that the points sit where intended.
  Eigen::VectorXd z = model.latents.col(2);
  double bone[6] = {0.02, -0.01, 0.01, 0.01, 0.0, -0.01};
  fitter.set_bone_transforms({BoneTransformFromParameters(bone)});
  Eigen::Matrix3Xd state, surface;
  std::string error;
  ASSERT_TRUE(fitter.Simulate(z, &state, &surface, &error)) << error;
  const Eigen::Matrix3Xi& triangles = model.neutral.triangles;
  const int num_triangles = static_cast<int>(triangles.cols());
  auto normal = [&](const Eigen::Matrix3Xd& v, int t) {
    const Eigen::Vector3d a = v.col(triangles(0, t));
    return Eigen::Vector3d(
        (v.col(triangles(1, t)) - a).cross(v.col(triangles(2, t)) - a).normalized());
  };
  const TriangleBvh bvh(surface, triangles);
  // Points of one kind, each with the surface point it should be matched to.
  struct Group {
    std::string name;
    std::vector<Eigen::Vector3d> points, closest;
  };
  std::vector<Group> groups(7);
  // Off triangle interiors along their normals at signed offsets (generic points: a
  // unique closest point inside the triangle, at least 1e-2 from its edges in barycentric
  // terms, which the differencing steps do not cross).
  auto off_faces = [&](Group* group, int count, int stride, int first, double lo, double hi) {
    for (int i = 0; static_cast<int>(group->points.size()) < count && i < 10 * count; ++i) {
      const int t = (stride * i + first) % num_triangles;
      const Eigen::Vector3d a = surface.col(triangles(0, t)), b = surface.col(triangles(1, t));
      const Eigen::Vector3d on = (a + b + 2 * surface.col(triangles(2, t))) / 4;
      const double offset = lo + (hi - lo) * (i % 7) / 6.0;
      const Eigen::Vector3d p = on + offset * normal(surface, t);
      const ClosestPointResult c = bvh.ClosestPoint(p);
      // Inside, a point deeper than its distance to a neighbouring face is closer to that
      // face: keep only points whose closest point is where they were put.
      if ((c.point - on).norm() > 1e-12 || c.barycentric.minCoeff() < 1e-2) continue;
      group->points.push_back(p);
      group->closest.push_back(on);
    }
  };
  groups[0].name = "outside, 0.005 to 0.02 (within s)";
  off_faces(&groups[0], 40, 7, 0, 0.005, 0.02);
  groups[1].name = "on the surface";
  off_faces(&groups[1], 3, 11, 5, 0.0, 0.0);
  groups[2].name = "inside, 0.005 to 0.02";
  off_faces(&groups[2], 8, 13, 3, -0.02, -0.005);
  groups[3].name = "outside and inside, 0.05 to 0.1 (beyond s)";
  off_faces(&groups[3], 6, 17, 1, 0.05, 0.1);
  off_faces(&groups[3], 10, 19, 2, -0.1, -0.05);
  groups[4].name = "outside, 0.3 to 0.5 (beyond max_distance 0.2)";
  off_faces(&groups[4], 4, 23, 4, 0.3, 0.5);
  // Off the bar's convex edges and corners, found at rest (where its faces are
  // axis-aligned): along the sum of the adjacent triangles' normals at the probed state,
  // inside the normal cone of the edge or corner.
  groups[5].name = "off edges (closest point mid-edge)";
  groups[6].name = "off corners (closest point a vertex)";
  const Eigen::Matrix3Xd& rest = model.neutral.vertices;
  std::map<std::pair<int, int>, std::vector<int>> edge_triangles;
  std::vector<std::vector<int>> vertex_triangles(rest.cols());
  for (int t = 0; t < num_triangles; ++t) {
    for (int k = 0; k < 3; ++k) {
      const int a = triangles(k, t), b = triangles((k + 1) % 3, t);
      edge_triangles[{std::min(a, b), std::max(a, b)}].push_back(t);
      vertex_triangles[a].push_back(t);
    }
  }
  int edge_count = 0;
  for (const auto& [edge, adjacent] : edge_triangles) {
    ASSERT_EQ(adjacent.size(), 2u);
    if (normal(rest, adjacent[0]).dot(normal(rest, adjacent[1])) > 0.5) continue;  // not a bar edge
    if (edge_count++ % 3 != 0) continue;  // every third of them
    const Eigen::Vector3d mid = (surface.col(edge.first) + surface.col(edge.second)) / 2;
    const Eigen::Vector3d direction =
        (normal(surface, adjacent[0]) + normal(surface, adjacent[1])).normalized();
    groups[5].points.push_back(mid + (0.01 + 0.01 * (edge_count % 6)) * direction);
    groups[5].closest.push_back(mid);
  }
  for (int v = 0; v < rest.cols(); ++v) {
    if (vertex_triangles[v].empty()) continue;
    std::vector<Eigen::Vector3d> directions;  // distinct rest normals
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (int t : vertex_triangles[v]) {
      const Eigen::Vector3d n = normal(rest, t);
      bool seen = false;
      for (const Eigen::Vector3d& m : directions) seen = seen || n.dot(m) > 0.5;
      if (!seen) directions.push_back(n);
      sum += normal(surface, t);
    }
    if (directions.size() < 3) continue;  // not a corner
    groups[6].points.push_back(surface.col(v) + (0.01 + 0.01 * (v % 6)) * sum.normalized());
    groups[6].closest.push_back(surface.col(v));
  }
  // 56 mesh edges lie on the bar's 12 edges (10 x 2 x 2 cells).
  const int expected_counts[] = {40, 3, 8, 10, 4, 19, 8};
  std::vector<Eigen::Vector3d> all;
  for (int g = 0; g < 7; ++g) {
    SCOPED_TRACE(groups[g].name);
    ASSERT_EQ(static_cast<int>(groups[g].points.size()), expected_counts[g]);
    for (size_t i = 0; i < groups[g].points.size(); ++i) {
      // The closest point is the intended one (on an edge: one barycentric weight 0; at
      // a corner: one weight 1).
      const ClosestPointResult c = bvh.ClosestPoint(groups[g].points[i]);
      EXPECT_LT((c.point - groups[g].closest[i]).norm(), 1e-12) << "point " << i;
      if (g == 5) {  // mid-edge
        EXPECT_EQ((c.barycentric.array() < 1e-12).count(), 1) << c.barycentric.transpose();
        EXPECT_NEAR(c.barycentric.maxCoeff(), 0.5, 1e-12);
      } else if (g == 6) {  // a vertex
        EXPECT_GT(c.barycentric.maxCoeff(), 1 - 1e-12);
      }
      all.push_back(groups[g].points[i]);
    }
  }
  Eigen::Matrix3Xd points(3, all.size());
  for (size_t i = 0; i < all.size(); ++i) points.col(i) = all[i];
  const int m = static_cast<int>(points.cols());
  PointCloudFitOptions cloud;
  cloud.robust_scale = 0.03;
  cloud.max_distance = 0.2;
  std::unique_ptr<ceres::CostFunction> cost(fitter.NewCloudCostFunction(points, cloud));
  ASSERT_EQ(cost->num_residuals(), m);
  const double* parameters[2] = {z.data(), bone};
  ceres::NumericDiffOptions numeric_options;
  // Ceres' Ridders starts at 2^5 times this step: 3.2e-3 (surface motion up to ~6e-3) keeps
  // the edge and corner points, 0.01 off, in their closest feature's region; 1e-3 (a first
  // step of 0.032) did not, and its extrapolation was then off by 4e-3 in the bone block.
  numeric_options.ridders_relative_initial_step_size = 1e-4;
  const std::vector<const ceres::Manifold*>* no_manifolds = nullptr;
  ceres::GradientChecker checker(cost.get(), no_manifolds, numeric_options);
  ceres::GradientChecker::ProbeResults results;
  checker.Probe(parameters, 1e-6, &results);
  ASSERT_EQ(results.jacobians.size(), 2u);
  // The residuals: sqrt(1/M) R(d), d < 0 outside, > 0 inside, capped beyond 0.2.
  const double scale = 1.0 / std::sqrt(static_cast<double>(m));
  for (int g = 0, row = 0; g < 7; ++g) {
    for (size_t i = 0; i < groups[g].points.size(); ++i, ++row) {
      const double r = results.residuals[row] / scale;
      if (g == 1) {
        EXPECT_LT(std::abs(r), 1e-12) << "row " << row;
      } else if (g == 2) {
        EXPECT_GT(r, 0.0) << "inside: row " << row;
      } else if (g == 0 || g == 5 || g == 6) {
        EXPECT_LT(r, 0.0) << "outside: row " << row;
      }
      if (g == 4) {
        EXPECT_NEAR(r, RobustDistance(-0.2, 0.03, nullptr), 1e-15) << "capped: row " << row;
        for (int block = 0; block < 2; ++block) {
          EXPECT_EQ(results.jacobians[block].row(row).cwiseAbs().maxCoeff(), 0.0) << "row " << row;
        }
      }
    }
  }
  // Each group relative to its own largest entry (the groups beyond s have smaller rows).
  // Measured: at most 1.2e-11.
  for (int block = 0; block < 2; ++block) {
    for (int g = 0, row = 0; g < 7; ++g) {
      const int k = static_cast<int>(groups[g].points.size());
      EXPECT_LT(testing::RelativeError(results.jacobians[block].middleRows(row, k),
                                       results.numeric_jacobians[block].middleRows(row, k)),
                1e-9)
          << "block " << block << ", " << groups[g].name << "\n"
          << results.error_log;
      row += k;
    }
  }
}

TEST(LatentFitTest, StandaloneCostIsAFunctionOfItsParameters) {
  // Without Ceres' evaluation callback (FitEquilibrium), no evaluation moves the start of
  // the next solve: neither a trial point's (no Jacobians) nor one with Jacobians. p1,
  // then a far p2 without and with Jacobians, then p1 again gives p1's residuals and
  // Jacobians bit for bit.
  const ActiveModel model = TrainedModel(true);
  LatentFitter fitter(model, LatentFitOptions());
  std::vector<int> vertices = {3, 20, 41, 57, 77};
  const FitTarget target = VertexTarget(vertices, model.neutral.vertices(Eigen::all, vertices));
  std::unique_ptr<ceres::CostFunction> cost(fitter.NewCostFunction(target));
  Eigen::VectorXd z1 = model.latents.col(2), z2 = model.latents.col(5);
  double bone1[6] = {0.05, -0.03, 0.02, 0.01, 0.02, -0.01}, bone2[6] = {-0.2, 0.1, 0.0, 0.1, 0, 0};
  const double* p1[2] = {z1.data(), bone1};
  const double* p2[2] = {z2.data(), bone2};
  const int n = cost->num_residuals();
  const int d = model.latent_dim();
  auto evaluate = [&](const double** p, Eigen::VectorXd* r, Eigen::MatrixXd* jz, Eigen::MatrixXd* jb) {
    r->resize(n);
    jz->resize(n, d);
    jb->resize(n, 6);
    // Row-major Jacobian blocks, as Ceres passes them.
    std::vector<double> z_rows(static_cast<size_t>(n) * d), bone_rows(static_cast<size_t>(n) * 6);
    double* jacobians[2] = {z_rows.data(), bone_rows.data()};
    if (!cost->Evaluate(p, r->data(), jacobians)) return false;
    *jz = Eigen::Map<Eigen::Matrix<double, -1, -1, Eigen::RowMajor>>(z_rows.data(), n, d);
    *jb = Eigen::Map<Eigen::Matrix<double, -1, -1, Eigen::RowMajor>>(bone_rows.data(), n, 6);
    return true;
  };
  Eigen::VectorXd r1, r2, r3;
  Eigen::MatrixXd jz1, jb1, jz2, jb2, jz3, jb3;
  ASSERT_TRUE(evaluate(p1, &r1, &jz1, &jb1));
  Eigen::VectorXd far(n), values_only(n);
  ASSERT_TRUE(cost->Evaluate(p2, far.data(), nullptr));
  ASSERT_TRUE(cost->Evaluate(p1, values_only.data(), nullptr));
  EXPECT_GT((far - r1).norm(), 1e-3);
  EXPECT_EQ((values_only - r1).cwiseAbs().maxCoeff(), 0.0);
  ASSERT_TRUE(evaluate(p2, &r2, &jz2, &jb2));
  ASSERT_TRUE(evaluate(p1, &r3, &jz3, &jb3));
  EXPECT_EQ((r2 - far).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ((r3 - r1).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ((jz3 - jz1).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ((jb3 - jb1).cwiseAbs().maxCoeff(), 0.0);
}

// Fits `model` (no priors) to the surface of the mean of training latents 1 and 4, from
// training latent 6: the data term's own optimum is that surface. Returns the fit's
// result in *fit and adds a failure where it is not reached.
void FitTheBlendOfTwoTrainingLatents(const ActiveModel& model, LatentFitResult* fit) {
  LatentFitOptions options;
  options.latent_prior = options.bone_prior = 0.0;
  options.solver.relative_force_tolerance = 1e-10;
  LatentFitter fitter(model, options);
  const Eigen::VectorXd truth = 0.5 * (model.latents.col(1) + model.latents.col(4));
  Eigen::Matrix3Xd state, surface;
  std::string error;
  ASSERT_TRUE(fitter.Simulate(truth, &state, &surface, &error)) << error;
  ASSERT_TRUE(fitter.Fit(FullSurfaceTarget(surface), model.latents.col(6), fit, &error)) << error;
  EXPECT_LT(fit->max_error, 1e-6) << fit->message;
  EXPECT_LT((fit->surface - surface).cwiseAbs().maxCoeff(), 1e-6);
}

TEST(LatentFitTest, RecoversAKnownLatentFromAnotherStart) {
  LatentFitResult fit;
  FitTheBlendOfTwoTrainingLatents(TrainedModel(false), &fit);
  EXPECT_EQ(fit.shifted_jacobians, 0);
}

// Bad target data returns false with a message (a NaN position "succeeded" with a NaN
// error; a vertex of another mesh aborted).
TEST(LatentFitTest, BadTargetDataIsRefusedNotFitted) {
  const ActiveModel model = TrainedModel(false);
  LatentFitter fitter(model, LatentFitOptions());
  FitTarget target = FullSurfaceTarget(model.poses[0].surface);
  target.positions(1, 5) = std::nan("");
  LatentFitResult result;
  std::string error;
  EXPECT_FALSE(fitter.Fit(target, model.latents.col(0), &result, &error));
  EXPECT_EQ(error, "fit target: point 5 has a non-finite position");
  target = VertexTarget({model.num_surface_vertices()}, Eigen::Matrix3Xd::Zero(3, 1));
  EXPECT_FALSE(fitter.Fit(target, model.latents.col(0), &result, &error));
  EXPECT_NE(error.find("not a surface vertex of the model"), std::string::npos) << error;
  Eigen::Matrix3Xd cloud = model.poses[0].surface;
  cloud(0, 7) = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(fitter.FitPointCloud(cloud, PointCloudFitOptions(), model.latents.col(0), &result,
                                    &error));
  EXPECT_EQ(error, "point 7 of the point cloud is not finite");
}

// A mesh piece that nothing holds and no surface vertex is embedded in makes the exact
// stiffness singular at every state. The fit's Jacobians then come from the
// regularized stiffness, as training's adjoints do (it failed at its first evaluation,
// saying only that the evaluation failed); the piece does not move the surface.
TEST(LatentFitTest, AFreePieceWithoutSurfaceIsFittedThroughTheRegularizedStiffness) {
  LatentFitResult fit;
  FitTheBlendOfTwoTrainingLatents(testing::PretrainedBarForFits(false, true), &fit);
  EXPECT_FALSE(fit.failed) << fit.message;
  EXPECT_GT(fit.shifted_jacobians, 0);
  EXPECT_EQ(fit.shifted_jacobians, fit.jacobians);
}

// The same model's fit Jacobian (latent block) against Ridders' differences of re-solved
// equilibria: the exact K is singular there, so every Jacobian comes from the
// regularized one, and its shift (1e-10 of the mean diagonal) must not show.
TEST(LatentFitTest, CostJacobianThroughTheRegularizedStiffnessPassesGradientChecker) {
  const ActiveModel model = testing::PretrainedBarForFits(false, true);
  const std::vector<int> vertices = {3, 20, 41, 57, 77};
  const FitTarget target = VertexTarget(vertices, model.neutral.vertices(Eigen::all, vertices));
  LatentFitOptions options;
  options.solver.relative_force_tolerance = 1e-12;
  options.fit_bones = false;
  LatentFitter fitter(model, options);
  const Eigen::VectorXd z = 0.5 * (model.latents.col(1) + model.latents.col(4));
  // Every re-solve starts at z's equilibrium: from rest, some of them stall on the free
  // piece at this tolerance and take 500 to 1000 L-BFGS iterations (docs/solver.md).
  Eigen::Matrix3Xd state, surface;
  std::string error;
  ASSERT_TRUE(fitter.Simulate(z, &state, &surface, &error)) << error;
  fitter.set_start_state(state);
  std::unique_ptr<ceres::CostFunction> cost(fitter.NewCostFunction(target));
  ASSERT_EQ(cost->parameter_block_sizes().size(), 1u);
  const double* parameters[1] = {z.data()};
  ceres::GradientChecker::ProbeResults results;
  testing::ProbeJacobians(*cost, parameters, 1e-6, &results, testing::RiddersFrom(1e-3));
  ASSERT_EQ(results.jacobians.size(), 1u) << results.error_log;
  EXPECT_GT(results.jacobians[0].norm(), 0.0);
  EXPECT_LT(testing::RelativeError(results.jacobians[0], results.numeric_jacobians[0]), 1e-6)
      << results.error_log;
}

TEST(LatentFitTest, RecoversLatentAndBoneMotion) {
  const ActiveModel model = TrainedModel(true);
  LatentFitOptions options;
  options.latent_prior = options.bone_prior = 0.0;  // the data term's own optimum
  options.solver.relative_force_tolerance = 1e-10;
  LatentFitter fitter(model, options);
  RigidTransform moved;
  moved.rotation = Eigen::AngleAxisd(0.1, Eigen::Vector3d(0.3, 1.0, 0.2).normalized()).toRotationMatrix();
  moved.translation = Eigen::Vector3d(0.05, -0.1, 0.03);
  fitter.set_bone_transforms({moved});
  const Eigen::VectorXd truth = model.latents.col(3);
  Eigen::Matrix3Xd state, surface;
  std::string error;
  ASSERT_TRUE(fitter.Simulate(truth, &state, &surface, &error)) << error;
  fitter.set_bone_transforms({RigidTransform()});  // start the fit at rest
  LatentFitResult fit;
  ASSERT_TRUE(fitter.Fit(FullSurfaceTarget(surface), fitter.MeanLatent(), &fit, &error)) << error;
  EXPECT_LT(fit.max_error, 1e-5) << fit.message;
  ASSERT_EQ(fit.bones.size(), 1u);
  EXPECT_LT((fit.bones[0].rotation - moved.rotation).norm(), 1e-5);
  EXPECT_LT((fit.bones[0].translation - moved.translation).norm(), 1e-5);
}

// The second start (LatentFitOptions::coarse_points): the fit kept is never worse by the
// fit's objective than the direct fit from the same start, its counters include both,
// and the fitter is left at the kept fit (its bones; its equilibrium as the next start).
TEST(LatentFitTest, SecondStartKeepsTheBetterFitAndCountsBoth) {
  const ActiveModel model = TrainedModel(true);
  LatentFitOptions options;
  options.solver.relative_force_tolerance = 1e-10;
  RigidTransform moved;
  moved.rotation =
      Eigen::AngleAxisd(0.2, Eigen::Vector3d(1.0, 0.4, -0.2).normalized()).toRotationMatrix();
  moved.translation = Eigen::Vector3d(-0.04, 0.08, 0.02);
  Eigen::Matrix3Xd state, surface;
  std::string error;
  {
    LatentFitter truth_fitter(model, options);
    truth_fitter.set_bone_transforms({moved});
    const Eigen::VectorXd z = 0.7 * model.latents.col(2) - 0.4 * model.latents.col(5);
    ASSERT_TRUE(truth_fitter.Simulate(z, &state, &surface, &error)) << error;
  }
  const FitTarget target = FullSurfaceTarget(surface);
  ASSERT_GT(target.num_points(), 10);
  LatentFitResult results[2];
  double objectives[2];
  for (int two : {0, 1}) {
    options.coarse_points = two ? 5 : 0;
    LatentFitter fitter(model, options);
    ASSERT_TRUE(fitter.Fit(target, fitter.MeanLatent(), &results[two], &error)) << error;
    objectives[two] = fitter.Objective(target, results[two].surface, results[two].latent);
    // The fitter's bones are the kept fit's, and its surface is that fit's equilibrium.
    ASSERT_EQ(fitter.bone_transforms().size(), 1u);
    EXPECT_LT((fitter.bone_transforms()[0].rotation - results[two].bones[0].rotation).norm(),
              1e-12);
    Eigen::Matrix3Xd again_state, again_surface;
    ASSERT_TRUE(fitter.Simulate(results[two].latent, &again_state, &again_surface, &error))
        << error;
    EXPECT_LT((again_surface - results[two].surface).cwiseAbs().maxCoeff(), 1e-6);
  }
  EXPECT_FALSE(results[0].second_start_ran);
  EXPECT_TRUE(results[1].second_start_ran);
  if (!results[1].second_start_kept) {
    EXPECT_LT((results[1].latent - results[0].latent).norm(), 1e-9);
  }
  EXPECT_LE(objectives[1], objectives[0] * (1 + 1e-9));
  // Both fits' work is counted: the direct one alone ran results[0]'s iterations.
  EXPECT_GT(results[1].iterations, results[0].iterations);
  EXPECT_GT(results[1].solves, results[0].solves);
}

TEST(LatentFitTest, PointCloudFitRecoversPoseFromPartialNoisyShuffledScan) {
  const ActiveModel model = TrainedModel(false);
  LatentFitOptions options;
  LatentFitter fitter(model, options);
  const Eigen::VectorXd truth = model.latents.col(5);
  Eigen::Matrix3Xd state, surface;
  std::string error;
  ASSERT_TRUE(fitter.Simulate(truth, &state, &surface, &error)) << error;
  // Sample only the triangles of the far half (x > 1 at rest), noisy, shuffled, plus
  // outliers.
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.003);
  std::vector<Eigen::Vector3d> samples;
  const Eigen::Matrix3Xi& tris = model.neutral.triangles;
  for (Eigen::Index t = 0; t < tris.cols(); ++t) {
    if (model.neutral.vertices(0, tris(0, t)) < 1.0) continue;
    for (int s = 0; s < 3; ++s) {
      double a = uniform(rng), b = uniform(rng);
      if (a + b > 1) {
        a = 1 - a;
        b = 1 - b;
      }
      const Eigen::Vector3d p = (1 - a - b) * surface.col(tris(0, t)) + a * surface.col(tris(1, t)) +
                                b * surface.col(tris(2, t));
      samples.push_back(p + Eigen::Vector3d(noise(rng), noise(rng), noise(rng)));
    }
  }
  for (int i = 0; i < 10; ++i) samples.push_back(Eigen::Vector3d(5 + i, -3, 2));  // outliers
  std::shuffle(samples.begin(), samples.end(), rng);
  Eigen::Matrix3Xd points(3, samples.size());
  for (size_t i = 0; i < samples.size(); ++i) points.col(i) = samples[i];
  PointCloudFitOptions cloud;
  cloud.max_distance = 0.5;
  cloud.robust_scale = 0.05;
  LatentFitResult fit;
  ASSERT_TRUE(fitter.FitPointCloud(points, cloud, fitter.MeanLatent(), &fit, &error)) << error;
  EXPECT_EQ(fit.used_points, static_cast<int>(samples.size()) - 10) << "outliers left out";
  // The whole surface (also the unscanned half) comes back close to the truth.
  const double vertex_error = (fit.surface - surface).colwise().norm().mean();
  const double motion = (surface - model.neutral.vertices).colwise().norm().mean();
  EXPECT_LT(vertex_error, 0.1 * motion) << "mean vertex error " << vertex_error << " vs motion " << motion;
  EXPECT_LT(fit.mean_error, 0.01);
}

TEST(LatentFitTest, ScanLandmarksPullTheFitInBothModes) {
  // A scan of one pose with landmarks taken from another: the landmarks' weight decides
  // which the fit follows. Without landmarks (or with weight 0) the fit is the scan's;
  // with a large weight it reaches the landmarks' pose at its vertices.
  const ActiveModel model = TrainedModel(false);
  LatentFitter fitter(model, LatentFitOptions());
  Eigen::Matrix3Xd state, scan_pose, landmark_pose;
  std::string error;
  ASSERT_TRUE(fitter.Simulate(model.latents.col(5), &state, &scan_pose, &error)) << error;
  ASSERT_TRUE(fitter.Simulate(model.latents.col(2), &state, &landmark_pose, &error)) << error;
  std::vector<int> vertices;
  for (int v = 0; v < model.num_surface_vertices(); v += 7) {
    if (model.neutral.vertices(0, v) > 1.0) vertices.push_back(v);
  }
  ASSERT_GE(vertices.size(), 4u);
  const Eigen::Matrix3Xd landmark_positions = landmark_pose(Eigen::all, vertices);
  const double apart =
      (scan_pose(Eigen::all, vertices) - landmark_positions).colwise().norm().mean();
  ASSERT_GT(apart, 0.02) << "the two poses must differ at the landmarks";
  for (const bool rematch : {true, false}) {
    SCOPED_TRACE(rematch ? "re-matched every evaluation" : "matching rounds");
    std::vector<double> landmark_errors;
    for (const double weight : {-1.0, 0.0, 100.0}) {  // -1: no landmarks at all
      PointCloudFitOptions cloud;
      cloud.rematch_every_evaluation = rematch;
      cloud.max_distance = 0.5;
      if (weight >= 0) {
        cloud.landmarks = VertexTarget(vertices, landmark_positions);
        cloud.landmark_weight = weight;
      }
      fitter.set_start_state(model.mesh.vertices);
      fitter.ForgetFactor();  // each fit as from a fresh fitter
      LatentFitResult fit;
      ASSERT_TRUE(fitter.FitPointCloud(scan_pose, cloud, fitter.PriorLatent(), &fit, &error))
          << error;
      // The reported landmark error is the fitted surface's distance to them.
      const double measured =
          (fit.surface(Eigen::all, vertices) - landmark_positions).colwise().norm().mean();
      if (weight >= 0) {
        EXPECT_NEAR(fit.landmark_mean_error, measured, 1e-12);
      } else {
        EXPECT_EQ(fit.landmark_mean_error, 0.0);
      }
      landmark_errors.push_back(measured);
    }
    // Weight 0 is no landmarks; weight 100 follows them (to a tenth of the poses' gap).
    EXPECT_NEAR(landmark_errors[1], landmark_errors[0], 1e-6 * apart);
    EXPECT_GT(landmark_errors[0], 0.5 * apart);
    EXPECT_LT(landmark_errors[2], 0.1 * apart);
  }
  // The start's objective counts them the same way: weight x their mean squared distance.
  PointCloudFitOptions plain, with;
  with.landmarks = VertexTarget(vertices, landmark_positions);
  with.landmark_weight = 3.0;
  const Eigen::VectorXd z = model.latents.col(5);
  const double squared =
      (scan_pose(Eigen::all, vertices) - landmark_positions).colwise().squaredNorm().mean();
  EXPECT_NEAR(fitter.StartObjective(nullptr, &scan_pose, with, scan_pose, z) -
                  fitter.StartObjective(nullptr, &scan_pose, plain, scan_pose, z),
              3.0 * squared, 1e-9 * squared);
}

// A scan fit with landmarks and an uncertainty estimate: its two data blocks share one
// equilibrium, whose Jacobian products Ceres' threads (of the solve and of the
// covariance) ask for at once (they raced for the products' lazy fill before). With 2
// threads the fit, its covariance and its surface deviations are the same, run after run,
// and close to those of one thread.
TEST(LatentFitTest, ScanWithLandmarksAndUncertaintyIsTheSameOnTwoThreads) {
  const ActiveModel model = TrainedModel(true);
  Eigen::Matrix3Xd state, scan;
  std::string error;
  LatentFitResult one_thread, two_threads;
  for (const int threads : {1, 2, 2, 2}) {
    LatentFitOptions options;
    options.num_threads = threads;
    options.uncertainty = true;
    LatentFitter fitter(model, options);
    if (scan.size() == 0) {
      ASSERT_TRUE(fitter.Simulate(model.latents.col(4), &state, &scan, &error)) << error;
    }
    std::vector<int> vertices;
    for (int v = 0; v < model.num_surface_vertices(); v += 9) vertices.push_back(v);
    PointCloudFitOptions cloud;
    cloud.max_distance = 0.5;
    cloud.rematch_every_evaluation = true;
    cloud.landmarks = VertexTarget(vertices, scan(Eigen::all, vertices));
    cloud.landmark_weight = 1.0;
    LatentFitResult fit;
    ASSERT_TRUE(fitter.FitPointCloud(scan, cloud, fitter.PriorLatent(), &fit, &error)) << error;
    ASSERT_GT(fit.surface_std.size(), 0) << fit.uncertainty_message;
    if (threads == 1) {
      one_thread = fit;
      continue;
    }
    // Parallel sums round differently from serial ones: close to the one-thread fit, and
    // the same bits on every two-thread run.
    EXPECT_LT(testing::RelativeError(fit.latent, one_thread.latent), 1e-4);
    EXPECT_LT(testing::RelativeError(fit.surface_std, one_thread.surface_std), 1e-3);
    if (two_threads.latent.size() == 0) {
      two_threads = fit;
      continue;
    }
    // (Parallel BLAS and Ceres' parallel sums may round differently from run to run:
    // measured 0 to 3e-17.)
    EXPECT_LT(testing::RelativeError(fit.latent, two_threads.latent), 1e-12);
    EXPECT_LT(testing::RelativeError(fit.parameter_covariance, two_threads.parameter_covariance),
              1e-12);
    EXPECT_LT(testing::RelativeError(fit.surface_std, two_threads.surface_std), 1e-12);
  }
}

// Scan points beyond max_distance are ignored by the fit, and by its noise estimate: a
// scan with far-away copies of its points (another object in the scan), fitted from the
// plain scan's result, stays there with the same noise and predicted deviations, in both
// scan modes (the far points had raised the one-solve mode's noise and, as zero
// residuals, lowered the rounds'). No priors: their weight depends on the point count.
TEST(LatentFitTest, ScanPointsBeyondMaxDistanceLeaveTheUncertaintyAlone) {
  const ActiveModel model = TrainedModel(false);
  LatentFitOptions options;
  options.latent_prior = 0.0;
  options.uncertainty = true;
  options.solver.relative_force_tolerance = 1e-10;
  Eigen::Matrix3Xd state, scan;
  std::string error;
  {
    LatentFitter fitter(model, options);
    ASSERT_TRUE(fitter.Simulate(model.latents.col(3), &state, &scan, &error)) << error;
  }
  std::mt19937 rng(6);
  std::normal_distribution<double> noise(0.0, 0.01);
  for (Eigen::Index i = 0; i < scan.size(); ++i) scan.data()[i] += noise(rng);
  Eigen::Matrix3Xd with_far(3, 2 * scan.cols());
  with_far << scan, scan.colwise() + Eigen::Vector3d(0, 0, 3.0);
  for (const bool one_solve : {true, false}) {
    SCOPED_TRACE(one_solve ? "one solve" : "matching rounds");
    PointCloudFitOptions cloud_options;
    cloud_options.max_distance = 0.5;
    cloud_options.latent_prior = 0.0;
    cloud_options.rematch_every_evaluation = one_solve;
    LatentFitter fitter(model, options);
    LatentFitResult plain, far;
    ASSERT_TRUE(fitter.FitPointCloud(scan, cloud_options, model.latents.col(3), &plain, &error))
        << error;
    ASSERT_GT(plain.surface_std.size(), 0) << plain.uncertainty_message;
    fitter.set_start_state(plain.state);
    ASSERT_TRUE(fitter.FitPointCloud(with_far, cloud_options, plain.latent, &far, &error)) << error;
    ASSERT_GT(far.surface_std.size(), 0) << far.uncertainty_message;
    EXPECT_GT(plain.noise_sigma, 0.0);
    // (The rounds, matching again between capped solves, move in the bar's flat
    // directions: their fit is not the same point, and their noise is within 5%: 2.1% on
    // one machine, under 1% on another. The far points, counted as zero residuals, had
    // lowered it by about 1 - 1/sqrt(2) = 29%.)
    EXPECT_NEAR(far.noise_sigma, plain.noise_sigma, (one_solve ? 0.01 : 0.05) * plain.noise_sigma);
    if (!one_solve) continue;
    EXPECT_LT(testing::RelativeError(far.latent, plain.latent), 1e-4);
    EXPECT_NEAR(far.surface_std.mean(), plain.surface_std.mean(), 0.01 * plain.surface_std.mean());
  }
}

// An infinite max_distance (no cap, which the options allow) estimates the uncertainty
// as a cap no point reaches does (it had counted no residual at all: "fewer data
// residuals (0) than parameters").
TEST(LatentFitTest, ScanWithoutCapHasAnUncertainty) {
  const ActiveModel model = TrainedModel(false);
  LatentFitOptions options;
  options.latent_prior = 0.0;
  options.uncertainty = true;
  Eigen::Matrix3Xd state, scan;
  std::string error;
  LatentFitter fitter(model, options);
  ASSERT_TRUE(fitter.Simulate(model.latents.col(2), &state, &scan, &error)) << error;
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.01);
  for (Eigen::Index i = 0; i < scan.size(); ++i) scan.data()[i] += noise(rng);
  std::vector<LatentFitResult> fits(2);
  for (int k = 0; k < 2; ++k) {
    PointCloudFitOptions cloud_options;
    cloud_options.max_distance = k == 0 ? 1e6 : std::numeric_limits<double>::infinity();
    cloud_options.latent_prior = 0.0;
    cloud_options.rematch_every_evaluation = true;
    fitter.set_start_state(state);
    ASSERT_TRUE(fitter.FitPointCloud(scan, cloud_options, model.latents.col(2), &fits[k], &error))
        << error;
    ASSERT_GT(fits[k].surface_std.size(), 0) << fits[k].uncertainty_message;
  }
  EXPECT_NEAR(fits[1].noise_sigma, fits[0].noise_sigma, 1e-6 * fits[0].noise_sigma);
}

TEST(LatentFitTest, ScanLatentPriorWeighsScanFitsOnly) {
  // PointCloudFitOptions::latent_prior: < 0 takes the other fits' weight; otherwise it
  // replaces it in scan fits and in the start's objective, and pulls the latent to the
  // prior's centre as it grows.
  const ActiveModel model = TrainedModel(false);
  LatentFitOptions options;
  options.latent_prior = 0.03;
  LatentFitter fitter(model, options);
  const Eigen::VectorXd truth = model.latents.col(5);
  Eigen::Matrix3Xd state, scan;
  std::string error;
  ASSERT_TRUE(fitter.Simulate(truth, &state, &scan, &error)) << error;
  ASSERT_GT(fitter.prior().latent.SquaredMahalanobis(truth), 0.1);
  auto start_objective = [&](double weight) {
    PointCloudFitOptions cloud;
    cloud.latent_prior = weight;
    return fitter.StartObjective(nullptr, &scan, cloud, scan, truth);
  };
  const double none = start_objective(0.0);
  const double inherited = start_objective(-1.0);
  EXPECT_EQ(inherited, start_objective(0.03));
  EXPECT_GT(inherited, none);
  EXPECT_NEAR(start_objective(0.3) - none, 10.0 * (inherited - none), 1e-9 * inherited);
  std::vector<double> distances;  // from the prior's centre, Mahalanobis
  for (const double weight : {0.0, 10.0}) {
    PointCloudFitOptions cloud;
    cloud.latent_prior = weight;
    cloud.max_distance = 0.5;
    fitter.set_start_state(model.mesh.vertices);
    fitter.ForgetFactor();
    LatentFitResult fit;
    ASSERT_TRUE(fitter.FitPointCloud(scan, cloud, fitter.PriorLatent(), &fit, &error)) << error;
    distances.push_back(std::sqrt(fitter.prior().latent.SquaredMahalanobis(fit.latent)));
    if (weight == 0.0) {
      EXPECT_LT(fit.mean_error, 1e-3) << "without a prior the scan is met";
    }
  }
  EXPECT_LT(distances[1], 0.5 * distances[0]);
}

TEST(LatentFitTest, UncertaintyShrinksWithMoreDataAndNearTheFixedEnd) {
  // Markers of a pose the model makes, with noise of 0.01 per coordinate: the estimated
  // noise is about 0.01, and the surface's predicted standard deviation is smaller with
  // all the markers than with a few, and near the fixed end than at the free end.
  const ActiveModel model = TrainedModel(false);
  LatentFitOptions options;
  options.latent_prior = options.bone_prior = 0.0;  // the data alone
  options.uncertainty = true;
  options.solver.relative_force_tolerance = 1e-10;
  LatentFitter fitter(model, options);
  Eigen::Matrix3Xd state, surface;
  std::string error;
  ASSERT_TRUE(fitter.Simulate(model.latents.col(3), &state, &surface, &error)) << error;
  std::mt19937 rng(4);
  std::normal_distribution<double> noise(0.0, 0.01);
  const int ns = model.num_surface_vertices();
  std::vector<double> mean_std;
  for (const int stride : {1, 7}) {
    std::vector<int> vertices;
    for (int v = 0; v < ns; v += stride) vertices.push_back(v);
    Eigen::Matrix3Xd positions = surface(Eigen::all, vertices);
    for (Eigen::Index i = 0; i < positions.size(); ++i) positions.data()[i] += noise(rng);
    fitter.set_start_state(model.mesh.vertices);
    LatentFitResult fit;
    ASSERT_TRUE(fitter.Fit(VertexTarget(vertices, positions), model.latents.col(3), &fit, &error))
        << error;
    ASSERT_EQ(fit.surface_std.size(), ns) << fit.uncertainty_message;
    const int parameters = model.latent_dim();
    ASSERT_EQ(fit.parameter_covariance.rows(), parameters);
    EXPECT_LT((fit.parameter_covariance - fit.parameter_covariance.transpose()).norm(),
              1e-12 * fit.parameter_covariance.norm());
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(fit.parameter_covariance);
    EXPECT_GE(eigen.eigenvalues().minCoeff(), -1e-12 * eigen.eigenvalues().maxCoeff());
    EXPECT_GT(fit.noise_sigma, 0.005) << "stride " << stride;
    EXPECT_LT(fit.noise_sigma, 0.02) << "stride " << stride;
    // Exactly the residual variance per degree of freedom: sum |fitted - marker|^2 over
    // the 3 x markers coordinates, divided by their number less the fitted parameters.
    const double squared = (fit.surface(Eigen::all, vertices) - positions).squaredNorm();
    const double dof = 3.0 * static_cast<double>(vertices.size()) - parameters;
    EXPECT_NEAR(fit.noise_sigma * fit.noise_sigma, squared / dof, 1e-6 * squared / dof)
        << "stride " << stride;
    EXPECT_TRUE(fit.surface_std.allFinite());
    mean_std.push_back(fit.surface_std.mean());
    if (stride == 1) {
      // G_v = d(vertex v)/dz of the equilibria themselves, by central differences of
      // re-solved surfaces: sqrt(trace(G_v C G_v^T)) is the reported deviation (a step
      // of 1e-3 with the 5-point stencil: smaller ones amplify the solves' 1e-10 force
      // tolerance).
      fitter.set_start_state(fit.state);
      auto surface_at = [&](const Eigen::VectorXd& z) -> Eigen::VectorXd {
        Eigen::Matrix3Xd x, y;
        std::string solve_error;
        EXPECT_TRUE(fitter.Simulate(z, &x, &y, &solve_error)) << solve_error;
        return Eigen::Map<const Eigen::VectorXd>(y.data(), y.size());
      };
      const Eigen::MatrixXd g = testing::CentralDifferenceJacobian(surface_at, fit.latent, 1e-3);
      double worst = 0.0;
      for (int v = 0; v < ns; ++v) {
        const Eigen::MatrixXd gv = g.middleRows(3 * static_cast<Eigen::Index>(v), 3);
        const double expected =
            std::sqrt(std::max(0.0, (gv * fit.parameter_covariance * gv.transpose()).trace()));
        worst = std::max(worst, std::abs(fit.surface_std[v] - expected));
      }
      EXPECT_LT(worst, 1e-5 * fit.surface_std.maxCoeff());
      // And the covariance's own scale: the noise variance times (G^T G)^-1, G the
      // markers' rows of that Jacobian (every vertex is a marker here, weights 1).
      const Eigen::MatrixXd expected_covariance =
          fit.noise_sigma * fit.noise_sigma * (g.transpose() * g).inverse();
      EXPECT_LT(testing::RelativeError(fit.parameter_covariance, expected_covariance), 1e-4)
          << fit.parameter_covariance << "\n" << expected_covariance;
    }
    // Near the fixed end the surface is held (its embedding weighs fixed vertices): its
    // predicted deviation is far below the free end's.
    double near = 0, far = 0;
    int near_count = 0, far_count = 0;
    for (int v = 0; v < ns; ++v) {
      const PointStencil stencil = EmbeddingStencil(model.embedding, model.mesh.tets, v);
      double fixed_weight = 0;
      for (int j = 0; j < 4; ++j) {
        if (std::find(model.static_vertices.begin(), model.static_vertices.end(),
                      stencil.vertex[j]) != model.static_vertices.end()) {
          fixed_weight += stencil.weight[j];
        }
      }
      if (fixed_weight >= 0.25) {
        near += fit.surface_std[v];
        ++near_count;
      } else if (fixed_weight == 0.0) {
        far += fit.surface_std[v];
        ++far_count;
      }
    }
    ASSERT_GT(near_count, 0);
    ASSERT_GT(far_count, 0);
    EXPECT_LT(near / near_count, 0.5 * far / far_count) << "stride " << stride;
  }
  EXPECT_LT(mean_std[0], 0.6 * mean_std[1]) << "all markers against every 7th";
}

TEST(LatentFitTest, BoneWithoutDataNearItEndsAtThePriorMean) {
  // A bone of one corner vertex of the fixed end; markers only on the far half of the
  // bar, which the corner's motion barely moves. With the bone prior the fit puts the
  // bone at the prior's mean (10 standard deviations from the start at rest); without
  // it the bone stays near its start.
  ActiveModel model = TrainedModel(false);
  int corner = model.static_vertices[0];
  for (int v : model.static_vertices) {
    if (model.mesh.vertices.col(v).sum() < model.mesh.vertices.col(corner).sum()) corner = v;
  }
  model.static_vertices.erase(
      std::find(model.static_vertices.begin(), model.static_vertices.end(), corner));
  Bone bone;
  bone.name = "corner";
  bone.vertices = {corner};
  bone.pose_transforms.assign(model.num_poses(), RigidTransform());
  model.bones.push_back(bone);
  model.fit_prior = LearnFitPrior(model);
  Eigen::VectorXd mean(6);
  const double translation_std = std::sqrt(model.fit_prior.bones[0].covariance(4, 4));
  mean << 0, 0, 0, 0, 10 * translation_std, 0;
  model.fit_prior.bones[0].mean = mean;
  std::vector<int> vertices;
  for (int v = 0; v < model.num_surface_vertices(); ++v) {
    if (model.neutral.vertices(0, v) > 1.0) vertices.push_back(v);
  }
  Eigen::Matrix3Xd state, surface;
  std::string error;
  {
    LatentFitter truth(model, LatentFitOptions());
    ASSERT_TRUE(truth.Simulate(model.latents.col(3), &state, &surface, &error)) << error;
  }
  const FitTarget target = VertexTarget(vertices, surface(Eigen::all, vertices));
  for (const double bone_prior : {0.01, 0.0}) {
    LatentFitOptions options;
    options.bone_prior = bone_prior;
    options.latent_prior = 0.0;  // the latent explains the data exactly
    options.solver.relative_force_tolerance = 1e-10;
    LatentFitter fitter(model, options);
    LatentFitResult fit;
    ASSERT_TRUE(fitter.Fit(target, fitter.PriorLatent(), &fit, &error)) << error;
    Eigen::VectorXd p(6);
    BoneTransformToParameters(fit.bones[0], p.data());
    const double distance = std::sqrt(model.fit_prior.bones[0].SquaredMahalanobis(p));
    if (bone_prior > 0) {
      EXPECT_LT(distance, 0.05) << "bone parameters " << p.transpose();
      // The markers were made with the bone at rest; the corner moved to the mean shifts
      // the far half a little, which the latent takes up.
      EXPECT_LT(fit.mean_error, 0.01);
    } else {
      EXPECT_GT(distance, 5.0) << "without the prior nothing pulls the bone to its mean";
    }
  }
  // A scan of the same points: its bone prior (PointCloudFitOptions::bone_prior) is
  // centred on the bones the fit starts from, not on the prior's mean, and weighed by
  // its own weight. From a start 3 standard deviations to the side the bone stays there
  // with it, and goes to the mean with the other fits' prior (as above).
  const Eigen::Matrix3Xd scan = surface(Eigen::all, vertices);
  const double side = 3 * std::sqrt(model.fit_prior.bones[0].covariance(5, 5));
  double start_parameters[6] = {0, 0, 0, 0, 0, side};
  const RigidTransform start = BoneTransformFromParameters(start_parameters);
  const Eigen::Map<const Eigen::VectorXd> start_vector(start_parameters, 6);
  for (const double scan_weight : {0.01, 0.0}) {
    LatentFitOptions options;
    options.bone_prior = 0.01;  // the other fits': centred on the prior's mean
    options.latent_prior = 0.0;
    options.solver.relative_force_tolerance = 1e-10;
    LatentFitter fitter(model, options);
    fitter.set_bone_transforms({start});
    PointCloudFitOptions cloud;
    cloud.bone_prior = scan_weight;
    LatentFitResult fit;
    ASSERT_TRUE(fitter.FitPointCloud(scan, cloud, fitter.PriorLatent(), &fit, &error)) << error;
    Eigen::VectorXd p(6);
    BoneTransformToParameters(fit.bones[0], p.data());
    const double from_mean = std::sqrt(model.fit_prior.bones[0].SquaredMahalanobis(p));
    const Eigen::VectorXd moved = model.fit_prior.bones[0].whitening * (p - start_vector);
    EXPECT_GT(from_mean, 5.0) << "scan weight " << scan_weight << ": " << p.transpose();
    if (scan_weight > 0) {
      EXPECT_LT(moved.norm(), 0.05) << "the scan's prior holds the start: " << p.transpose();
    }
    // The start's objective leaves the bone prior out (every start is its centre).
    const Eigen::VectorXd z = fitter.PriorLatent();
    fitter.set_bone_transforms({start});
    const double at_start = fitter.StartObjective(nullptr, &scan, cloud, surface, z);
    fitter.set_bone_transforms(RestBoneTransforms(model));
    EXPECT_EQ(fitter.StartObjective(nullptr, &scan, cloud, surface, z), at_start);
  }
}

TEST(LatentFitTest, StartIsTheTrainingPoseClosestToTheTarget) {
  ActiveModel model = TrainedModel(true);
  std::string error;
  ASSERT_TRUE(testing::StoreTrainingEquilibria(&model));
  LatentFitter fitter(model, LatentFitOptions());
  const int chosen_pose = 4;
  const Eigen::Matrix3Xd surface =
      EmbeddedPositions(model.embedding, model.mesh.tets, model.states[chosen_pose]);
  Eigen::VectorXd z = fitter.PriorLatent();
  std::string name;
  const FitTarget target = FullSurfaceTarget(surface);
  ASSERT_TRUE(fitter.ChooseStart(&target, nullptr, PointCloudFitOptions(), FitStartOptions(), &z,
                                 &name, &error)) << error;
  EXPECT_EQ(name, model.poses[chosen_pose].name);
  EXPECT_EQ(z, Eigen::VectorXd(model.latents.col(chosen_pose)));
  // A scan of it (its vertices, no correspondence) picks it too.
  z = fitter.PriorLatent();
  ASSERT_TRUE(fitter.ChooseStart(nullptr, &surface, PointCloudFitOptions(), FitStartOptions(), &z,
                                 &name, &error)) << error;
  EXPECT_EQ(name, model.poses[chosen_pose].name);
  // Without the training poses the given start stays.
  FitStartOptions given;
  given.training_poses = false;
  ASSERT_TRUE(fitter.ChooseStart(&target, nullptr, PointCloudFitOptions(), given, &z, &name, &error));
  EXPECT_EQ(name, "given");
}

// A scan beyond --max_distance everywhere holds nothing: such a fit fails, unless
// landmarks that weigh in it hold it (weight 0 ones do not: the fit ended "converged"
// where it started), and the start choice scores such landmarks' starts (it called every
// start unusable).
TEST(LatentFitTest, LandmarksHoldAScanOutOfReachOnlyWhereTheyWeigh) {
  const ActiveModel model = TrainedModel(false);
  LatentFitter fitter(model, LatentFitOptions());
  Eigen::Matrix3Xd state, surface;
  std::string error;
  ASSERT_TRUE(fitter.Simulate(model.latents.col(2), &state, &surface, &error)) << error;
  const Eigen::Matrix3Xd far = surface.colwise() + Eigen::Vector3d(0, 0, 5.0);
  std::vector<int> vertices;
  for (int v = 0; v < model.num_surface_vertices(); v += 5) vertices.push_back(v);
  PointCloudFitOptions cloud;
  cloud.max_distance = 0.5;
  cloud.landmarks = VertexTarget(vertices, surface(Eigen::all, vertices));
  cloud.landmark_weight = 0.0;
  LatentFitResult fit;
  fitter.set_start_state(model.mesh.vertices);
  EXPECT_FALSE(fitter.FitPointCloud(far, cloud, fitter.PriorLatent(), &fit, &error));
  EXPECT_NE(error.find("fewer than 3 of the scan's"), std::string::npos) << error;
  EXPECT_FALSE(std::isfinite(fitter.StartObjective(nullptr, &far, cloud, surface,
                                                   fitter.PriorLatent())));
  cloud.landmark_weight = 1.0;
  EXPECT_TRUE(std::isfinite(fitter.StartObjective(nullptr, &far, cloud, surface,
                                                  fitter.PriorLatent())));
  fitter.set_start_state(model.mesh.vertices);
  EXPECT_TRUE(fitter.FitPointCloud(far, cloud, fitter.PriorLatent(), &fit, &error)) << error;
}

// A start whose surface matches only 2 of the scan's points scores infinity in both
// modes (a match of fewer than 3 holds nothing, and its small mean distance must not win
// ChooseStart); with 3 it is finite. Only 0 matched points had been tried.
TEST(LatentFitTest, AStartMatchingFewerThanThreeScanPointsScoresInfinity) {
  const ActiveModel model = TrainedModel(false);
  LatentFitter fitter(model, LatentFitOptions());
  Eigen::Matrix3Xd state, surface;
  std::string error;
  ASSERT_TRUE(fitter.Simulate(model.latents.col(2), &state, &surface, &error)) << error;
  for (const bool rematch : {false, true}) {
    PointCloudFitOptions cloud;
    cloud.max_distance = 0.5;
    cloud.rematch_every_evaluation = rematch;
    for (const int near : {2, 3}) {
      Eigen::Matrix3Xd scan = surface.colwise() + Eigen::Vector3d(0, 0, 5.0);
      for (int k = 0; k < near; ++k) scan.col(10 * k) = surface.col(10 * k);
      const double objective =
          fitter.StartObjective(nullptr, &scan, cloud, surface, fitter.PriorLatent());
      if (near < 3) {
        EXPECT_TRUE(std::isinf(objective)) << "rematch " << rematch << ": " << objective;
      } else {
        EXPECT_TRUE(std::isfinite(objective)) << "rematch " << rematch;
      }
    }
  }
}

// The surface of training latent p simulated at rest bones: a scan with every point.
void ScanOfTrainingPose(const ActiveModel& model, int p, Eigen::Matrix3Xd* scan) {
  LatentFitter fitter(model, LatentFitOptions());
  Eigen::Matrix3Xd state;
  std::string error;
  ASSERT_TRUE(fitter.Simulate(model.latents.col(p), &state, scan, &error)) << error;
}

// Scan fits by matching rounds, points within 0.5 of the surface.
PointCloudFitOptions MatchingRounds() {
  PointCloudFitOptions cloud;
  cloud.max_distance = 0.5;
  cloud.rematch_every_evaluation = false;
  return cloud;
}

// Matching rounds converge when their mean distance settles, whatever the capped solve
// of the last round says (with one iteration per round it always hit its cap, and the
// fit was reported not converged). Rounds that run out converge where the last round's
// solve settled the distance (one more matching says so), and not where it did not.
TEST(LatentFitTest, MatchingRoundsConvergeByTheirOwnTest) {
  const ActiveModel model = TrainedModel(false);
  Eigen::Matrix3Xd scan;
  std::string error;
  ASSERT_NO_FATAL_FAILURE(ScanOfTrainingPose(model, 2, &scan));
  PointCloudFitOptions cloud = MatchingRounds();
  cloud.iterations_per_round = 1;
  cloud.relative_tolerance = 0.05;
  // Each fit by a fitter of its own, so that their paths are the same.
  auto fit_rounds = [&](int rounds, LatentFitResult* fit) {
    LatentFitter fitter(model, LatentFitOptions());
    cloud.max_rounds = rounds;
    return fitter.FitPointCloud(scan, cloud, fitter.PriorLatent(), fit, &error);
  };
  LatentFitResult fit;
  ASSERT_TRUE(fit_rounds(50, &fit)) << error;
  const int matchings = static_cast<int>(fit.round_distances.size());
  ASSERT_LT(matchings, 50);
  ASSERT_GE(matchings, 3) << "the test needs rounds that settle after two solves or more";
  EXPECT_TRUE(fit.converged) << fit.message;
  const Eigen::Matrix3Xd settled = fit.surface;
  // As many rounds as there were solves: they run out where the distance has settled.
  ASSERT_TRUE(fit_rounds(matchings - 1, &fit)) << error;
  EXPECT_TRUE(fit.converged) << fit.message;
  EXPECT_EQ(static_cast<int>(fit.round_distances.size()), matchings);
  EXPECT_LT((fit.surface - settled).norm(), 1e-9 * (1.0 + settled.norm()));
  // One round from the prior's centre does not settle it.
  ASSERT_TRUE(fit_rounds(1, &fit)) << error;
  EXPECT_FALSE(fit.converged) << fit.message;
}

// The temporal prior adds (weight / W') |L_z^-1 (z - previous)|^2 and, for each fitted
// bone, the same with the bone prior's whitening, to the objective the fits minimize (and
// the start choice compares), and a fit with it ends nearer the previous latent.
TEST(LatentFitTest, TemporalPriorAddsItsTermAndPullsTheFitTowardThePreviousFrame) {
  const ActiveModel model = TrainedModel(true);
  LatentFitOptions options;
  options.num_threads = 1;
  LatentFitter fitter(model, options);
  Eigen::Matrix3Xd state, surface;
  std::string error;
  ASSERT_TRUE(fitter.Simulate(model.latents.col(3), &state, &surface, &error)) << error;
  std::vector<int> markers;
  for (int v = 0; v < surface.cols(); v += 7) markers.push_back(v);
  const FitTarget target = VertexTarget(markers, surface(Eigen::all, markers));
  const Eigen::VectorXd previous = model.latents.col(1);
  std::vector<RigidTransform> previous_bones = fitter.bone_transforms();
  ASSERT_FALSE(previous_bones.empty());
  previous_bones[0].translation = Eigen::Vector3d(0.0, 0.02, 0.0);
  const Eigen::VectorXd z = model.latents.col(2);
  const double without = fitter.Objective(target, surface, z);
  const double weight = 0.5;
  fitter.SetTemporalPrior(weight, previous, previous_bones);
  const double with = fitter.Objective(target, surface, z);
  Eigen::Matrix<double, 6, 1> bone_now, bone_before;
  BoneTransformToParameters(fitter.bone_transforms()[0], bone_now.data());
  BoneTransformToParameters(previous_bones[0], bone_before.data());
  const double points = PriorPoints(target, options.prior_points_cap);
  const double expected =
      weight / points *
      ((fitter.prior().latent.whitening * (z - previous)).squaredNorm() +
       (fitter.prior().bones[0].whitening * (bone_now - bone_before)).squaredNorm());
  EXPECT_NEAR(with - without, expected, 1e-12 * (1.0 + expected));
  ASSERT_GT(expected, 0.0);
  // Fits from the same start, without and with it.
  LatentFitResult free, held;
  {
    LatentFitter plain(model, options);
    ASSERT_TRUE(plain.Fit(target, previous, &free, &error)) << error;
  }
  fitter.SetTemporalPrior(0.0, previous, previous_bones);
  EXPECT_NEAR(fitter.Objective(target, surface, z), without, 1e-15 * (1.0 + without));
  fitter.SetTemporalPrior(weight, previous, previous_bones);
  ASSERT_TRUE(fitter.Fit(target, previous, &held, &error)) << error;
  EXPECT_LT((held.latent - previous).norm(), (free.latent - previous).norm());
  // ... and its bone toward the previous frame's (not toward the bone prior's mean).
  ASSERT_EQ(held.bones.size(), previous_bones.size());
  Eigen::Matrix<double, 6, 1> free_bone, held_bone;
  BoneTransformToParameters(free.bones[0], free_bone.data());
  BoneTransformToParameters(held.bones[0], held_bone.data());
  EXPECT_LT((held_bone - bone_before).norm(), 0.9 * (free_bone - bone_before).norm())
      << "free " << free_bone.transpose() << "\nheld " << held_bone.transpose()
      << "\nprevious " << bone_before.transpose();
}

// Fit options that run Ceres and the equilibrium solves to round-off, on one thread, with
// the given latent prior and prior-points cap (for the stationarity checks below).
LatentFitOptions RoundOffFitOptions(double latent_prior, double prior_points_cap) {
  LatentFitOptions options;
  options.num_threads = 1;
  options.latent_prior = latent_prior;
  options.prior_points_cap = prior_points_cap;
  options.function_tolerance = 1e-15;
  options.parameter_tolerance = 1e-15;
  options.max_iterations = 200;
  options.solver.relative_force_tolerance = 1e-12;
  return options;
}

// The fit minimizes its documented objective: at its result, Objective (the data term
// plus every prior, each value-tested on its own) is stationary in the latent and the
// bone's 6 parameters, by central differences of re-solved equilibria. Unequal weights, a
// prior-points cap below the targets' total weight, and the latent, bone and temporal
// priors and the latent regularization all on, so that each weight and normalisation of
// the Ceres problem is compared with the formula's (a factor applied alike to a cost and
// its Jacobian passes every derivative test, and moves the minimum). Point-to-point and
// point-to-plane.
TEST(LatentFitTest, FitIsAStationaryPointOfItsDocumentedObjective) {
  const ActiveModel model = TrainedModel(true);
  LatentFitOptions options = RoundOffFitOptions(0.3, 7);
  options.bone_prior = 0.1;
  options.latent_regularization = 1e-3;
  LatentFitter fitter(model, options);
  const std::vector<RigidTransform> rest_bones = fitter.bone_transforms();
  ASSERT_EQ(rest_bones.size(), 1u);
  std::vector<RigidTransform> moved = rest_bones;
  moved[0].translation += Eigen::Vector3d(0.0, 0.02, 0.01);
  fitter.set_bone_transforms(moved);
  Eigen::Matrix3Xd state, surface;
  std::string error;
  ASSERT_TRUE(fitter.Simulate(model.latents.col(3), &state, &surface, &error)) << error;
  std::vector<int> markers;
  for (int v = 0; v < surface.cols(); v += 5) markers.push_back(v);
  std::mt19937 rng(8);
  std::normal_distribution<double> noise(0.0, 0.005);
  Eigen::Matrix3Xd positions = surface(Eigen::all, markers);
  for (Eigen::Index i = 0; i < positions.size(); ++i) positions.data()[i] += noise(rng);
  FitTarget point = VertexTarget(markers, positions);
  point.weights.resize(point.num_points());
  const double cycle[3] = {0.3, 1.0, 2.5};
  for (int k = 0; k < point.num_points(); ++k) point.weights[k] = cycle[k % 3];
  for (const int k : {1, 4, 7}) {  // unused points, far off: no part of the fit or its errors
    point.weights[k] = 0.0;
    point.positions(1, k) += 0.5;
  }
  ASSERT_GT(point.weights.sum(), 2.0 * options.prior_points_cap);
  FitTarget plane = point;
  plane.normals = Eigen::Matrix3Xd::Random(3, point.num_points()).colwise().normalized();
  plane.tangential_weight = 0.2;
  std::vector<RigidTransform> previous = rest_bones;
  previous[0].translation += Eigen::Vector3d(0.01, 0.0, 0.0);
  const int d = model.latent_dim();
  for (const FitTarget* target : {&point, &plane}) {
    SCOPED_TRACE(target == &point ? "point-to-point" : "point-to-plane");
    fitter.set_bone_transforms(rest_bones);
    fitter.set_start_state(model.mesh.vertices);
    fitter.SetTemporalPrior(0.2, model.latents.col(1), previous);
    LatentFitResult fit;
    ASSERT_TRUE(fitter.Fit(*target, model.latents.col(0), &fit, &error)) << error;
    Eigen::VectorXd theta(d + 6);
    theta.head(d) = fit.latent;
    BoneTransformToParameters(fit.bones[0], theta.data() + d);
    auto value = [&](const Eigen::VectorXd& t, bool data_only) {
      fitter.set_bone_transforms({BoneTransformFromParameters(t.data() + d)});
      fitter.set_start_state(fit.state);
      Eigen::Matrix3Xd x, y;
      std::string solve_error;
      EXPECT_TRUE(fitter.Simulate(t.head(d), &x, &y, &solve_error)) << solve_error;
      return data_only ? TargetDataTerm(*target, y) : fitter.Objective(*target, y, t.head(d));
    };
    const Eigen::VectorXd objective = testing::CentralDifferenceGradient(
        [&](const Eigen::VectorXd& t) { return value(t, false); }, theta, 1e-4);
    const Eigen::VectorXd data = testing::CentralDifferenceGradient(
        [&](const Eigen::VectorXd& t) { return value(t, true); }, theta, 1e-4);
    std::printf("fit's stationarity: |d objective| %.3g, |d data term| %.3g (%d iterations)\n",
                objective.norm(), data.norm(), fit.iterations);
    // The errors it reports: mean, rms and max distance over the points of positive weight.
    std::vector<double> distances;
    for (int k = 0; k < target->num_points(); ++k) {
      if (target->weights[k] > 0.0) {
        distances.push_back((fit.surface.col(markers[k]) - target->positions.col(k)).norm());
      }
    }
    const Eigen::Map<const Eigen::VectorXd> used(distances.data(), distances.size());
    EXPECT_EQ(fit.used_points, target->num_points() - 3);
    EXPECT_NEAR(fit.mean_error, used.mean(), 1e-14);
    EXPECT_NEAR(fit.rms_error, std::sqrt(used.squaredNorm() / used.size()), 1e-14);
    EXPECT_NEAR(fit.max_error, used.maxCoeff(), 1e-14);
    EXPECT_GT(data.norm(), 1e-3) << "the priors pull the fit off the data's own minimum";
    EXPECT_LT(objective.norm(), 1e-5 * data.norm()) << "objective " << objective.transpose()
                                                    << "\ndata " << data.transpose();
  }
}

// The same for a scan fit re-matched at every evaluation: at its result, StartObjective
// (the robust closest-point term over 1/sqrt(M), the scan's latent prior over
// min(M, cap) points and the landmarks' term) is stationary in the latent. The scan's
// latent prior differs from the options' and the cap is below M, so each weight is the
// scan's own.
TEST(LatentFitTest, ScanFitIsAStationaryPointOfItsObjective) {
  const ActiveModel model = TrainedModel(false);
  const LatentFitOptions options = RoundOffFitOptions(0.03, 20);
  LatentFitter fitter(model, options);
  Eigen::Matrix3Xd state, surface, landmark_surface;
  std::string error;
  ASSERT_TRUE(fitter.Simulate(model.latents.col(2), &state, &landmark_surface, &error)) << error;
  ASSERT_TRUE(fitter.Simulate(model.latents.col(3), &state, &surface, &error)) << error;
  std::mt19937 rng(9);
  std::normal_distribution<double> noise(0.0, 0.003);
  Eigen::Matrix3Xd scan = surface;
  for (Eigen::Index i = 0; i < scan.size(); ++i) scan.data()[i] += noise(rng);
  ASSERT_GT(scan.cols(), 2 * options.prior_points_cap);
  PointCloudFitOptions cloud;
  cloud.rematch_every_evaluation = true;
  cloud.max_distance = 0.5;
  cloud.robust_scale = 0.05;
  cloud.latent_prior = 0.3;
  const std::vector<int> landmarks = {0, 13, 27, 41, 55, 69};
  cloud.landmarks = VertexTarget(landmarks, landmark_surface(Eigen::all, landmarks));
  cloud.landmark_weight = 0.5;
  fitter.set_start_state(model.mesh.vertices);
  LatentFitResult fit;
  ASSERT_TRUE(fitter.FitPointCloud(scan, cloud, model.latents.col(0), &fit, &error)) << error;
  auto value = [&](const Eigen::VectorXd& z, bool data_only) {
    fitter.set_start_state(fit.state);
    Eigen::Matrix3Xd x, y;
    std::string solve_error;
    EXPECT_TRUE(fitter.Simulate(z, &x, &y, &solve_error)) << solve_error;
    PointCloudFitOptions data = cloud;
    if (data_only) {
      data.latent_prior = 0.0;
      data.landmark_weight = 0.0;
    }
    return fitter.StartObjective(nullptr, &scan, data, y, z);
  };
  const Eigen::VectorXd objective = testing::CentralDifferenceGradient(
      [&](const Eigen::VectorXd& z) { return value(z, false); }, fit.latent, 1e-4);
  const Eigen::VectorXd data = testing::CentralDifferenceGradient(
      [&](const Eigen::VectorXd& z) { return value(z, true); }, fit.latent, 1e-4);
  std::printf("scan fit's stationarity: |d objective| %.3g, |d scan term| %.3g (%d "
              "iterations)\n", objective.norm(), data.norm(), fit.iterations);
  EXPECT_GT(data.norm(), 1e-3) << "the prior and landmarks pull the fit off the scan's minimum";
  EXPECT_LT(objective.norm(), 1e-5 * data.norm()) << "objective " << objective.transpose()
                                                  << "\nscan term " << data.transpose();
}

// The matching rounds' work counts the solve of their start, whose surface the first
// round matches: one round is that solve plus a fit to that matching, which a fitter of
// its own repeats step by step (the rounds counted only the fit's solves before).
TEST(LatentFitTest, MatchingRoundsCountTheSolveOfTheirStart) {
  const ActiveModel model = TrainedModel(false);
  Eigen::Matrix3Xd state, scan;
  std::string error;
  ASSERT_NO_FATAL_FAILURE(ScanOfTrainingPose(model, 2, &scan));
  PointCloudFitOptions cloud = MatchingRounds();
  cloud.iterations_per_round = 3;
  cloud.max_rounds = 1;
  // No priors, which scan fits weigh by rules of their own.
  cloud.latent_prior = -1.0;
  cloud.bone_prior = -1.0;
  LatentFitOptions options;
  options.latent_prior = 0.0;
  options.bone_prior = 0.0;
  options.max_iterations = cloud.iterations_per_round;
  LatentFitResult rounds;
  {
    LatentFitter fitter(model, options);
    ASSERT_TRUE(fitter.FitPointCloud(scan, cloud, fitter.PriorLatent(), &rounds, &error))
        << error;
  }
  LatentFitter fitter(model, options);
  const Eigen::VectorXd start = fitter.PriorLatent();
  Eigen::Matrix3Xd start_surface;
  ASSERT_TRUE(fitter.Simulate(start, &state, &start_surface, &error)) << error;
  const int start_solves = 1;
  ASSERT_TRUE(fitter.last_simulate_report().converged);
  int used = 0;
  double mean = 0.0;
  const FitTarget target = MatchPointCloud(scan, start_surface, model.neutral.triangles, cloud,
                                           1, &used, &mean);
  ASSERT_GE(used, 3);
  LatentFitResult direct;
  ASSERT_TRUE(fitter.Fit(target, start, &direct, &error)) << error;
  ASSERT_GT(direct.solves, 0);
  EXPECT_EQ(rounds.iterations, direct.iterations);
  EXPECT_LT((rounds.surface - direct.surface).norm(), 1e-9 * (1.0 + direct.surface.norm()));
  EXPECT_EQ(rounds.solves, direct.solves + start_solves);
  EXPECT_GE(rounds.solve_factorizations, direct.solve_factorizations + 1);
}

// Matching rounds refuse a match of fewer than 3 scan points whatever the landmarks, so
// there a start that reaches no scan point scores +inf, also with landmarks (its matched
// data term was 0/0, and the NaN score of a given start kept every training pose from
// being chosen: "no start reaches the scan").
TEST(LatentFitTest, MatchingRoundsGivenStartThatReachesNothingLosesToATrainingPose) {
  ActiveModel model = TrainedModel(false);
  ASSERT_TRUE(testing::StoreTrainingEquilibria(&model));
  LatentFitter fitter(model, LatentFitOptions());
  const int pose = 2;
  const Eigen::Matrix3Xd pose_surface =
      EmbeddedPositions(model.embedding, model.mesh.tets, model.states[pose]);
  // The given start, off every training latent.
  const Eigen::VectorXd given =
      fitter.PriorLatent() - 1.5 * (model.latents.col(pose) - fitter.PriorLatent());
  for (int p = 0; p < model.num_poses(); ++p) {
    ASSERT_GT((given - model.latents.col(p)).norm(), 1e-6);
  }
  Eigen::Matrix3Xd state, given_surface;
  std::string error;
  ASSERT_TRUE(fitter.Simulate(given, &state, &given_surface, &error)) << error;
  // The scan: the pose's surface vertices far from the given start's surface.
  const TriangleBvh bvh(given_surface, model.neutral.triangles);
  const std::vector<ClosestPointResult> closest = bvh.ClosestPoints(pose_surface, 1);
  std::vector<double> distances;
  for (const ClosestPointResult& c : closest) distances.push_back(c.distance);
  std::vector<double> sorted = distances;
  std::sort(sorted.begin(), sorted.end());
  const double max_distance = 0.5 * sorted[sorted.size() * 8 / 10];
  ASSERT_GT(max_distance, 0.0);
  std::vector<int> far;
  for (size_t v = 0; v < distances.size(); ++v) {
    if (distances[v] > 2.0 * max_distance) far.push_back(static_cast<int>(v));
  }
  ASSERT_GE(far.size(), 6u);
  const Eigen::Matrix3Xd scan = pose_surface(Eigen::all, far);
  PointCloudFitOptions cloud;
  cloud.max_distance = max_distance;
  cloud.rematch_every_evaluation = false;
  const std::vector<int> landmark_vertices(far.begin(), far.begin() + 3);
  cloud.landmarks = VertexTarget(landmark_vertices, pose_surface(Eigen::all, landmark_vertices));
  cloud.landmark_weight = 0.03;
  EXPECT_EQ(fitter.StartObjective(nullptr, &scan, cloud, given_surface, given),
            std::numeric_limits<double>::infinity());
  Eigen::VectorXd start = given;
  std::string name;
  fitter.set_start_state(model.mesh.vertices);
  ASSERT_TRUE(fitter.ChooseStart(nullptr, &scan, cloud, FitStartOptions(), &start, &name,
                                 &error)) << error;
  EXPECT_NE(name, "given");
  EXPECT_FALSE(name.empty());
  // Where the scan is reached, landmarks weigh in the score in rounds mode too (as in
  // the rounds' fits): landmarks off the pose's surface raise the pose's score.
  PointCloudFitOptions moved = cloud;
  moved.landmarks = VertexTarget(
      landmark_vertices,
      pose_surface(Eigen::all, landmark_vertices).colwise() + Eigen::Vector3d(0, 0, 0.1));
  moved.landmark_weight = 0.0;
  const Eigen::VectorXd z_pose = model.latents.col(pose);
  const double without = fitter.StartObjective(nullptr, &scan, moved, pose_surface, z_pose);
  moved.landmark_weight = 100.0;
  const double with = fitter.StartObjective(nullptr, &scan, moved, pose_surface, z_pose);
  ASSERT_TRUE(std::isfinite(without));
  EXPECT_NEAR(with - without, 100.0 * 0.01, 1e-6);
}

// Without fit_bones the bones stay where they were set: a training pose at other bone
// motions does not start the fit (it held the bones at its motion before), one at the
// same motions may.
TEST(LatentFitTest, BonesNotFittedKeepTheirMotionWhenTheStartIsChosen) {
  ActiveModel model = TrainedModel(true);
  const int moved_pose = 4;
  model.bones[0].pose_transforms[moved_pose].translation = Eigen::Vector3d(0.0, 0.05, 0.0);
  ASSERT_TRUE(testing::StoreTrainingEquilibria(&model));
  const FitTarget target = FullSurfaceTarget(
      EmbeddedPositions(model.embedding, model.mesh.tets, model.states[moved_pose]));
  for (const bool fit_bones : {true, false}) {
    SCOPED_TRACE(fit_bones ? "bones fitted" : "bones not fitted");
    LatentFitOptions options;
    options.fit_bones = fit_bones;
    LatentFitter fitter(model, options);
    Eigen::VectorXd z = fitter.PriorLatent();
    std::string name, error;
    ASSERT_TRUE(fitter.ChooseStart(&target, nullptr, PointCloudFitOptions(), FitStartOptions(),
                                   &z, &name, &error))
        << error;
    const Eigen::Vector3d translation = fitter.bone_transforms()[0].translation;
    if (fit_bones) {
      EXPECT_EQ(name, model.poses[moved_pose].name);
      EXPECT_EQ(translation, model.bones[0].pose_transforms[moved_pose].translation);
    } else {
      EXPECT_NE(name, model.poses[moved_pose].name);
      EXPECT_EQ(translation, Eigen::Vector3d::Zero());
    }
  }
}

}  // namespace
}  // namespace aqs
