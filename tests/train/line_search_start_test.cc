#include "train/line_search_start.h"

#include <random>
#include <vector>

#include <gtest/gtest.h>

namespace aqs {
namespace {

Eigen::VectorXd RandomPoint(std::mt19937* rng) {
  std::normal_distribution<double> normal;
  Eigen::VectorXd x(7);
  for (int i = 0; i < x.size(); ++i) x[i] = normal(*rng);
  return x;
}

std::vector<const Eigen::VectorXd*> Pointers(const std::vector<Eigen::VectorXd>& points) {
  std::vector<const Eigen::VectorXd*> pointers;
  for (const Eigen::VectorXd& p : points) pointers.push_back(&p);
  return pointers;
}

// The line found reproduces the point.
void ExpectReproduces(const std::vector<Eigen::VectorXd>& points, const Eigen::VectorXd& x,
                      const PointOnLine& line) {
  ASSERT_GE(line.from, 0);
  ASSERT_GE(line.to, 0);
  const Eigen::VectorXd on_line =
      points[line.from] + line.t * (points[line.to] - points[line.from]);
  EXPECT_LT((on_line - x).norm(), 1e-12 * x.norm());
}

// FindPointOnLine finds x on the line from points[from] to points[to] at t.
void ExpectLine(const std::vector<Eigen::VectorXd>& points, const Eigen::VectorXd& x, int from,
                int to, double t) {
  PointOnLine line;
  ASSERT_TRUE(FindPointOnLine(Pointers(points), x.data(), &line));
  EXPECT_EQ(line.from, from);
  EXPECT_EQ(line.to, to);
  EXPECT_NEAR(line.t, t, 1e-12);
  ExpectReproduces(points, x, line);
}

TEST(FindPointOnLineTest, FindsTheBacktrackOfALineSearch) {
  std::mt19937 rng(1);
  const Eigen::VectorXd base = RandomPoint(&rng), direction = RandomPoint(&rng);
  // An earlier iteration's point, the base, the rejected unit step; then the trial 0.3.
  const std::vector<Eigen::VectorXd> points = {RandomPoint(&rng), base, base + direction};
  const Eigen::VectorXd trial = base + 0.3 * direction;
  PointOnLine line;
  ASSERT_TRUE(FindPointOnLine(Pointers(points), trial.data(), &line));
  EXPECT_GT(line.t, 0.0);
  EXPECT_LT(line.t, 1.0);
  EXPECT_TRUE((line.from == 1 && line.to == 2) || (line.from == 2 && line.to == 1));
  ExpectReproduces(points, trial, line);
}

TEST(FindPointOnLineTest, PrefersTheTightestBracket) {
  std::mt19937 rng(2);
  const Eigen::VectorXd base = RandomPoint(&rng), direction = RandomPoint(&rng);
  // A zoom: the base, the step 1 (too long), the step 0.5 (too short); the trial 0.7.
  const std::vector<Eigen::VectorXd> points = {base, base + direction, base + 0.5 * direction};
  const Eigen::VectorXd trial = base + 0.7 * direction;
  PointOnLine line;
  ASSERT_TRUE(FindPointOnLine(Pointers(points), trial.data(), &line));
  EXPECT_TRUE((line.from == 1 && line.to == 2) || (line.from == 2 && line.to == 1));
  ExpectReproduces(points, trial, line);
}

TEST(FindPointOnLineTest, ExtrapolatesAnExpansionFromTheNearerEnd) {
  std::mt19937 rng(3);
  const Eigen::VectorXd base = RandomPoint(&rng), direction = RandomPoint(&rng);
  const std::vector<Eigen::VectorXd> points = {base, base + direction};
  // Ceres' largest expansion.
  ExpectLine(points, base + 10.0 * direction, 0, 1, 10.0);
  // Beyond kPointOnLineMaxT times the span: too far to extrapolate.
  const Eigen::VectorXd far = base + 25.0 * direction;
  PointOnLine line;
  EXPECT_FALSE(FindPointOnLine(Pointers(points), far.data(), &line));
}

// The remembered points in either order: an expansion beyond the older point (the
// newer one is the base), and a backtrack beyond the older of two trial points whose
// base has left the memory (t = 1.8 from the newer one through the older).
TEST(FindPointOnLineTest, TheOrderOfTheRememberedPointsDoesNotMatter) {
  std::mt19937 rng(5);
  const Eigen::VectorXd base = RandomPoint(&rng), direction = RandomPoint(&rng);
  ExpectLine({base + direction, base}, base + 10.0 * direction, 1, 0, 10.0);
  ExpectLine({base + 0.5 * direction, base + direction}, base + 0.1 * direction, 1, 0, 1.8);
}

TEST(FindPointOnLineTest, RefusesPointsOffTheLineRepeatsAndTooFewPoints) {
  std::mt19937 rng(4);
  const std::vector<Eigen::VectorXd> points = {RandomPoint(&rng), RandomPoint(&rng),
                                               RandomPoint(&rng)};
  PointOnLine line;
  // A new L-BFGS direction from the last point: on no line through two earlier points.
  const Eigen::VectorXd next = points[2] + 0.5 * RandomPoint(&rng);
  EXPECT_FALSE(FindPointOnLine(Pointers(points), next.data(), &line));
  // Slightly off a line (1e-6 relative): refused.
  Eigen::VectorXd off = points[0] + 0.5 * (points[1] - points[0]);
  off[0] += 1e-6 * (points[1] - points[0]).norm();
  EXPECT_FALSE(FindPointOnLine(Pointers(points), off.data(), &line));
  // A repeat of an evaluated point.
  EXPECT_FALSE(FindPointOnLine(Pointers(points), points[1].data(), &line));
  // One point holds no line.
  const std::vector<Eigen::VectorXd> one = {points[0]};
  const Eigen::VectorXd any = points[1];
  EXPECT_FALSE(FindPointOnLine(Pointers(one), any.data(), &line));
}

// The curved warm start is the quadratic in the trial's coordinate through the far end
// and the warm start, with the near end (the last evaluation) as its vertex's side: the
// far end at the far end, the warm start at the near end, constant second differences,
// and the same curve seen from either end of the line.
TEST(CurvedLineStartTest, PassesThroughTheFarEndAndTheWarmStartAndIsQuadratic) {
  std::mt19937 rng(17);
  std::normal_distribution<double> normal;
  auto random = [&]() {
    Eigen::Matrix3Xd m(3, 5);
    for (Eigen::Index i = 0; i < m.size(); ++i) m.data()[i] = normal(rng);
    return m;
  };
  const Eigen::Matrix3Xd from = random(), to = random(), start = random();
  const double tolerance = 1e-12 * (from.norm() + to.norm() + start.norm());
  Eigen::Matrix3Xd c0, c1, c;
  // The last evaluation at `to`: from at t = 0, the warm start at t = 1.
  ASSERT_TRUE(CurvedLineStart(from, to, 0.0, to, start, &c0));
  ASSERT_TRUE(CurvedLineStart(from, to, 1.0, to, start, &c1));
  EXPECT_LT((c0 - from).norm(), tolerance);
  EXPECT_LT((c1 - start).norm(), tolerance);
  // At `from`: to at t = 1, the warm start at t = 0.
  ASSERT_TRUE(CurvedLineStart(from, to, 1.0, from, start, &c1));
  ASSERT_TRUE(CurvedLineStart(from, to, 0.0, from, start, &c0));
  EXPECT_LT((c1 - to).norm(), tolerance);
  EXPECT_LT((c0 - start).norm(), tolerance);
  // Quadratic in t: equal second differences over t = 0.2, 0.5, 0.8, 1.1 (an expansion
  // beyond the bracket too), and the same curve as the line reversed.
  for (const Eigen::Matrix3Xd* last : {&from, &to}) {
    std::vector<Eigen::Matrix3Xd> points;
    for (const double t : {0.2, 0.5, 0.8, 1.1}) {
      ASSERT_TRUE(CurvedLineStart(from, to, t, *last, start, &c));
      points.push_back(c);
      Eigen::Matrix3Xd reversed;
      ASSERT_TRUE(CurvedLineStart(to, from, 1.0 - t, *last, start, &reversed));
      EXPECT_LT((reversed - c).norm(), tolerance);
    }
    const Eigen::Matrix3Xd second = points[2] - 2.0 * points[1] + points[0];
    EXPECT_LT((points[3] - 2.0 * points[2] + points[1] - second).norm(), tolerance);
    EXPECT_GT(second.norm(), 1e-3) << "curved, not the chord";
  }
  // The warm start from neither end: no candidate, the output untouched.
  c = start;
  EXPECT_FALSE(CurvedLineStart(from, to, 0.5, random(), start, &c));
  EXPECT_EQ(c, start);
}

}  // namespace
}  // namespace aqs
