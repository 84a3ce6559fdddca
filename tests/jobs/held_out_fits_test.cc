// The evaluation's held-out fits (jobs/held_out_fits.h): a fit that fails is left out,
// and the others stand; fits kept in a store (jobs/held_out_fit_store.h) are taken by
// a rerun, bit for bit, for the same model, learned state, options and poses only.

#include "jobs/held_out_fits.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "eval/surface_autoencoder.h"
#include "jobs/held_out_fit_store.h"
#include "model/fit_prior.h"
#include "testing/fit_fixtures.h"
#include "testing/synthetic_muscles.h"
#include "testing/temp_dir.h"

namespace aqs {
namespace {

namespace fs = std::filesystem;

class HeldOutFitsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    model_ = testing::PretrainedBarForFits(false);
    ASSERT_TRUE(testing::StoreTrainingEquilibria(&model_));
    const testing::SyntheticMuscles held_out = testing::MakeSyntheticMuscles(1, 2, 0.3, 23);
    // Two bent poses the model never saw, fitted from the mean latent at rest.
    surfaces_ = {held_out.test_surfaces[0], held_out.test_surfaces[1]};
    options_.num_threads = 1;
  }

  HeldOutFits Fit(const LatentFitOptions& options, const std::string& store = "") const {
    HeldOutFits out;
    FitHeldOutPoses(model_, options, false, names_, surfaces_, store, nullptr, &out);
    EXPECT_EQ(out.fits.size(), names_.size());
    EXPECT_EQ(out.seconds.size(), names_.size());
    EXPECT_EQ(out.store_warning, "");
    return out;
  }

  ActiveModel model_;
  std::vector<std::string> names_ = {"bent", "bent_too"};
  std::vector<Eigen::Matrix3Xd> surfaces_;
  LatentFitOptions options_;
  testing::TempDir dir_;
};

// One solver iteration: no equilibrium from rest, so no start can be simulated.
LatentFitOptions Failing(LatentFitOptions options) {
  options.solver.max_iterations = 1;
  options.solver.max_lbfgs_iterations = 1;
  return options;
}

void ExpectSameFit(const LatentFitResult& a, const LatentFitResult& b, int t) {
  EXPECT_EQ(a.failed, b.failed) << t;
  EXPECT_EQ(a.start, b.start) << t;
  EXPECT_EQ(a.message, b.message) << t;
  EXPECT_EQ(a.latent, b.latent) << t;
  EXPECT_EQ(a.state, b.state) << t;
  EXPECT_EQ(a.surface, b.surface) << t;
  ASSERT_EQ(a.bones.size(), b.bones.size()) << t;
  for (size_t i = 0; i < a.bones.size(); ++i) {
    EXPECT_EQ(a.bones[i].rotation, b.bones[i].rotation) << t;
    EXPECT_EQ(a.bones[i].translation, b.bones[i].translation) << t;
  }
  EXPECT_EQ(a.rms_error, b.rms_error) << t;
  EXPECT_EQ(a.mean_error, b.mean_error) << t;
  EXPECT_EQ(a.max_error, b.max_error) << t;
  EXPECT_EQ(a.iterations, b.iterations) << t;
  EXPECT_EQ(a.used_points, b.used_points) << t;
  EXPECT_EQ(a.converged, b.converged) << t;
}

TEST_F(HeldOutFitsTest, AFailedFitIsMarkedAndTheOthersStand) {
  // With the default solver, both fit.
  HeldOutFits out = Fit(options_);
  for (const LatentFitResult& fit : out.fits) {
    EXPECT_FALSE(fit.failed) << fit.message;
    EXPECT_EQ(fit.surface.cols(), model_.num_surface_vertices());
  }
  // Every fit fails, each with its pose's name, and the others stand.
  out = Fit(Failing(options_));
  for (size_t t = 0; t < out.fits.size(); ++t) {
    EXPECT_TRUE(out.fits[t].failed) << t;
    EXPECT_EQ(out.fits[t].start, kFailedFitStart);
    EXPECT_EQ(out.fits[t].surface.cols(), 0);
    EXPECT_EQ(out.fits[t].message.rfind("held-out pose '" + names_[t] + "': ", 0), 0u)
        << out.fits[t].message;
  }
}

TEST_F(HeldOutFitsTest, ARerunTakesTheKeptFitsBitForBit) {
  const std::string store = dir_.File("evaluation/held_out_fits");
  const HeldOutFits first = Fit(options_, store);
  EXPECT_EQ(first.kept, 0);
  EXPECT_TRUE(fs::exists(store + "/key.txt"));
  for (const char* file : {"/0000.bin", "/0000.txt", "/0001.bin", "/0001.txt"}) {
    EXPECT_TRUE(fs::exists(store + file)) << file;
  }
  // Both taken, as they were.
  HeldOutFits second = Fit(options_, store);
  EXPECT_EQ(second.kept, 2);
  for (int t = 0; t < 2; ++t) ExpectSameFit(second.fits[t], first.fits[t], t);
  EXPECT_EQ(second.seconds, first.seconds);
  // A stop before pose 1's record was written: pose 1 is fitted again, to the same
  // result (each fit starts from rest with a fitter of its own).
  fs::remove(store + "/0001.txt");
  second = Fit(options_, store);
  EXPECT_EQ(second.kept, 1);
  for (int t = 0; t < 2; ++t) ExpectSameFit(second.fits[t], first.fits[t], t);
  // A damaged block is not taken.
  fs::resize_file(store + "/0000.bin", 16);
  EXPECT_EQ(Fit(options_, store).kept, 1);
  EXPECT_EQ(Fit(options_, store).kept, 2);
}

