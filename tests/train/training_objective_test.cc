#include "train/end_to_end_objective.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <limits>
#include <random>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "diff/equilibrium_differentiator.h"
#include "physics/actuation.h"
#include "physics/boundary_conditions.h"
#include "testing/finite_difference.h"
#include "testing/training_fixtures.h"
#include "util/fault_injection.h"

namespace aqs {
namespace {

// The synthetic bar with 4 poses, volumetric targets and a small pre-trained decoder
// (tanh, a coarse grid: a few dozen control nodes).
ActiveModel PretrainedBar() {
  testing::SyntheticBarSpec spec;
  spec.activation = Activation::kTanh;
  spec.node_spacing = 0.35;
  return testing::PretrainedSyntheticBar(spec);
}

// A random walk from `start`: `steps` points, the first `start` itself, each next one
// moved by normal noise of deviation `sigma` in every parameter.
std::vector<Eigen::VectorXd> RandomWalk(const Eigen::VectorXd& start, int steps, double sigma,
                                        unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0.0, sigma);
  std::vector<Eigen::VectorXd> points = {start};
  while (static_cast<int>(points.size()) < steps) {
    Eigen::VectorXd x = points.back();
    for (int i = 0; i < x.size(); ++i) x[i] += normal(rng);
    points.push_back(x);
  }
  return points;
}

// Evaluates both objectives with gradients at x: their costs agree to `cost_tolerance`
// (relative) and their gradients to `gradient_tolerance` of b's largest component.
void ExpectAgreeAt(const EndToEndObjective& a, const EndToEndObjective& b,
                   const Eigen::VectorXd& x, double cost_tolerance, double gradient_tolerance,
                   const std::string& where) {
  double ca = 0, cb = 0;
  Eigen::VectorXd ga(x.size()), gb(x.size());
  ASSERT_TRUE(a.Evaluate(x.data(), &ca, ga.data())) << where << ": " << a.last_failure();
  ASSERT_TRUE(b.Evaluate(x.data(), &cb, gb.data())) << where << ": " << b.last_failure();
  EXPECT_NEAR(ca, cb, cost_tolerance * cb) << where;
  EXPECT_LT((ga - gb).cwiseAbs().maxCoeff(), gradient_tolerance * gb.cwiseAbs().maxCoeff())
      << where;
}

// The gradient of the end-to-end objective with respect to decoder weights and latents
// against central differences of the whole objective, re-solving every equilibrium;
// without and with the equilibrium-energy regularizer (which must add to the cost).
//
// Then the demo's decoder form (anchored at the origin, a linear skip, ELU, wider), at
// its pre-trained point and at a point moved off it (a random step in every parameter,
// as after some training), with the energy regularizer.
struct ObjectiveCheck {
  std::string name;
  ActiveModel model;
  double energy_weight = 0.0;
  double step = 0.0;  // deviation of the random move off the pre-trained point (0: none)
};

std::vector<ObjectiveCheck> ObjectiveChecks() {
  std::vector<ObjectiveCheck> checks;
  const ActiveModel tanh_bar = PretrainedBar();
  checks.push_back({"tanh, energy 0", tanh_bar, 0.0, 0.0});
  checks.push_back({"tanh, energy 10", tanh_bar, 10.0, 0.0});
  testing::SyntheticBarSpec spec;
  spec.activation = Activation::kElu;
  spec.anchored = true;
  spec.linear_skip = true;
  spec.hidden = 12;
  spec.node_spacing = 0.35;
  const ActiveModel demo_form = testing::PretrainedSyntheticBar(spec);
  checks.push_back({"anchored ELU with skip, energy 0.1", demo_form, 0.1, 0.0});
  checks.push_back({"anchored ELU with skip, energy 0.1, moved", demo_form, 0.1, 3e-3});
  return checks;
}

// The objective's gradient at x0 (`gradient`) against central differences of the
// re-solved objective in every latent and `decoder_samples` random decoder parameters
// (seed `seed`): each error, relative to max |g|, below `tolerance`. Returns the worst
// and sets *checked to the number of components compared.
double WorstGradientError(const EndToEndObjective& objective, const ActiveModel& model,
                          const Eigen::VectorXd& x0, const Eigen::VectorXd& gradient,
                          int decoder_samples, unsigned seed, double tolerance,
                          size_t* checked) {
  const int np = model.decoder->num_parameters();
  std::vector<int> indices;
  for (int i = np; i < objective.NumParameters(); ++i) indices.push_back(i);
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> pick(0, np - 1);
  for (int i = 0; i < decoder_samples; ++i) indices.push_back(pick(rng));
  double worst = 0;
  for (int i : indices) {
    auto f = [&](const Eigen::VectorXd& t) {
      Eigen::VectorXd x = x0;
      x[i] += t[0];
      double c = 0;
      EXPECT_TRUE(objective.Evaluate(x.data(), &c, nullptr)) << objective.last_failure();
      return c;
    };
    const double numeric = testing::CentralDifferenceGradient(f, Eigen::VectorXd::Zero(1), 1e-4)[0];
    const double error_i =
        std::abs(numeric - gradient[i]) / std::max(1e-8, gradient.cwiseAbs().maxCoeff());
    worst = std::max(worst, error_i);
    EXPECT_LT(error_i, tolerance) << "parameter " << i << ": analytic " << gradient[i]
                                  << " numeric " << numeric;
  }
  *checked = indices.size();
  return worst;
}

TEST(EndToEndObjectiveTest, GradientMatchesCentralDifferencesOfResolvedObjective) {
  double unregularized_cost = 0;
  for (const ObjectiveCheck& check : ObjectiveChecks()) {
    const ActiveModel& model = check.model;
    ASSERT_TRUE(model.decoder);
    const double energy_weight = check.energy_weight;
    SCOPED_TRACE(check.name);
    TrainOptions options;
    options.latent_regularization = 1e-2;
    options.decoder_regularization = 1e-3;
    options.energy_regularization = energy_weight;
    options.solver.relative_force_tolerance = 1e-12;  // Newton reaches round-off
    options.num_threads = 2;
    EndToEndObjective objective(options, model);
    const Eigen::VectorXd x0 =
        check.step > 0 ? RandomWalk(objective.ModelParameters(), 2, check.step, 9).back()
                       : objective.ModelParameters();
    double cost = 0;
    Eigen::VectorXd gradient(objective.NumParameters());
    ASSERT_TRUE(objective.Evaluate(x0.data(), &cost, gradient.data())) << objective.last_failure();
    if (check.name == "tanh, energy 0") {
      unregularized_cost = cost;
    } else if (check.name == "tanh, energy 10") {
      EXPECT_GT(cost, unregularized_cost * 1.01) << "the energy term adds to the cost";
    }

    // Every latent and a random sample of decoder parameters.
    size_t checked = 0;
    const double worst =
        WorstGradientError(objective, model, x0, gradient, 12, 4, 1e-7, &checked);
    std::printf("training objective (%s): %zu components checked, worst error %.2e (relative "
                "to max |g|)\n",
                check.name.c_str(), checked, worst);
    // And along random directions over every decoder parameter at once: a wrong
    // derivative confined to a few weights, which the sample above may miss, shows here
    // (each weight's share of a direction is about 1 / sqrt(parameters); review of
    // lib/train).
    const int np = model.decoder->num_parameters();
    const double decoder_norm = std::max(1e-8, gradient.head(np).norm());
    std::mt19937 rng(11);
    std::normal_distribution<double> normal;
    double worst_direction = 0;
    for (int k = 0; k < 3; ++k) {
      Eigen::VectorXd v = Eigen::VectorXd::Zero(objective.NumParameters());
      for (int i = 0; i < np; ++i) v[i] = normal(rng);
      v /= v.norm();
      auto f = [&](const Eigen::VectorXd& t) {
        const Eigen::VectorXd x = x0 + t[0] * v;
        double c = 0;
        EXPECT_TRUE(objective.Evaluate(x.data(), &c, nullptr)) << objective.last_failure();
        return c;
      };
      // The best of three steps: where an ELU's pre-activation crosses 0 within the
      // step, a central difference errs by up to (jump in curvature) x step / 4 (from one
      // pre-trained start 1.9e-8 and 4.6e-8 at 1e-4), which a smaller step shrinks; a
      // wrong derivative errs by the same amount at every step.
      double error = std::numeric_limits<double>::infinity();
      std::string errors;
      for (const double h : {1e-4, 1e-5, 1e-6}) {
        const double numeric =
            testing::CentralDifferenceGradient(f, Eigen::VectorXd::Zero(1), h)[0];
        const double error_h = std::abs(numeric - gradient.dot(v)) / decoder_norm;
        error = std::min(error, error_h);
        char text[64];
        std::snprintf(text, sizeof(text), " %.1e at %.0e", error_h, h);
        errors += text;
      }
      worst_direction = std::max(worst_direction, error);
      // Measured at most 4.2e-11 (2026-12-07); a weight's error of 1e-4 of a typical
      // component would show as about 3e-8.
      EXPECT_LT(error, 1e-8) << "direction " << k << ": analytic " << gradient.dot(v)
                             << ", errors" << errors;
      std::printf("  direction %d: errors%s\n", k, errors.c_str());
    }
    std::printf("  along 3 random directions over all %d decoder parameters: worst error %.2e "
                "(relative to |g_decoder|)\n",
                np, worst_direction);
  }
}

// last_failure() is the last evaluation's: a later evaluation that succeeds clears it, so
// that a solve's stop is not blamed on a failure many evaluations before.
TEST(EndToEndObjectiveTest, LastFailureIsTheLastEvaluations) {
  ActiveModel model = PretrainedBar();
  EndToEndObjective objective(TrainOptions(), model);
  const Eigen::VectorXd x = objective.ModelParameters();
  double cost = 0;
  objective.set_time_limit(1e-9);
  while (objective.Evaluate(x.data(), &cost, nullptr)) {}
  EXPECT_EQ(objective.last_failure(), "the time limit has passed");
  objective.set_time_limit(0.0);
  ASSERT_TRUE(objective.Evaluate(x.data(), &cost, nullptr)) << objective.last_failure();
  EXPECT_EQ(objective.last_failure(), "");
}

// A kept evaluation's equilibria outlive the few the objective remembers: after more
// evaluations than that (a line search's trial points after the one it accepted),
// StatesAt and UseStatesOf still find them, bit for bit, where an evaluation that was
// not kept is forgotten, and prefer them to those of a later evaluation at the same
// point.
TEST(EndToEndObjectiveTest, KeptStatesOutliveLaterEvaluations) {
  ActiveModel model = PretrainedBar();
  TrainOptions options;
  options.solver.relative_force_tolerance = 1e-11;
  EndToEndObjective objective(options, model);
  const int steps = 2 + EndToEndObjective::kRememberedEvaluations;
  const std::vector<Eigen::VectorXd> walk =
      RandomWalk(objective.ModelParameters(), steps, 1e-2, 9);
  double cost = 0;
  ASSERT_TRUE(objective.Evaluate(walk[0].data(), &cost, nullptr)) << objective.last_failure();
  const std::vector<Eigen::Matrix3Xd> kept = objective.states();
  ASSERT_TRUE(objective.KeepStatesOf(walk[0].data()));
  for (int i = 1; i < steps; ++i) {
    ASSERT_TRUE(objective.Evaluate(walk[i].data(), &cost, nullptr)) << objective.last_failure();
  }
  std::vector<Eigen::Matrix3Xd> states;
  EXPECT_FALSE(objective.StatesAt(walk[1].data(), &states));  // evaluated, not kept
  ASSERT_TRUE(objective.StatesAt(walk[0].data(), &states));
  double moved = 0;  // how far the last evaluation's equilibria are from the kept ones
  for (size_t p = 0; p < kept.size(); ++p) {
    EXPECT_TRUE(states[p].cwiseEqual(kept[p]).all()) << "pose " << p;
    moved = std::max(moved, (objective.states()[p] - kept[p]).cwiseAbs().maxCoeff());
  }
  EXPECT_GT(moved, 1e-6);
  // Evaluated again from the last point's equilibria: the kept ones still win.
  ASSERT_TRUE(objective.Evaluate(walk[0].data(), &cost, nullptr)) << objective.last_failure();
  double again = 0;
  for (size_t p = 0; p < kept.size(); ++p) {
    again = std::max(again, (objective.states()[p] - kept[p]).cwiseAbs().maxCoeff());
  }
  ASSERT_GT(again, 0.0) << "the second solve reached the same bits; the test shows nothing";
  ASSERT_TRUE(objective.StatesAt(walk[0].data(), &states));
  for (size_t p = 0; p < kept.size(); ++p) {
    EXPECT_TRUE(states[p].cwiseEqual(kept[p]).all()) << "pose " << p;
  }
  ASSERT_TRUE(objective.UseStatesOf(walk[0].data()));
  for (size_t p = 0; p < kept.size(); ++p) {
    EXPECT_TRUE(objective.states()[p].cwiseEqual(kept[p]).all()) << "pose " << p;
  }
}

// Ceres' line searches accept the lowest trial they evaluated (of those with sufficient
// decrease), which may come before more trials than the objective remembers: the
// evaluation of the lowest loss since the last kept point can still be kept, bit for
// bit, and the others that were forgotten cannot.
TEST(EndToEndObjectiveTest, KeepsTheLowestEvaluationSinceTheLastKeptPoint) {
  ActiveModel model = PretrainedBar();
  TrainOptions options;
  options.solver.relative_force_tolerance = 1e-11;
  EndToEndObjective objective(options, model), probe(options, model);
  const Eigen::VectorXd x0 = objective.ModelParameters();
  // Trial points, ordered by their loss (from an objective of their own), lowest first.
  std::vector<Eigen::VectorXd> trials =
      RandomWalk(x0, 3 + EndToEndObjective::kRememberedEvaluations, 1e-2, 10);
  trials.erase(trials.begin());
  std::vector<std::pair<double, int>> order;
  for (int i = 0; i < static_cast<int>(trials.size()); ++i) {
    double loss = 0;
    ASSERT_TRUE(probe.Evaluate(trials[i].data(), &loss, nullptr)) << probe.last_failure();
    order.emplace_back(loss, i);
  }
  std::sort(order.begin(), order.end());
  ASSERT_LT(order[0].first, 0.999 * order[1].first);

  double cost = 0;
  double mean = -1, max = -1;
  EXPECT_FALSE(objective.KeptSurfaceErrors(&mean, &max));  // nothing kept yet
  EXPECT_EQ(mean, -1);
  ASSERT_TRUE(objective.Evaluate(x0.data(), &cost, nullptr)) << objective.last_failure();
  ASSERT_TRUE(objective.KeepStatesOf(x0.data()));
  std::vector<Eigen::Matrix3Xd> lowest_states;
  double lowest_mean = 0, lowest_max = 0;
  for (const auto& [loss, i] : order) {
    ASSERT_TRUE(objective.Evaluate(trials[i].data(), &cost, nullptr)) << objective.last_failure();
    if (lowest_states.empty()) {
      lowest_states = objective.states();
      lowest_mean = objective.mean_surface_error();
      lowest_max = objective.max_surface_error();
    }
  }
  const Eigen::VectorXd& lowest = trials[order[0].second];
  const Eigen::VectorXd& forgotten = trials[order[1].second];
  std::vector<Eigen::Matrix3Xd> states;
  EXPECT_FALSE(objective.StatesAt(lowest.data(), &states));  // no longer remembered
  EXPECT_FALSE(objective.KeepStatesOf(forgotten.data()));
  ASSERT_TRUE(objective.KeepStatesOf(lowest.data()));
  ASSERT_TRUE(objective.StatesAt(lowest.data(), &states));
  for (size_t p = 0; p < states.size(); ++p) {
    EXPECT_TRUE(states[p].cwiseEqual(lowest_states[p]).all()) << "pose " << p;
  }
  // The kept point's surface errors, not the last evaluation's (what the training log
  // writes beside the accepted loss).
  ASSERT_TRUE(objective.KeptSurfaceErrors(&mean, &max));
  EXPECT_EQ(mean, lowest_mean);
  EXPECT_EQ(max, lowest_max);
  EXPECT_NE(mean, objective.mean_surface_error());
}

// The decoder regularizer adds lambda |params|^2 to the cost and 2 lambda params to the
// decoder part of the gradient, and nothing to the latents' (the central differences
// above check the whole gradient with it on); negative or non-finite weights are refused.
TEST(EndToEndObjectiveTest, DecoderRegularizationIsWeightDecay) {
  ActiveModel model = PretrainedBar();
  TrainOptions plain;
  plain.solver.relative_force_tolerance = 1e-12;
  TrainOptions decayed = plain;
  decayed.decoder_regularization = 0.05;
  std::string error;
  ASSERT_TRUE(decayed.Validate(&error)) << error;
  EndToEndObjective plain_objective(plain, model), decayed_objective(decayed, model);
  const Eigen::VectorXd x = plain_objective.ModelParameters();
  const int np = model.decoder->num_parameters();
  double plain_cost = 0, decayed_cost = 0;
  Eigen::VectorXd plain_gradient(x.size()), decayed_gradient(x.size());
  ASSERT_TRUE(plain_objective.Evaluate(x.data(), &plain_cost, plain_gradient.data()));
  ASSERT_TRUE(decayed_objective.Evaluate(x.data(), &decayed_cost, decayed_gradient.data()));
  const double decay = 0.05 * x.head(np).squaredNorm();
  ASSERT_GT(decay, 0.1 * plain_cost);  // large enough to be seen
  EXPECT_NEAR(decayed_cost - plain_cost, decay, 1e-10 * decayed_cost);
  const Eigen::VectorXd difference = decayed_gradient - plain_gradient;
  EXPECT_LT((difference.head(np) - 0.1 * x.head(np)).cwiseAbs().maxCoeff(),
            1e-9 * decayed_gradient.cwiseAbs().maxCoeff());
  EXPECT_LT(difference.tail(x.size() - np).cwiseAbs().maxCoeff(),
            1e-9 * decayed_gradient.cwiseAbs().maxCoeff());
  for (double bad : {-1e-3, std::numeric_limits<double>::quiet_NaN()}) {
    TrainOptions refused = plain;
    refused.decoder_regularization = bad;
    EXPECT_FALSE(refused.Validate(&error)) << bad;
    EXPECT_NE(error.find("decoder_regularization"), std::string::npos) << error;
  }
}

// A model of one pose keeps its solver and factor too (it refactorized at every
// evaluation): evaluations at nearby points reuse the factor.
TEST(EndToEndObjectiveTest, OnePoseKeepsItsOwnFactor) {
  testing::SyntheticBarSpec spec;
  spec.activation = Activation::kTanh;
  spec.node_spacing = 0.35;
  spec.num_poses = 1;
  ActiveModel model = testing::PretrainedSyntheticBar(spec);
  ASSERT_EQ(model.num_poses(), 1);
  TrainOptions options;
  options.solver.relative_force_tolerance = 1e-11;
  TrainOptions shared = options;
  shared.max_factor_cache_gb = 0.0;
  EndToEndObjective own(options, model), one_of_many(shared, model);
  EXPECT_TRUE(own.solver_per_pose());
  for (const Eigen::VectorXd& x : RandomWalk(own.ModelParameters(), 4, 1e-3, 3)) {
    ExpectAgreeAt(own, one_of_many, x, 1e-9, 1e-6, "one pose");
  }
  EXPECT_LT(own.total_counters().factorizations, one_of_many.total_counters().factorizations);
}

// One solver and factor per pose (factors reused by CG, states predicted to first
// order) and one solver per thread give the same objective and gradient.
TEST(EndToEndObjectiveTest, SolverLayoutsAgree) {
  ActiveModel model = PretrainedBar();
  TrainOptions options;
  options.solver.relative_force_tolerance = 1e-11;
  TrainOptions shared = options;
  shared.max_factor_cache_gb = 0.0;
  EndToEndObjective per_pose_objective(options, model), shared_objective(shared, model);
  ASSERT_TRUE(per_pose_objective.solver_per_pose());
  ASSERT_FALSE(shared_objective.solver_per_pose());
  int step = 0;
  for (const Eigen::VectorXd& x : RandomWalk(per_pose_objective.ModelParameters(), 3, 1e-3, 5)) {
    ExpectAgreeAt(per_pose_objective, shared_objective, x, 1e-9, 1e-6,
                  "step " + std::to_string(step++));
  }
  // After the first evaluation the per-pose factors serve later solves and adjoints.
  EXPECT_GT(per_pose_objective.total_counters().reused_solves, 0);
  EXPECT_LT(per_pose_objective.total_counters().factorizations,
            shared_objective.total_counters().factorizations);
}

// Solvers per thread that keep each pose's factor in single precision between its
// evaluations (a budget that holds those copies but not a solver per pose) give the
// objective and gradient of a fresh factorization per evaluation, with fewer
// factorizations; a budget for some of the copies keeps the first poses' only.
TEST(EndToEndObjectiveTest, StoredFactorsServeSharedSolvers) {
  ActiveModel model = PretrainedBar();
  ASSERT_GE(model.num_poses(), 3);
  TrainOptions shared;
  shared.solver.relative_force_tolerance = 1e-11;
  shared.num_threads = 2;
  shared.max_factor_cache_gb = 0.0;
  EndToEndObjective shared_objective(shared, model);
  EXPECT_EQ(shared_objective.num_stored_factors(), 0);
  const double copy_gb = shared_objective.stored_factor_gb();
  ASSERT_GT(copy_gb, 0.0);
  ASSERT_LT(2.0 * copy_gb, shared_objective.factor_gb());
  TrainOptions stored = shared;
  stored.max_factor_cache_gb = 1.0001 * copy_gb * model.num_poses();
  TrainOptions some = shared;
  some.max_factor_cache_gb = 1.0001 * copy_gb * 2;
  EndToEndObjective stored_objective(stored, model), some_objective(some, model);
  ASSERT_FALSE(stored_objective.solver_per_pose());
  EXPECT_EQ(stored_objective.num_stored_factors(), model.num_poses());
  ASSERT_FALSE(some_objective.solver_per_pose());
  EXPECT_EQ(some_objective.num_stored_factors(), 2);
  Eigen::VectorXd x = shared_objective.ModelParameters();
  std::mt19937 rng(6);
  std::normal_distribution<double> normal(0.0, 1e-4);  // steps late in training
  for (int step = 0; step < 3; ++step) {
    if (step > 0) {
      for (int i = 0; i < x.size(); ++i) x[i] += normal(rng);
    }
    double c0 = 0, c1 = 0, c2 = 0;
    Eigen::VectorXd g0(x.size()), g1(x.size()), g2(x.size());
    ASSERT_TRUE(shared_objective.Evaluate(x.data(), &c0, g0.data())) << shared_objective.last_failure();
    ASSERT_TRUE(stored_objective.Evaluate(x.data(), &c1, g1.data())) << stored_objective.last_failure();
    ASSERT_TRUE(some_objective.Evaluate(x.data(), &c2, g2.data())) << some_objective.last_failure();
    EXPECT_NEAR(c1, c0, 1e-9 * c0) << "step " << step;
    EXPECT_NEAR(c2, c0, 1e-9 * c0) << "step " << step;
    EXPECT_LT((g1 - g0).cwiseAbs().maxCoeff(), 1e-6 * g0.cwiseAbs().maxCoeff()) << "step " << step;
    EXPECT_LT((g2 - g0).cwiseAbs().maxCoeff(), 1e-6 * g0.cwiseAbs().maxCoeff()) << "step " << step;
  }
  const int all_stored = stored_objective.total_counters().factorizations;
  const int some_stored = some_objective.total_counters().factorizations;
  const int none_stored = shared_objective.total_counters().factorizations;
  std::printf("factorizations over 3 evaluations: every factor stored %d, 2 stored %d, none %d\n",
              all_stored, some_stored, none_stored);
  EXPECT_LT(all_stored, none_stored);
  EXPECT_LE(all_stored, some_stored);
  EXPECT_LE(some_stored, none_stored);
}

// An evaluation that fails (one pose's equilibrium not reached) keeps every pose's warm
// start, also those of the poses that did converge.
TEST(EndToEndObjectiveTest, FailedEvaluationKeepsEveryWarmStart) {
  ActiveModel model = PretrainedBar();
  EndToEndObjective objective(TrainOptions(), model);
  Eigen::VectorXd x = objective.ModelParameters();
  double cost = 0;
  ASSERT_TRUE(objective.Evaluate(x.data(), &cost, nullptr)) << objective.last_failure();
  const std::vector<Eigen::Matrix3Xd> before = objective.states();
  const int np = model.decoder->num_parameters(), d = model.latent_dim();
  x.segment(np, d) *= 1.001;            // pose 0: a small change, solved
  x[np + d] = std::numeric_limits<double>::quiet_NaN();  // pose 1: actuations refused
  EXPECT_FALSE(objective.Evaluate(x.data(), &cost, nullptr));
  ASSERT_EQ(objective.states().size(), before.size());
  for (size_t p = 0; p < before.size(); ++p) {
    EXPECT_EQ((objective.states()[p] - before[p]).cwiseAbs().maxCoeff(), 0.0) << "pose " << p;
  }
  // Every pose solved, but a loss that is not finite (a latent of 1e160: the tanh decoder
  // saturates, its square overflows): failed too, and nothing moves either.
  Eigen::VectorXd huge = objective.ModelParameters();
  huge[np + d] = 1e160;
  EXPECT_FALSE(objective.Evaluate(huge.data(), &cost, nullptr));
  EXPECT_NE(objective.last_failure().find("not finite"), std::string::npos)
      << objective.last_failure();
  for (size_t p = 0; p < before.size(); ++p) {
    EXPECT_EQ((objective.states()[p] - before[p]).cwiseAbs().maxCoeff(), 0.0) << "pose " << p;
  }
  std::vector<Eigen::Matrix3Xd> remembered;
  EXPECT_FALSE(objective.StatesAt(huge.data(), &remembered));
}

// Once a pose fails, the poses not yet begun are skipped (the evaluation fails anyway):
// one thread, the first pose refused, no other pose solved.
TEST(EndToEndObjectiveTest, FailedPoseEndsTheEvaluationEarly) {
  ActiveModel model = PretrainedBar();
  TrainOptions options;
  options.num_threads = 1;
  EndToEndObjective objective(options, model);
  Eigen::VectorXd x = objective.ModelParameters();
  double cost = 0;
  ASSERT_TRUE(objective.Evaluate(x.data(), &cost, nullptr)) << objective.last_failure();
  const int np = model.decoder->num_parameters();
  x.tail(x.size() - np) *= 1.01;  // every pose moves: each would need Newton steps
  Eigen::VectorXd refused = x;
  refused[np] = std::numeric_limits<double>::quiet_NaN();  // pose 0: actuations refused
  EXPECT_FALSE(objective.Evaluate(refused.data(), &cost, nullptr));
  EXPECT_NE(objective.last_failure().find(model.poses[0].name), std::string::npos)
      << objective.last_failure();
  EXPECT_EQ(objective.last_counters().newton_steps, 0);
  EXPECT_EQ(objective.last_counters().factorizations, 0);
  ASSERT_TRUE(objective.Evaluate(x.data(), &cost, nullptr)) << objective.last_failure();
  EXPECT_GT(objective.last_counters().newton_steps, 0);
}

// Past its time limit an evaluation fails at once (a failed line-search step), and
// lifting the limit restores the same value.
TEST(EndToEndObjectiveTest, TimeLimitFailsEvaluationsUntilLifted) {
  ActiveModel model = PretrainedBar();
  ASSERT_TRUE(model.decoder);
  TrainOptions options;
  options.num_threads = 2;
  EndToEndObjective objective(options, model);
  const Eigen::VectorXd x0 = objective.ModelParameters();
  double before = 0, after = 0, limited = -1;
  ASSERT_TRUE(objective.Evaluate(x0.data(), &before, nullptr)) << objective.last_failure();
  objective.set_time_limit(1e-6);
  std::this_thread::sleep_for(std::chrono::milliseconds(5));
  EXPECT_FALSE(objective.Evaluate(x0.data(), &limited, nullptr));
  EXPECT_EQ(limited, -1);  // untouched
  EXPECT_EQ(objective.last_failure(), "the time limit has passed");
  objective.set_time_limit(0.0);
  ASSERT_TRUE(objective.Evaluate(x0.data(), &after, nullptr)) << objective.last_failure();
  EXPECT_NEAR(after, before, 1e-10 * before);
}

// The equilibria of recent evaluations are found again by their exact parameters and
// can be made the warm starts; older or other points are not found.
TEST(EndToEndObjectiveTest, RemembersTheEquilibriaOfRecentEvaluations) {
  ActiveModel model = PretrainedBar();
  ASSERT_TRUE(model.decoder);
  TrainOptions options;
  options.num_threads = 2;
  EndToEndObjective objective(options, model);
  const Eigen::VectorXd x0 = objective.ModelParameters();
  double cost = 0;
  ASSERT_TRUE(objective.Evaluate(x0.data(), &cost, nullptr)) << objective.last_failure();
  const std::vector<Eigen::Matrix3Xd> states0 = objective.states();
  std::vector<Eigen::VectorXd> others;
  for (int k = 1; k <= EndToEndObjective::kRememberedEvaluations; ++k) {
    Eigen::VectorXd x = x0;
    x.tail(x0.size() - model.decoder->num_parameters()) *= 1.0 + 0.2 * k;  // latents
    ASSERT_TRUE(objective.Evaluate(x.data(), &cost, nullptr)) << objective.last_failure();
    others.push_back(x);
  }
  std::vector<Eigen::Matrix3Xd> found;
  // x0 was pushed out by kRememberedEvaluations newer evaluations.
  EXPECT_FALSE(objective.StatesAt(x0.data(), &found));
  ASSERT_TRUE(objective.StatesAt(others[0].data(), &found));
  ASSERT_EQ(found.size(), states0.size());
  double moved = 0;
  for (size_t p = 0; p < found.size(); ++p) moved += (found[p] - states0[p]).norm();
  EXPECT_GT(moved, 1e-6);  // another point's equilibria
  // The newest point's equilibria are the current states; an older one's can be restored.
  ASSERT_TRUE(objective.StatesAt(others.back().data(), &found));
  for (size_t p = 0; p < found.size(); ++p) EXPECT_EQ(found[p], objective.states()[p]);
  ASSERT_TRUE(objective.StatesAt(others[0].data(), &found));
  ASSERT_TRUE(objective.UseStatesOf(others[0].data()));
  for (size_t p = 0; p < found.size(); ++p) EXPECT_EQ(found[p], objective.states()[p]);
  Eigen::VectorXd unseen = x0;
  unseen[0] += 1e-12;
  EXPECT_FALSE(objective.UseStatesOf(unseen.data()));
}

// A line search's backtrack (a trial between its start and a rejected longer step)
// starts each pose from the two points' equilibria, interpolated, where that is closer
// to equilibrium than the last evaluation's. Solvers shared with no factor kept (so no
// first-order prediction, and the warm start is the rejected step's equilibrium): the
// interpolation is nearer for every pose, and gives the objective and gradient of the
// warm start with fewer Newton steps.
TEST(EndToEndObjectiveTest, BacktrackStartsFromTheLineThroughEarlierEquilibria) {
  ActiveModel model = PretrainedBar();
  ASSERT_TRUE(model.decoder);
  TrainOptions options;
  options.solver.relative_force_tolerance = 1e-11;
  options.max_factor_cache_gb = 0.0;  // solvers shared, no factor kept: no prediction
  TrainOptions off = options;
  off.line_search_starts = false;
  EndToEndObjective on_line(options, model), from_last(off, model);
  const Eigen::VectorXd x0 = on_line.ModelParameters();
  // A long step: every latent doubled, the decoder's parameters perturbed.
  Eigen::VectorXd direction = Eigen::VectorXd::Zero(x0.size());
  const int np = model.decoder->num_parameters();
  direction.tail(x0.size() - np) = x0.tail(x0.size() - np);
  std::mt19937 rng(7);
  std::normal_distribution<double> normal(0.0, 1e-2);
  for (int i = 0; i < np; ++i) direction[i] = normal(rng) * std::abs(x0[i]);
  const std::vector<double> steps = {0.0, 1.0, 0.3};  // start, rejected step, backtrack
  for (double step : steps) {
    ExpectAgreeAt(on_line, from_last, x0 + step * direction, 1e-9, 1e-6,
                  "step " + std::to_string(step));
  }
  const EvaluationCounters& a = on_line.last_counters();
  const EvaluationCounters& b = from_last.last_counters();
  std::printf("backtrack to 0.3 of a rejected step: from the line %d Newton steps, %d "
              "factorizations (%d of %d poses started there); from the last evaluation %d, %d\n",
              a.newton_steps, a.factorizations, a.line_starts, model.num_poses(), b.newton_steps,
              b.factorizations);
  EXPECT_EQ(a.line_starts, model.num_poses());
  EXPECT_EQ(b.line_starts, 0);
  EXPECT_LT(a.newton_steps, b.newton_steps);
  EXPECT_LE(a.factorizations, b.factorizations);
  // Only the trial on a line starts there.
  EXPECT_EQ(on_line.total_counters().line_starts, a.line_starts);
}

// A looser adjoint tolerance (CG on the pose's earlier factor stops sooner) moves the
// gradient by about that fraction and costs no more CG iterations; out-of-range
// tolerances are refused, naming the field.
TEST(EndToEndObjectiveTest, AdjointToleranceBoundsTheGradientsError) {
  ActiveModel model = PretrainedBar();
  ASSERT_TRUE(model.decoder);
  TrainOptions tight;
  tight.solver.relative_force_tolerance = 1e-12;
  TrainOptions loose = tight;
  loose.adjoint_tolerance = 1e-6;
  std::string error;
  ASSERT_TRUE(loose.Validate(&error)) << error;
  EndToEndObjective tight_objective(tight, model), loose_objective(loose, model);
  ASSERT_TRUE(loose_objective.solver_per_pose());  // adjoints by CG on each pose's factor
  // The same equilibria (cost to 1e-10), the gradient to about the adjoint's tolerance.
  int step = 0;
  for (const Eigen::VectorXd& x : RandomWalk(tight_objective.ModelParameters(), 3, 1e-3, 8)) {
    ExpectAgreeAt(loose_objective, tight_objective, x, 1e-10, 1e-4,
                  "step " + std::to_string(step++));
  }
  EXPECT_GT(tight_objective.total_counters().reused_solves, 0);
  std::printf("adjoint tolerance 1e-10: %d factorizations, %d CG iterations; 1e-6: %d, %d\n",
              tight_objective.total_counters().factorizations,
              tight_objective.total_counters().cg_iterations,
              loose_objective.total_counters().factorizations,
              loose_objective.total_counters().cg_iterations);
  for (double bad : {0.0, 0.1, std::numeric_limits<double>::quiet_NaN()}) {
    TrainOptions refused = tight;
    refused.adjoint_tolerance = bad;
    EXPECT_FALSE(refused.Validate(&error)) << bad;
    EXPECT_NE(error.find("adjoint_tolerance"), std::string::npos) << error;
  }
}

// The line search's step expansion must exceed 1 (Ceres' own requirement), named when not.
TEST(EndToEndObjectiveTest, StepExpansionIsValidated) {
  TrainOptions options;
  std::string error;
  options.max_step_expansion = 3.0;
  EXPECT_TRUE(options.Validate(&error)) << error;
  for (double bad : {1.0, 0.5, std::numeric_limits<double>::infinity()}) {
    options.max_step_expansion = bad;
    EXPECT_FALSE(options.Validate(&error)) << bad;
    EXPECT_NE(error.find("max_step_expansion"), std::string::npos) << error;
  }
}

// A stiffness that is singular at every equilibrium, in a direction the loss does not
// see (here a vertex that no element holds: a zero block in K): the adjoint system is
// consistent, and the exact path solves it (CG on the solver's nearby factor), with no
// escape and no shift; the gradient is that of the re-solved objective. (The shifted
// adjoint, for an inconsistent system, has its error bound checked in
// diff/equilibrium_differentiator_test.cc: ShiftedAdjointApproachesTheExactGradient.)
TEST(EndToEndObjectiveTest, AVertexInNoElementLeavesTheGradientExact) {
  ActiveModel model = PretrainedBar();
  const int nv = model.mesh.num_vertices();
  model.mesh.vertices.conservativeResize(3, nv + 1);
  model.mesh.vertices.col(nv) = Eigen::Vector3d(-5.0, -5.0, -5.0);
  model.states.clear();
  {
    const ShapeTargetModel physics(model.mesh, model.mu);
    EquilibriumDifferentiator exact(physics,
                                    FixedVertexMask(PoseBoundaryConditions(model, 0), nv + 1));
    std::string error;
    EXPECT_FALSE(exact.Prepare(model.mesh.vertices, IdentityActuations(model.mesh.num_tets()),
                               &error))
        << "K is singular: its exact factorization fails";
  }
  TrainOptions options;
  options.latent_regularization = 1e-2;
  options.decoder_regularization = 1e-3;
  options.solver.relative_force_tolerance = 1e-12;
  options.num_threads = 1;
  EndToEndObjective objective(options, model);
  const Eigen::VectorXd x0 = objective.ModelParameters();
  double cost = 0;
  Eigen::VectorXd gradient(objective.NumParameters());
  ASSERT_TRUE(objective.Evaluate(x0.data(), &cost, gradient.data())) << objective.last_failure();
  EXPECT_EQ(objective.last_counters().shifted_adjoints, 0);
  EXPECT_EQ(objective.last_counters().unstable_escapes, 0);
  size_t checked = 0;
  const double worst = WorstGradientError(objective, model, x0, gradient, 8, 5, 1e-7, &checked);
  std::printf("vertex in no element: %zu components checked, worst error %.2e\n", checked, worst);
}

// The shifted adjoint (K + shift mean(diag K) I), taken where the exact one fails: forced
// here at stable equilibria, where the exact gradient exists, so that the branch is
// checked against central differences of the re-solved objective. The first evaluation
// goes through the escape from an "unstable" equilibrium and the smallest shift (1e-10);
// the next, the pose known degenerate, straight to the shifted factor. The shift's bias
// is the gradient's error: 4.9e-7 of max |g| on this bar (against the exact gradient and
// against central differences alike), within the 2e-6 checked.
bool FailExactAdjoint(const char* point) {
  return std::string(point) == "objective:exact_adjoint";
}

TEST(EndToEndObjectiveTest, ShiftedAdjointGradientMatchesCentralDifferences) {
  const ActiveModel model = PretrainedBar();
  TrainOptions options;
  options.latent_regularization = 1e-2;
  options.decoder_regularization = 1e-3;
  options.energy_regularization = 0.1;
  options.solver.relative_force_tolerance = 1e-12;
  options.num_threads = 2;
  EndToEndObjective objective(options, model);
  const Eigen::VectorXd x0 = objective.ModelParameters();
  const FailureHook previous = SetFailureHookForTesting(&FailExactAdjoint);
  double cost = 0;
  Eigen::VectorXd gradient(objective.NumParameters()), again(objective.NumParameters());
  const bool evaluated = objective.Evaluate(x0.data(), &cost, gradient.data());
  const EvaluationCounters first = objective.last_counters();
  const bool evaluated_again = objective.Evaluate(x0.data(), &cost, again.data());
  const EvaluationCounters second = objective.last_counters();
  SetFailureHookForTesting(previous);
  ASSERT_TRUE(evaluated && evaluated_again) << objective.last_failure();
  EXPECT_EQ(first.shifted_adjoints, model.num_poses());
  EXPECT_EQ(first.unstable_escapes, model.num_poses());
  EXPECT_EQ(second.shifted_adjoints, model.num_poses());
  EXPECT_EQ(second.unstable_escapes, 0) << "known degenerate: no exact attempt, no escape";
  EXPECT_LT((again - gradient).cwiseAbs().maxCoeff(), 1e-7 * gradient.cwiseAbs().maxCoeff());
  // The exact gradient, for the shift's own error.
  EndToEndObjective exact_objective(options, model);
  Eigen::VectorXd exact(objective.NumParameters());
  ASSERT_TRUE(exact_objective.Evaluate(x0.data(), &cost, exact.data()));
  EXPECT_EQ(exact_objective.last_counters().shifted_adjoints, 0);
  const double shift_error =
      (gradient - exact).cwiseAbs().maxCoeff() / exact.cwiseAbs().maxCoeff();
  size_t checked = 0;
  const double worst = WorstGradientError(objective, model, x0, gradient, 8, 6, 2e-6, &checked);
  std::printf("shifted adjoint: %zu components checked, worst error %.2e; against the exact "
              "gradient %.2e (relative to max |g|)\n",
              checked, worst, shift_error);
}

}  // namespace
}  // namespace aqs
