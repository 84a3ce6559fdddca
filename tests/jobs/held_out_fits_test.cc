// The evaluation's held-out fits (jobs/held_out_fits.h): a fit that fails is left out,
// and the others stand.

#include "jobs/held_out_fits.h"

#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "testing/fit_fixtures.h"
#include "testing/synthetic_muscles.h"

namespace aqs {
namespace {

TEST(HeldOutFitsTest, AFailedFitIsMarkedAndTheOthersStand) {
  ActiveModel model = testing::PretrainedBarForFits(false);
  ASSERT_TRUE(testing::StoreTrainingEquilibria(&model));
  const testing::SyntheticMuscles held_out = testing::MakeSyntheticMuscles(1, 2, 0.3, 23);
  // Two bent poses the model never saw, fitted from the mean latent at rest.
  const std::vector<std::string> names = {"bent", "bent_too"};
  const std::vector<Eigen::Matrix3Xd> surfaces = {held_out.test_surfaces[0],
                                                  held_out.test_surfaces[1]};
  LatentFitOptions options;
  options.num_threads = 1;
  std::vector<LatentFitResult> fits;
  std::vector<double> seconds;
  // With the default solver, both fit.
  FitHeldOutPoses(model, options, false, names, surfaces, nullptr, &fits, &seconds);
  ASSERT_EQ(fits.size(), 2u);
  for (const LatentFitResult& fit : fits) {
    EXPECT_FALSE(fit.failed) << fit.message;
    EXPECT_EQ(fit.surface.cols(), model.num_surface_vertices());
  }
  // One solver iteration: no equilibrium from rest, so no start can be simulated. Every
  // fit fails, each with its pose's name, and the others stand.
  options.solver.max_iterations = 1;
  options.solver.max_lbfgs_iterations = 1;
  FitHeldOutPoses(model, options, false, names, surfaces, nullptr, &fits, &seconds);
  ASSERT_EQ(fits.size(), 2u);
  for (size_t t = 0; t < fits.size(); ++t) {
    EXPECT_TRUE(fits[t].failed) << t;
    EXPECT_EQ(fits[t].start, kFailedFitStart);
    EXPECT_EQ(fits[t].surface.cols(), 0);
    EXPECT_EQ(fits[t].message.rfind("held-out pose '" + names[t] + "': ", 0), 0u)
        << fits[t].message;
  }
}

}  // namespace
}  // namespace aqs