TEST_F(HeldOutFitsTest, KeptFitsOfAnotherModelOptionsOrPoseAreNotTaken) {
  const std::string store = dir_.File("held_out_fits");
  Fit(options_, store);
  EXPECT_EQ(Fit(options_, store).kept, 2);
  // Other fit options: the store is emptied, and kept anew.
  LatentFitOptions other = options_;
  other.latent_prior *= 2;
  EXPECT_EQ(Fit(other, store).kept, 0);
  EXPECT_EQ(Fit(other, store).kept, 2);
  other.solver.relative_force_tolerance *= 0.5;
  EXPECT_EQ(Fit(other, store).kept, 0);
  EXPECT_EQ(Fit(options_, store).kept, 0);
  // Another learned state (a retrained model's latents).
  model_.latents(0, 0) += 1e-9;
  EXPECT_EQ(Fit(options_, store).kept, 0);
  EXPECT_EQ(Fit(options_, store).kept, 2);
  // Another surface under the same name, or another name: that pose is fitted again.
  surfaces_[1](0, 0) += 1e-9;
  EXPECT_EQ(Fit(options_, store).kept, 1);
  std::swap(names_[0], names_[1]);
  EXPECT_EQ(Fit(options_, store).kept, 0);
  // Fitting threads are not part of the key.
  LatentFitOptions threads = options_;
  threads.num_threads = 2;
  HeldOutFits out;
  FitHeldOutPoses(model_, threads, false, names_, surfaces_, store, nullptr, &out);
  EXPECT_EQ(out.kept, 2);
}

// An item's record goes before its numbers are replaced: a save that fails after the
// numbers (here the record's temporary file is blocked by a folder) leaves no record over
// other numbers, which a later run would take for the pose's fit. The other pose's item
// is not touched.
TEST_F(HeldOutFitsTest, AFailedSaveLeavesNoRecordOverOtherNumbers) {
  const std::string folder = dir_.File("held_out_fits");
  const HeldOutFits first = Fit(options_, folder);
  std::ifstream key_file(folder + "/key.txt");
  const std::string key((std::istreambuf_iterator<char>(key_file)),
                        std::istreambuf_iterator<char>());
  HeldOutFitStore store;
  std::string error;
  ASSERT_TRUE(store.Open(folder, key, &error)) << error;
  LatentFitResult fit;
  double seconds = 0.0;
  ASSERT_TRUE(store.Load(model_, names_[0], surfaces_[0], &fit, &seconds));
  fs::create_directories(folder + "/0000.txt.tmp" + std::to_string(::getpid()));
  EXPECT_FALSE(store.Save(model_, names_[0], surfaces_[0], first.fits[1], 1.0, &error));
  EXPECT_FALSE(store.Load(model_, names_[0], surfaces_[0], &fit, &seconds))
      << "pose 1's numbers taken for pose 0's fit";
  EXPECT_TRUE(store.Load(model_, names_[1], surfaces_[1], &fit, &seconds));
}

// Kept fits are found by pose and surface, not by their place in the list: a pose added
// in front, or the list in another order, takes every fit kept (they were refitted from
// the first pose out of place on, and the kept ones overwritten).
TEST_F(HeldOutFitsTest, KeptFitsAreFoundByPoseNotByPlace) {
  const std::string store = dir_.File("held_out_fits");
  const HeldOutFits first = Fit(options_, store);
  std::swap(names_[0], names_[1]);
  std::swap(surfaces_[0], surfaces_[1]);
  HeldOutFits again = Fit(options_, store);
  EXPECT_EQ(again.kept, 2);
  ExpectSameFit(again.fits[0], first.fits[1], 0);
  ExpectSameFit(again.fits[1], first.fits[0], 1);
  // One pose added in front: the two kept, one fitted (and kept in a new item).
  names_.insert(names_.begin(), "bent_again");
  Eigen::Matrix3Xd moved = surfaces_[0];
  moved.row(2).array() += 1e-3;
  surfaces_.insert(surfaces_.begin(), moved);
  EXPECT_EQ(Fit(options_, store).kept, 2);
  EXPECT_EQ(Fit(options_, store).kept, 3);
  EXPECT_TRUE(fs::exists(store + "/0002.txt"));
}

TEST_F(HeldOutFitsTest, FailedFitsAreKeptWithTheirMessage) {
  const std::string store = dir_.File("held_out_fits");
  const HeldOutFits first = Fit(Failing(options_), store);
  const HeldOutFits second = Fit(Failing(options_), store);
  EXPECT_EQ(second.kept, 2);
  for (int t = 0; t < 2; ++t) {
    EXPECT_TRUE(second.fits[t].failed);
    ExpectSameFit(second.fits[t], first.fits[t], t);
  }
}

