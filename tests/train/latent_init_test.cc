#include "train/latent_init.h"

#include <random>

#include <gtest/gtest.h>

namespace aqs {
namespace {

// Random samples (D x P) spanning a few directions, plus noise.
Eigen::MatrixXd RandomSamples(int d, int p, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::MatrixXd samples(d, p);
  for (int i = 0; i < samples.size(); ++i) samples.data()[i] = normal(rng);
  return samples;
}

// About the mean: every row has zero mean, squares summing to P - 1, and the rows are
// orthogonal (uncorrelated components).
TEST(WhitenedPcaScoresTest, AboutTheMeanTheScoresAreWhite) {
  const int p = 7;
  const Eigen::MatrixXd samples = RandomSamples(40, p, 3);
  const Eigen::MatrixXd z = WhitenedPcaScores(samples, Eigen::VectorXd::Ones(40), 4);
  ASSERT_EQ(z.rows(), 4);
  ASSERT_EQ(z.cols(), p);
  const Eigen::MatrixXd gram = z * z.transpose();
  EXPECT_TRUE(gram.isApprox((p - 1) * Eigen::MatrixXd::Identity(4, 4), 1e-10)) << gram;
  EXPECT_LT(z.rowwise().sum().cwiseAbs().maxCoeff(), 1e-10);
}

// About a given centre: the components are those of the displacements from it. A
// sample equal to the centre scores zero; the scores keep the displacements' Gram
// matrix up to the whitening (projected on the leading components, with all P
// components the Gram of the whitened scores' columns is diagonal in that basis), and
// a sample that is the centre plus twice another's displacement scores twice as much.
TEST(WhitenedPcaScoresTest, AboutAGivenCentreTheCentreScoresZero) {
  const int d = 30;
  Eigen::MatrixXd samples = RandomSamples(d, 6, 5);
  const Eigen::VectorXd center = Eigen::VectorXd::LinSpaced(d, -1.0, 2.0);
  samples.col(2) = center;                                            // the neutral
  samples.col(5) = center + 2.0 * (samples.col(1) - center);          // twice pose 1
  const Eigen::MatrixXd z = WhitenedPcaScores(samples, Eigen::VectorXd::Ones(d), 3, &center);
  EXPECT_LT(z.col(2).norm(), 1e-12);
  EXPECT_TRUE(z.col(5).isApprox(2.0 * z.col(1), 1e-9)) << z;
  // The mean is not the centre here, so the scores of the other samples do not sum to 0.
  EXPECT_GT(z.rowwise().sum().cwiseAbs().maxCoeff(), 1e-3);
  const Eigen::MatrixXd gram = z * z.transpose();
  EXPECT_TRUE(gram.isApprox(5.0 * Eigen::MatrixXd::Identity(3, 3), 1e-10)) << gram;
  // Differs from the scores about the mean.
  const Eigen::MatrixXd about_mean = WhitenedPcaScores(samples, Eigen::VectorXd::Ones(d), 3);
  EXPECT_GT(about_mean.col(2).norm(), 1e-3);
}

// Rows beyond the number of non-trivial components are zero: P samples about their
// mean have at most P - 1.
TEST(WhitenedPcaScoresTest, ExtraRowsAreZero) {
  const Eigen::MatrixXd samples = RandomSamples(20, 3, 9);
  const Eigen::MatrixXd z = WhitenedPcaScores(samples, Eigen::VectorXd::Ones(20), 5);
  EXPECT_GT(z.row(1).norm(), 1.0);
  EXPECT_EQ(z.bottomRows(3).norm(), 0.0);
}

// A row weight is a multiplicity: weights of 2 on some rows give the scores of the
// samples with those rows written twice and every weight 1 (each component up to its
// sign, which an eigenvector does not fix).
TEST(WhitenedPcaScoresTest, ARowOfWeightTwoCountsAsTheRowTwice) {
  const int d = 12;
  const Eigen::MatrixXd samples = RandomSamples(d, 6, 11);
  Eigen::VectorXd weights = Eigen::VectorXd::Ones(d);
  weights.head(4).setConstant(2.0);
  Eigen::MatrixXd doubled(d + 4, samples.cols());
  doubled << samples, samples.topRows(4);
  const Eigen::MatrixXd weighted = WhitenedPcaScores(samples, weights, 3);
  const Eigen::MatrixXd repeated = WhitenedPcaScores(doubled, Eigen::VectorXd::Ones(d + 4), 3);
  for (int k = 0; k < 3; ++k) {
    const double sign = weighted.row(k).dot(repeated.row(k)) < 0.0 ? -1.0 : 1.0;
    EXPECT_LT((weighted.row(k) - sign * repeated.row(k)).norm(), 1e-9 * repeated.row(k).norm())
        << "component " << k;
  }
}

}  // namespace
}  // namespace aqs
