// DefaultContactSolverOptions and the contact terms' Hessians in Newton steps.

#include "contact/contact_solver.h"

#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "equilibrium/quasistatic_solver.h"
#include "geometry/embedding.h"
#include "testing/contact_scenes.h"

namespace aqs {
namespace {

using testing::BallsContactOptions;
using testing::PushBalls;
using testing::PushedBalls;

TEST(ContactSolverTest, NewtonStepsOnTheContactStiffnessReachTheTolerance) {
  // The two balls pressed together (as above), with the self-contact pairs detected at
  // the contact-free equilibrium and offsets as the augmented Lagrangian makes them
  // (large residuals: Gauss-Newton converges linearly there). One equilibrium solve
  // with those pairs fixed, with Newton steps on the stiffness with the pairs' Hessians
  // (their couplings in the pattern) and with Levenberg-Marquardt only. (Pairs switching
  // on and off make the first Newton steps short; once the active set settles, Newton
  // converges quadratically: 9e-6 -> 1e-10 in one step here.)
  PushedBalls balls;
  ASSERT_TRUE(PushBalls(0.3, &balls));
  const ActiveModel& model = balls.model;
  const ContactOptions options = BallsContactOptions(0.4);
  const ContactSolver contact(model, options);
  std::vector<SelfContactPair> pairs =
      contact.DetectSelfContacts(EmbeddedPositions(model.embedding, model.mesh.tets, balls.free));
  ASSERT_GT(pairs.size(), 20u);
  for (SelfContactPair& pair : pairs) pair.offset = 3 * options.thickness;
  const SelfContactTerm term(pairs, options.thickness, std::numeric_limits<double>::infinity(),
                             std::numeric_limits<double>::infinity());
  const ShapeTargetModel physics(model.mesh, model.mu);
  QuasistaticSolveReport reports[2];
  Eigen::Matrix3Xd results[2];
  for (int newton = 0; newton < 2; ++newton) {
    QuasistaticSolverOptions solver_options = DefaultContactSolverOptions();
    solver_options.relative_force_tolerance = 1e-7;
    if (newton == 0) {
      solver_options.method = EquilibriumMethod::kLevenbergMarquardt;
      solver_options.newton_relative_force = 0.0;
    }
    QuasistaticSolver solver(physics, ModelBoundaryConditions(model, {balls.push}), solver_options);
    solver.AddEnergyTerm(&term);
    solver.SetPositions(balls.free);
    reports[newton] = solver.Solve();
    results[newton] = solver.positions();
  }
  const QuasistaticSolveReport& lm = reports[0];
  const QuasistaticSolveReport& newton = reports[1];
  EXPECT_TRUE(newton.converged) << newton.Summary();
  EXPECT_GT(newton.newton_steps, 0) << newton.Summary();
  EXPECT_NE(newton.termination.find("Newton: force tolerance reached"), std::string::npos)
      << newton.Summary();
  // Levenberg-Marquardt alone ends at its round-off floor near this tolerance (its cost
  // changes become noise), converged or not; L-BFGS and Newton reach the tolerance with
  // fewer factorizations than Levenberg-Marquardt takes iterations (each of which
  // factorizes its normal equations).
  EXPECT_EQ(lm.newton_steps, 0) << lm.Summary();
  EXPECT_LE(newton.final_max_force, newton.force_tolerance) << newton.Summary();
  EXPECT_LT(newton.factorizations, lm.lm_iterations) << lm.Summary() << "\n" << newton.Summary();
  // The same equilibrium (to what Levenberg-Marquardt reached).
  EXPECT_LT((results[0] - results[1]).cwiseAbs().maxCoeff(), 1e-3) << lm.Summary();
}

}  // namespace
}  // namespace aqs