TEST_F(HeldOutFitsTest, AStoreThatCannotBeMadeIsAWarningAndTheFitsStand) {
  const std::string blocker = dir_.Write("file", "not a folder");
  HeldOutFits out;
  FitHeldOutPoses(model_, options_, false, names_, surfaces_, blocker + "/store", nullptr, &out);
  EXPECT_NE(out.store_warning.find(blocker), std::string::npos) << out.store_warning;
  ASSERT_EQ(out.fits.size(), 2u);
  for (const LatentFitResult& fit : out.fits) EXPECT_FALSE(fit.failed) << fit.message;
}

// --latent_prior=0 switches off the latent prior of both learned models' held-out fits,
// which otherwise follow one rule (a Gaussian learned from the model's own training
// latents, weighted latent_prior / min(points, prior_points_cap)). The physics fit (bone
// prior off too) then does not depend on the model's prior at all; the auto-encoder's
// (trained on the same poses) is the data term's stationary point, and its start is
// chosen by the data term alone. With a weight, both depend on their prior.
TEST_F(HeldOutFitsTest, LatentPriorZeroSwitchesOffBothModelsPriors) {
  LatentFitOptions off = options_;
  off.latent_prior = 0.0;
  off.bone_prior = 0.0;
  // The physics model with another prior: shifted by one standard deviation per
  // coordinate, a quarter of the covariance.
  ActiveModel other_prior = model_;
  other_prior.fit_prior = LearnFitPrior(model_);
  GaussianPrior& latent = other_prior.fit_prior.latent;
  latent.mean += latent.covariance.diagonal().cwiseSqrt();
  ASSERT_TRUE(latent.SetCovariance(0.25 * latent.covariance));
  for (const bool prior_on : {false, true}) {
    const LatentFitOptions& options = prior_on ? options_ : off;
    HeldOutFits own, other;
    FitHeldOutPoses(model_, options, false, names_, surfaces_, "", nullptr, &own);
    FitHeldOutPoses(other_prior, options, false, names_, surfaces_, "", nullptr, &other);
    for (int t = 0; t < 2; ++t) {
      ASSERT_FALSE(own.fits[t].failed) << own.fits[t].message;
      if (prior_on) {
        EXPECT_GT((own.fits[t].latent - other.fits[t].latent).norm(), 1e-6) << t;
      } else {
        ExpectSameFit(own.fits[t], other.fits[t], t);
      }
    }
  }

  // The auto-encoder baseline of the same poses and latent size.
  std::vector<Eigen::Matrix3Xd> training;
  for (const TrainingPose& pose : model_.poses) training.push_back(pose.surface);
  SurfaceAutoencoderOptions ae_options;
  ae_options.latent_dim = model_.latent_dim();
  ae_options.hidden_dims = {8};
  ae_options.max_iterations = 200;
  SurfaceAutoencoder autoencoder;
  std::ostringstream log;
  std::string error;
  ASSERT_TRUE(autoencoder.Train(model_.neutral.vertices, training, ae_options, log, &error))
      << error;
  const int ns = model_.num_surface_vertices();
  std::vector<int> all(ns);
  for (int i = 0; i < ns; ++i) all[i] = i;
  for (int t = 0; t < 2; ++t) {
    const std::unique_ptr<ceres::CostFunction> data =
        autoencoder.NewFitCostFunction(all, surfaces_[t]);
    double gradient_with_prior = 0.0;
    for (const bool prior_on : {true, false}) {
      const LatentFitOptions& options = prior_on ? options_ : off;
      std::string start_name;
      const Eigen::VectorXd start =
          AutoencoderStart(autoencoder, model_, surfaces_[t], options, true, &start_name);
      Eigen::VectorXd z;
      double rms = 0.0;
      ASSERT_TRUE(autoencoder.FitLatent(all, surfaces_[t], start, options, &z, &rms));
      // The data term's gradient J^T r at the fit.
      Eigen::VectorXd r(data->num_residuals());
      Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> jacobian(
          data->num_residuals(), z.size());
      const double* block = z.data();
      double* jacobian_blocks[1] = {jacobian.data()};
      ASSERT_TRUE(data->Evaluate(&block, r.data(), jacobian_blocks));
      const double gradient = (jacobian.transpose() * r).norm();
      if (prior_on) {
        gradient_with_prior = gradient;
        EXPECT_GT(gradient, 1e-6) << t << ": the prior pulls against the data";
        EXPECT_GT(autoencoder.FitPriorTerm(z, ns, options), 0.0);
      } else {
        EXPECT_LT(gradient, 1e-3 * gradient_with_prior) << t << ": the data term alone";
        EXPECT_EQ(autoencoder.FitPriorTerm(z, ns, options), 0.0);
        EXPECT_EQ(autoencoder.FitPriorTerm(start, ns, options), 0.0);
      }
    }
  }
}

}  // namespace
}  // namespace aqs
