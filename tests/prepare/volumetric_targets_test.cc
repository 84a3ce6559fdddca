// Volumetric targets by embedded simulation (prepare/volumetric_targets.h): a pose's
// target depends on the pose alone, bit for bit: not on the number of threads, the order
// the poses are solved in, or the other poses solved before it (every pose's solve
// starts from the factor of the body at rest). The MPI ranks' share of the same work is
// tested in tests/dist/mpi_pose_work_test.cc, the store of a stopped run in
// target_store_test.cc.

#include "prepare/volumetric_targets.h"

#include <cmath>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "physics/rotation_variant_svd.h"
#include "testing/synthetic_muscles.h"

namespace aqs {
namespace {

constexpr int kPoses = 5;

class VolumetricTargetsTest : public ::testing::Test {
 protected:
  void SetUp() override { base_ = testing::MakeSyntheticMuscles(kPoses, 0, 0.3, 11).model; }

  // Targets of `poses` (in that order) made on a fresh copy of the model.
  ActiveModel MakeOf(const std::vector<int>& poses, int num_threads) {
    ActiveModel model = base_;
    VolumetricTargetOptions options;
    options.num_threads = num_threads;
    std::vector<std::string> failures(kPoses);
    std::ostringstream log;
    MakeVolumetricTargetsOf(options, poses, nullptr, &model, log, &failures);
    for (int p : poses) EXPECT_EQ(failures[p], "") << p;
    return model;
  }

  static void ExpectSameTarget(const ActiveModel& a, const ActiveModel& b, int p,
                               const std::string& what) {
    ASSERT_EQ(a.poses[p].target.cols(), a.mesh.num_tets()) << what << ", pose " << p;
    ASSERT_EQ(b.poses[p].target.cols(), b.mesh.num_tets()) << what << ", pose " << p;
    EXPECT_TRUE(a.poses[p].target == b.poses[p].target)
        << what << ", pose " << p << ": largest difference "
        << (a.poses[p].target - b.poses[p].target).cwiseAbs().maxCoeff();
    EXPECT_EQ(a.poses[p].embedding_mean_error, b.poses[p].embedding_mean_error)
        << what << ", pose " << p;
  }

