// Linear PCA of surfaces and its ridge-regularized marker fits (eval/surface_pca.h), the
// baselines of the evaluation and of aqs_bench_fit.

#include "eval/surface_pca.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include <Eigen/QR>
#include <Eigen/SVD>
#include <gtest/gtest.h>

namespace aqs {
namespace {

constexpr int kVertices = 30;

// `count` surfaces mean + sum_j c_j mode_j of `modes` fixed random modes, the
// coefficients random (seed).
std::vector<Eigen::Matrix3Xd> LinearSurfaces(int count, int modes, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  auto random = [&](int rows, int cols) {
    Eigen::MatrixXd m(rows, cols);
    for (int i = 0; i < m.size(); ++i) m.data()[i] = normal(rng);
    return m;
  };
  const Eigen::MatrixXd mean = random(3, kVertices);
  std::vector<Eigen::MatrixXd> basis;
  for (int j = 0; j < modes; ++j) basis.push_back(random(3, kVertices));
  std::vector<Eigen::Matrix3Xd> surfaces;
  for (int p = 0; p < count; ++p) {
    Eigen::Matrix3Xd s = mean;
    for (int j = 0; j < modes; ++j) s += normal(rng) * basis[j];
    surfaces.push_back(s);
  }
  return surfaces;
}

TEST(SurfacePcaTest, ReproducesSurfacesInItsSpan) {
  const std::vector<Eigen::Matrix3Xd> surfaces = LinearSurfaces(6, 2, 1);
  const SurfacePca pca(surfaces, 2);
  EXPECT_EQ(pca.num_components(), 2);
  for (const Eigen::Matrix3Xd& s : surfaces) {
    EXPECT_LT((pca.Decode(pca.Encode(s)) - s).cwiseAbs().maxCoeff(), 1e-10);
    const std::vector<int> markers = {0, 5, 9};
    Eigen::Matrix3Xd at(3, 3);
    for (int i = 0; i < 3; ++i) at.col(i) = s.col(markers[i]);
    EXPECT_LT((pca.FitToVertices(markers, at) - s).cwiseAbs().maxCoeff(), 1e-9);
    EXPECT_LT((pca.FitToVerticesRidge(markers, at, 0.0) - s).cwiseAbs().maxCoeff(), 1e-9);
  }
}

// The documented properties, on surfaces of more modes than kept: the centre is the mean
// of the surfaces, the basis orthonormal, the variances the squared singular values of
// the centred data over the number of surfaces, and the components the leading ones
// (any centre inside the span would pass ReproducesSurfacesInItsSpan).
TEST(SurfacePcaTest, CentreBasisAndVariancesAreThoseOfClassicPca) {
  const std::vector<Eigen::Matrix3Xd> surfaces = LinearSurfaces(9, 5, 4);
  const int p = static_cast<int>(surfaces.size());
  const SurfacePca pca(surfaces, 3);
  ASSERT_EQ(pca.num_components(), 3);
  Eigen::MatrixXd data(3 * kVertices, p);
  for (int i = 0; i < p; ++i) {
    data.col(i) = Eigen::Map<const Eigen::VectorXd>(surfaces[i].data(), 3 * kVertices);
  }
  const Eigen::VectorXd mean = data.rowwise().mean();
  EXPECT_LT((pca.mean() - mean).cwiseAbs().maxCoeff(), 1e-13);
  EXPECT_LT((pca.basis().transpose() * pca.basis() - Eigen::MatrixXd::Identity(3, 3))
                .cwiseAbs()
                .maxCoeff(),
            1e-12);
  const Eigen::MatrixXd centred = data.colwise() - mean;
  Eigen::BDCSVD<Eigen::MatrixXd> svd(centred, Eigen::ComputeThinU);
  for (int j = 0; j < 3; ++j) {
    const double variance = svd.singularValues()[j] * svd.singularValues()[j] / p;
    EXPECT_NEAR(pca.variances()[j], variance, 1e-10 * variance) << j;
    // The same direction (up to sign) as the j-th left singular vector.
    EXPECT_NEAR(std::abs(pca.basis().col(j).dot(svd.matrixU().col(j))), 1.0, 1e-9) << j;
  }
}

// PCA about a given centre (the evaluation's "PCA (neutral)"): the zero coefficients
// give the centre exactly and the centre encodes to zero. It is a PCA of the
// displacements from the centre, uncentred: surfaces on a line that misses the centre
// (centre + offset + t mode) take two components about the centre, where one holds them
// about their mean (a PCA that recentred on the mean would reproduce them with one).
TEST(SurfacePcaTest, PcaAboutAGivenCentreIsOfTheDisplacementsFromIt) {
  std::mt19937 rng(5);
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::Matrix3Xd centre(3, kVertices), offset(3, kVertices), mode(3, kVertices);
  for (Eigen::Matrix3Xd* m : {&centre, &offset, &mode}) {
    for (Eigen::Index i = 0; i < m->size(); ++i) m->data()[i] = normal(rng);
  }
  std::vector<Eigen::Matrix3Xd> surfaces;
  for (int i = 0; i < 5; ++i) surfaces.push_back(centre + offset + normal(rng) * mode);
  const auto worst_error = [&](const SurfacePca& pca) {
    double worst = 0.0;
    for (const Eigen::Matrix3Xd& s : surfaces) {
      worst = std::max(worst, (pca.Decode(pca.Encode(s)) - s).cwiseAbs().maxCoeff());
    }
    return worst;
  };
  const SurfacePca about_mean(surfaces, 1);
  EXPECT_LT(worst_error(about_mean), 1e-10);
  const SurfacePca one(surfaces, 1, &centre);
  ASSERT_EQ(one.num_components(), 1);
  EXPECT_LT((one.Decode(Eigen::VectorXd::Zero(1)) - centre).cwiseAbs().maxCoeff(), 1e-13);
  EXPECT_LT(one.Encode(centre).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_GT(worst_error(one), 1e-2);
  const SurfacePca two(surfaces, 2, &centre);
  ASSERT_EQ(two.num_components(), 2);
  EXPECT_LT((two.Decode(Eigen::VectorXd::Zero(2)) - centre).cwiseAbs().maxCoeff(), 1e-13);
  EXPECT_LT(worst_error(two), 1e-10);
}

// Too few markers to determine the coefficients (one marker, 3 rows, for 5 components):
// ridge 0 gives the limit of small ridges (the solution of least whitened norm), not
// whichever least-squares solution a pivoted QR picks.
TEST(SurfacePcaTest, NoRidgeWithTooFewMarkersIsTheLimitOfSmallRidges) {
  const std::vector<Eigen::Matrix3Xd> surfaces = LinearSurfaces(10, 6, 6);
  const SurfacePca pca(surfaces, 5);
  ASSERT_EQ(pca.num_components(), 5);
  const std::vector<int> markers = {7};
  const Eigen::Matrix3Xd at = surfaces[3].col(7) + Eigen::Vector3d(0.1, -0.2, 0.05);
  const Eigen::Matrix3Xd none = pca.FitToVerticesRidge(markers, at, 0.0);
  const Eigen::Matrix3Xd small = pca.FitToVerticesRidge(markers, at, 1e-9);
  EXPECT_LT((none - small).cwiseAbs().maxCoeff(), 1e-6 * (small - pca.Decode(
      Eigen::VectorXd::Zero(5))).cwiseAbs().maxCoeff());
  EXPECT_LT((none.col(7) - at.col(0)).norm(), 1e-10);  // still through the marker
}

// The ridge fit minimizes |A c - b|^2 + ridge sum_j c_j^2 / variance_j over the markers'
// rows A of the basis (b: the markers less the mean), recomputed here as one stacked
// least-squares problem: the ridge is divided by each component's own variance.
TEST(SurfacePcaTest, RidgeFitMinimizesTheMarkersMisfitPlusRidgeOverVariances) {
  const std::vector<Eigen::Matrix3Xd> surfaces = LinearSurfaces(12, 5, 3);
  const SurfacePca pca(surfaces, 5);
  ASSERT_EQ(pca.num_components(), 5);
  ASSERT_GT(pca.variances().maxCoeff(), 2.0 * pca.variances().minCoeff());
  const std::vector<int> markers = {4, 17};
  Eigen::Matrix3Xd at = surfaces[2](Eigen::all, markers);
  at(1, 0) += 0.3;
  const double ridge = 0.37;
  const int k = pca.num_components();
  const int rows = 3 * static_cast<int>(markers.size());
  Eigen::MatrixXd stacked = Eigen::MatrixXd::Zero(rows + k, k);
  Eigen::VectorXd right = Eigen::VectorXd::Zero(rows + k);
  for (size_t i = 0; i < markers.size(); ++i) {
    stacked.middleRows(3 * i, 3) = pca.basis().middleRows(3 * markers[i], 3);
    right.segment<3>(3 * i) = at.col(i) - pca.mean().segment<3>(3 * markers[i]);
  }
  for (int j = 0; j < k; ++j) stacked(rows + j, j) = std::sqrt(ridge / pca.variances()[j]);
  const Eigen::VectorXd c = stacked.colPivHouseholderQr().solve(right);
  const Eigen::Matrix3Xd expected = pca.Decode(c);
  const Eigen::Matrix3Xd fitted = pca.FitToVerticesRidge(markers, at, ridge);
  EXPECT_LT((fitted - expected).cwiseAbs().maxCoeff(), 1e-10 * expected.cwiseAbs().maxCoeff());
}

// Markers that determine the coefficients: no ridge reproduces a left-out surface
// exactly, and a large one pulls it to the mean; ridge 0 wins.
TEST(SurfacePcaTest, LeaveOneOutPrefersNoRidgeWhereMarkersDetermineTheFit) {
  const std::vector<Eigen::Matrix3Xd> surfaces = LinearSurfaces(8, 2, 2);
  const RidgeChoice choice = ChooseRidgeLeaveOneOut(surfaces, 2, {1, 7, 12, 20}, {}, {1e6, 0.0});
  EXPECT_EQ(choice.ridge, 0.0);
  EXPECT_LT(choice.loo_error, 1e-9);
  ASSERT_EQ(choice.errors.size(), 2u);
  EXPECT_GT(choice.errors[0], 0.1);
  EXPECT_EQ(choice.loo_error, choice.errors[1]);
}

// One marker (3 numbers) for 5 coefficients: unregularized least squares is
// underdetermined and errs; a ridge (the training spread as a prior) does better.
TEST(SurfacePcaTest, LeaveOneOutChoosesARidgeWhereMarkersAreFew) {
  const std::vector<Eigen::Matrix3Xd> surfaces = LinearSurfaces(12, 5, 3);
  const RidgeChoice choice =
      ChooseRidgeLeaveOneOut(surfaces, 5, {4}, {}, {0.0, 0.01, 0.1, 1.0, 10.0});
  EXPECT_GT(choice.ridge, 0.0);
  EXPECT_LT(choice.loo_error, choice.errors[0]);
  // Ties go to the first candidate.
  const RidgeChoice tie = ChooseRidgeLeaveOneOut(surfaces, 5, {4}, {}, {0.1, 0.1});
  EXPECT_EQ(tie.errors[0], tie.errors[1]);
  EXPECT_EQ(tie.ridge, 0.1);
}

}  // namespace
}  // namespace aqs