  ActiveModel base_;
};

TEST_F(VolumetricTargetsTest, APosesTargetDependsOnThePoseAlone) {
  const ActiveModel in_order = MakeOf({0, 1, 2, 3, 4}, 1);
  const ActiveModel reversed = MakeOf({4, 3, 2, 1, 0}, 1);
  const ActiveModel two_threads = MakeOf({0, 1, 2, 3, 4}, 2);
  const ActiveModel some = MakeOf({3, 1}, 1);
  for (int p = 0; p < kPoses; ++p) {
    ExpectSameTarget(in_order, reversed, p, "reversed order");
    ExpectSameTarget(in_order, two_threads, p, "two threads");
  }
  ExpectSameTarget(in_order, some, 3, "poses 3 and 1 alone");
  ExpectSameTarget(in_order, some, 1, "poses 3 and 1 alone");
  EXPECT_EQ(some.poses[0].target.cols(), 0);
}

TEST_F(VolumetricTargetsTest, MakeVolumetricTargetsIsMakeVolumetricTargetsOfEveryPose) {
  ActiveModel model = base_;
  VolumetricTargetOptions options;
  options.num_threads = 2;
  std::ostringstream log;
  std::string error;
  ASSERT_TRUE(MakeVolumetricTargets(options, &model, log, &error)) << error;
  const ActiveModel one_by_one = MakeOf({2, 0, 4, 1, 3}, 1);
  for (int p = 0; p < kPoses; ++p) ExpectSameTarget(model, one_by_one, p, "one by one");
  // The poses are solved from the rest factor: few need a factorization of their own.
  EXPECT_NE(log.str().find("by CG on an earlier factor"), std::string::npos) << log.str();
}

// A pose whose surface the embedded simulation can reach only by turning elements inside
// out (the bar's surface mirrored across its middle, y -> 0.4 - y): its log line counts
// them, as it does not for a pose without any.
TEST_F(VolumetricTargetsTest, InvertedElementsAreCounted) {
  ActiveModel model = base_;
  Eigen::Matrix3Xd mirrored = model.neutral.vertices;
  mirrored.row(1) = (0.4 - mirrored.row(1).array()).matrix();
  model.poses[0].surface = mirrored;
  VolumetricTargetOptions options;
  options.num_threads = 1;
  std::vector<std::string> failures(kPoses);
  std::ostringstream log;
  MakeVolumetricTargetsOf(options, {0, 1}, nullptr, &model, log, &failures);
  const std::string text = log.str();
  const size_t second = text.find("\n");
  ASSERT_NE(second, std::string::npos) << text;
  EXPECT_NE(text.substr(0, second).find(" element(s) inverted (lowest det F -"),
            std::string::npos)
      << text;
  EXPECT_EQ(text.substr(second).find("inverted"), std::string::npos) << text;
}

// A pose whose direct solve fails within the budget (one Newton step after at most 3
// L-BFGS iterations) is reached by continuation in 4 steps, each from the last: its
// target is the one the direct solve reaches with the default budget. (No test had
// entered the continuation before.)
TEST_F(VolumetricTargetsTest, ContinuationReachesThePoseWhereTheDirectSolveFails) {
  const ActiveModel expected = MakeOf({0}, 1);
  VolumetricTargetOptions options;
  options.num_threads = 1;
  options.solver.max_iterations = 1;
  options.solver.max_lbfgs_iterations = 3;
  options.continuation_steps = 1;
  ActiveModel model = base_;
  std::vector<std::string> failures(kPoses);
  std::ostringstream log;
  MakeVolumetricTargetsOf(options, {0}, nullptr, &model, log, &failures);
  EXPECT_NE(failures[0].find("did not converge"), std::string::npos) << failures[0];
  options.continuation_steps = 4;
  model = base_;
  failures.assign(kPoses, "");
  log.str("");
  MakeVolumetricTargetsOf(options, {0}, nullptr, &model, log, &failures);
  EXPECT_EQ(failures[0], "");
  EXPECT_NE(log.str().find(" in 4 steps"), std::string::npos) << log.str();
  ASSERT_EQ(model.poses[0].target.cols(), model.mesh.num_tets());
  const ActuationMatrix& target = expected.poses[0].target;
  EXPECT_LT((model.poses[0].target - target).cwiseAbs().maxCoeff(),
            1e-6 * target.cwiseAbs().maxCoeff());
  EXPECT_NEAR(model.poses[0].embedding_mean_error, expected.poses[0].embedding_mean_error,
              1e-6 * expected.poses[0].embedding_mean_error);
}

// An element's target reproduces its deformation gradient F up to a proper rotation:
// R S = F with R in SO(3), for inverted F too with kExact (S then has one negative
// eigenvalue, det S = det F); kMirror gives sqrt(F^T F) there, the mirror image, which
// no rotation takes to F. Where det F > 0 both are SymmetricPolarFactor, bit for bit.
// Random, rotated, inverted and nearly flat F.
TEST(ElementTargetTest, ExactTargetsReproduceInvertedElements) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  for (int trial = 0; trial < 200; ++trial) {
    Eigen::Matrix3d f;
    for (int i = 0; i < 9; ++i) f.data()[i] = uniform(rng);
    if (trial % 4 == 1) f = Eigen::AngleAxisd(2.5, Eigen::Vector3d(1, 2, 3).normalized()) * f;
    if (trial % 4 == 2) f.col(2) = 0.5 * f.col(0) - 0.25 * f.col(1) + 1e-7 * f.col(2);  // flat
    if (trial % 4 == 3) f = Eigen::Matrix3d(Eigen::Vector3d(1.2, 0.9, -0.3).asDiagonal()) * f;
    SCOPED_TRACE(::testing::Message() << "trial " << trial << ", det F " << f.determinant());
    const Vector6d exact = ElementTarget(f, InvertedTargets::kExact);
    const Vector6d mirror = ElementTarget(f, InvertedTargets::kMirror);
    const Eigen::Matrix3d s = SymmetricFromActuation(exact.data());
    // R = argmin over rotations of |F - R S|, by the physics' own SVD of F S.
    const RotationVariantSvd svd = ComputeRotationVariantSvd(f * s);
    const Eigen::Matrix3d r = svd.u * svd.v.transpose();
    EXPECT_NEAR(r.determinant(), 1.0, 1e-12);
    EXPECT_LT((f - r * s).norm(), 1e-10 * (1.0 + f.norm()));
    if (f.determinant() > 0) {
      EXPECT_EQ(exact, ActuationFromSymmetric(SymmetricPolarFactor(f)));
      EXPECT_EQ(mirror, exact);
    } else {
      EXPECT_NEAR(s.determinant(), f.determinant(), 1e-10 * (1.0 + f.norm() * f.squaredNorm()));
      EXPECT_EQ(mirror, ActuationFromSymmetric(SymmetricPolarFactor(f)));
      const Eigen::Matrix3d m = SymmetricFromActuation(mirror.data());
      const RotationVariantSvd mirror_svd = ComputeRotationVariantSvd(f * m);
      const Eigen::Matrix3d best = mirror_svd.u * mirror_svd.v.transpose();
      // (The closest it comes is 2 |sigma_2|, F's smallest singular value.)
      EXPECT_GT((f - best * m).norm(), std::abs(ComputeRotationVariantSvd(f).sigma[2]));
    }
  }
}

TEST(ElementTargetTest, NamesRoundTrip) {
  for (InvertedTargets kind : {InvertedTargets::kExact, InvertedTargets::kMirror}) {
    InvertedTargets parsed = kind == InvertedTargets::kExact ? InvertedTargets::kMirror
                                                             : InvertedTargets::kExact;
    EXPECT_TRUE(ParseInvertedTargets(InvertedTargetsName(kind), &parsed));
    EXPECT_EQ(parsed, kind);
  }
  InvertedTargets parsed = InvertedTargets::kExact;
  EXPECT_FALSE(ParseInvertedTargets("reflect", &parsed));
}

}  // namespace
}  // namespace aqs
