// End-to-end training over MPI (run by mpirun with 2 ranks, tests/dist/CMakeLists.txt)
// against one process: the same loss and gradient, the same short run, checkpoints
// that resume with another number of ranks, failing poses reported by name, spare ranks.
// Rank 0 computes the one-process reference while the others wait.

#include <cmath>
#include <cstdio>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "testing/training_fixtures.h"

#include "dist/communicator.h"
#include "dist/model_sharing.h"
#include "dist/mpi_world.h"
#include "jobs/learning_jobs.h"
#include "jobs/mpi_benchmark.h"
#include "model/model_directory.h"
#include "model/model_io.h"
#include "train/end_to_end_objective.h"
#include "train/trainer.h"

namespace aqs {
namespace {

using testing::World;

TrainOptions Options() {
  TrainOptions options;
  options.num_threads = 1;
  options.log_every = 0;
  options.latent_regularization = 1e-2;
  return options;
}

double Relative(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  return (a - b).norm() / std::max(1e-300, b.norm());
}

double Relative(double a, double b) { return std::abs(a - b) / std::max(1e-300, std::abs(b)); }

// x0 (the model's parameters) and x1 = x0 + a fixed small step.
std::vector<Eigen::VectorXd> Points(const EndToEndObjective& objective) {
  const Eigen::VectorXd x0 = objective.ModelParameters();
  Eigen::VectorXd x1 = x0;
  for (Eigen::Index i = 0; i < x1.size(); ++i) x1[i] += 2e-3 * std::sin(0.7 * i + 0.3);
  return {x0, x1};
}

struct Evaluation {
  bool ok = false;
  double cost = 0, mean = 0, max = 0;
  Eigen::VectorXd gradient;
};

// Rank 0: evaluates with gradients at each point, in order.
std::vector<Evaluation> EvaluateAt(const EndToEndObjective& objective,
                                   const std::vector<Eigen::VectorXd>& points) {
  std::vector<Evaluation> out(points.size());
  for (size_t k = 0; k < points.size(); ++k) {
    out[k].gradient.resize(objective.NumParameters());
    out[k].ok = objective.Evaluate(points[k].data(), &out[k].cost, out[k].gradient.data());
    EXPECT_TRUE(out[k].ok) << objective.last_failure();
    out[k].mean = objective.mean_surface_error();
    out[k].max = objective.max_surface_error();
  }
  return out;
}

TEST(MpiTrainingTest, LossAndGradientMatchOneProcess) {
  const Communicator& world = World();
  const ActiveModel model = testing::PretrainedBar(4);
  const TrainOptions options = Options();
  std::vector<Evaluation> one;
  if (world.is_root()) {
    EndToEndObjective local(options, model);
    one = EvaluateAt(local, Points(local));
  }
  TrainOptions distributed = options;
  distributed.communicator = &world;
  EndToEndObjective objective(distributed, model);
  EXPECT_EQ(objective.owned_poses(), OwnedIndices(4, world.rank(), world.size()));
  if (!world.is_root()) {
    EXPECT_TRUE(objective.Serve());
    return;
  }
  const std::vector<Evaluation> many = EvaluateAt(objective, Points(objective));
  objective.StopWorkers(true);
  for (size_t k = 0; k < one.size(); ++k) {
    const double cost_error = Relative(many[k].cost, one[k].cost);
    const double gradient_error = Relative(many[k].gradient, one[k].gradient);
    std::printf("point %zu over %d ranks: loss %.17g vs one process %.17g (relative %.1e), "
                "gradient relative difference %.1e (|g| %.3e)\n",
                k, world.size(), many[k].cost, one[k].cost, cost_error, gradient_error,
                one[k].gradient.norm());
    EXPECT_LE(cost_error, 1e-12);
    EXPECT_LE(gradient_error, 1e-12);
    EXPECT_LE((many[k].gradient - one[k].gradient).cwiseAbs().maxCoeff(),
              1e-12 * one[k].gradient.cwiseAbs().maxCoeff());
    // The surface errors to round-off (a batch of decoded latents rounds a little
    // differently from another batch).
    EXPECT_LE(Relative(many[k].mean, one[k].mean), 1e-12);
    EXPECT_LE(Relative(many[k].max, one[k].max), 1e-12);
  }
}

// A solver report without its time ("0.005481 s" -> "T s").
std::string WithoutSeconds(const std::string& text) {
  return std::regex_replace(text, std::regex("[0-9.e+-]+ s\\b"), "T s");
}

// A pose that fails to converge on another rank fails the evaluation on rank 0 with
// the same message as in one process (the pose's name and the solver's report), and
// the next evaluation works.
TEST(MpiTrainingTest, AFailingPoseStopsTheEvaluationWithItsNameAndReason) {
  const Communicator& world = World();
  ActiveModel model = testing::PretrainedBar(4);
  Eigen::VectorXd x0;
  {
    // Converged equilibria as warm starts (each rank alike).
    EndToEndObjective warm(Options(), model);
    x0 = warm.ModelParameters();
    double cost = 0;
    EXPECT_TRUE(warm.Evaluate(x0.data(), &cost, nullptr)) << warm.last_failure();
    model.states = warm.states();
  }
  // Pose 1 (rank 1's with 2 ranks) jumps far with one Newton iteration allowed.
  TrainOptions options = Options();
  options.solver.max_iterations = 1;
  const int np = model.decoder->num_parameters();
  Eigen::VectorXd bad = x0;
  bad.segment(np + 1 * model.latent_dim(), model.latent_dim()).array() += 3.0;
  std::string one_failure;
  if (world.is_root()) {
    EndToEndObjective local(options, model);
    double cost = 0;
    EXPECT_TRUE(local.Evaluate(x0.data(), &cost, nullptr)) << local.last_failure();
    EXPECT_FALSE(local.Evaluate(bad.data(), &cost, nullptr));
    one_failure = local.last_failure();
  }
  TrainOptions distributed = options;
  distributed.communicator = &world;
  EndToEndObjective objective(distributed, model);
  if (!world.is_root()) {
    EXPECT_FALSE(objective.Serve());  // rank 0 stops with a failure status
    return;
  }
  double cost = 0;
  EXPECT_TRUE(objective.Evaluate(x0.data(), &cost, nullptr)) << objective.last_failure();
  EXPECT_FALSE(objective.Evaluate(bad.data(), &cost, nullptr));
  std::printf("one process: %s\n%d ranks:     %s\n", one_failure.c_str(), world.size(),
              objective.last_failure().c_str());
  EXPECT_EQ(WithoutSeconds(objective.last_failure()), WithoutSeconds(one_failure));
  EXPECT_NE(objective.last_failure().find("pose '" + model.poses[1].name + "'"), std::string::npos)
      << objective.last_failure();
  // The ranks are still in step: the next evaluation works.
  EXPECT_TRUE(objective.Evaluate(x0.data(), &cost, nullptr)) << objective.last_failure();
  objective.StopWorkers(false);
}

// Latent refits over the ranks (each refits the poses it owns, before the first
// iteration and after every second) end at the parameters of the one-process run, to
// round-off.
TEST(MpiTrainingTest, LatentRefitsOverTheRanksGiveTheParametersOfOneProcess) {
  const Communicator& world = World();
  const ActiveModel model = testing::PretrainedBar(4);
  TrainOptions options = Options();
  options.max_iterations = 4;
  options.latent_refit_iterations = 2;
  options.latent_refit_every = 2;
  std::ostringstream log;
  std::string error;
  ActiveModel one = model;
  TrainReport one_report;
  if (world.is_root()) {
    EXPECT_TRUE(TrainEndToEnd(options, &one, &one_report, log, &error)) << error;
  }
  ActiveModel many = model;
  TrainReport report;
  options.communicator = &world;
  std::ostringstream many_log;
  EXPECT_TRUE(TrainEndToEnd(options, &many, &report, many_log, &error)) << error;
  if (!world.is_root()) return;
  EXPECT_EQ(report.latent_refits, one_report.latent_refits);
  EXPECT_GE(report.latent_refits, 2);
  // The refits' lines (losses, poses improved) are those of one process.
  const std::regex refit_line("latent refit: loss ([^ ]+) -> ([^ ]+) \\((\\d+) of");
  std::vector<std::string> one_lines, many_lines;
  const std::string one_text = log.str(), many_text = many_log.str();
  for (std::sregex_iterator it(one_text.begin(), one_text.end(), refit_line), end; it != end; ++it) {
    one_lines.push_back((*it)[0]);
  }
  for (std::sregex_iterator it(many_text.begin(), many_text.end(), refit_line), end; it != end;
       ++it) {
    many_lines.push_back((*it)[0]);
  }
  EXPECT_EQ(many_lines, one_lines) << many_text << "\n---\n" << one_text;
  const double params = Relative(many.decoder_params, one.decoder_params);
  const double latents = Relative(Eigen::Map<const Eigen::VectorXd>(many.latents.data(), many.latents.size()),
                                  Eigen::Map<const Eigen::VectorXd>(one.latents.data(), one.latents.size()));
  const double moved = Relative(Eigen::Map<const Eigen::VectorXd>(one.latents.data(), one.latents.size()),
                                Eigen::Map<const Eigen::VectorXd>(model.latents.data(), model.latents.size()));
  std::printf("%d iterations with %d refit rounds over %d ranks vs one process: decoder "
              "parameters relative difference %.1e, latents %.1e (they moved %.1e)\n",
              report.iterations, report.latent_refits, world.size(), params, latents, moved);
  EXPECT_EQ(report.iterations, one_report.iterations);
  EXPECT_GT(moved, 1e-6);
  EXPECT_LE(params, 1e-10);
  EXPECT_LE(latents, 1e-10);
  EXPECT_LE(Relative(report.final_loss, one_report.final_loss), 1e-10);
}

// A short L-BFGS run over the ranks ends at the parameters of the one-process run, to
// round-off.
TEST(MpiTrainingTest, ShortRunGivesTheParametersOfOneProcess) {
  const Communicator& world = World();
  const ActiveModel model = testing::PretrainedBar(4);
  TrainOptions options = Options();
  options.max_iterations = 5;
  std::ostringstream log;
  std::string error;
  ActiveModel one = model;
  TrainReport one_report;
  if (world.is_root()) {
    EXPECT_TRUE(TrainEndToEnd(options, &one, &one_report, log, &error)) << error;
  }
  ActiveModel many = model;
  TrainReport report;
  options.communicator = &world;
  EXPECT_TRUE(TrainEndToEnd(options, &many, &report, log, &error)) << error;
  if (!world.is_root()) return;
  const double params = Relative(many.decoder_params, one.decoder_params);
  const double latents = Relative(Eigen::Map<const Eigen::VectorXd>(many.latents.data(), many.latents.size()),
                                  Eigen::Map<const Eigen::VectorXd>(one.latents.data(), one.latents.size()));
  double states = 0;
  for (int p = 0; p < model.num_poses(); ++p) {
    ASSERT_EQ(many.states[p].cols(), model.mesh.num_vertices());
    states = std::max(states, (many.states[p] - one.states[p]).norm() / one.states[p].norm());
  }
  const double moved = Relative(one.decoder_params, model.decoder_params);
  std::printf("%d iterations over %d ranks vs one process: decoder parameters relative "
              "difference %.1e (they moved %.1e), latents %.1e, equilibria %.1e, final loss "
              "%.17g vs %.17g\n",
              report.iterations, world.size(), params, moved, latents, states, report.final_loss,
              one_report.final_loss);
  EXPECT_EQ(report.iterations, one_report.iterations);
  EXPECT_GT(moved, 1e-6);  // training did something
  EXPECT_LE(params, 1e-10);
  EXPECT_LE(latents, 1e-10);
  EXPECT_LE(states, 1e-10);
  EXPECT_LE(Relative(report.final_loss, one_report.final_loss), 1e-10);
}

// Resumes training of the model at `path` up to `iterations` on the ranks of
// `communicator` (null: rank 0 alone) as aqs_train does, and returns rank 0's report
// (its initial loss is the resumed start loss).
TrainReport Resume(const std::string& path, const Communicator* communicator, int iterations) {
  const bool root = communicator == nullptr || communicator->is_root();
  PathLock lock;
  ActiveModel model;
  std::ostringstream log;
  std::string error;
  TrainReport report;
  bool ok = true;
  if (root) ok = LockModelForWriting(path, &log, &lock, &error) && LoadModel(path, &model, &error);
  if (communicator != nullptr) {
    EXPECT_TRUE(communicator->Agree(ok, &error)) << error;
    if (!root) ok = LoadModel(path, &model, &error);
    ok = ShareModel(*communicator, path, ok, &model, &error);
  }
  EXPECT_TRUE(ok) << error;
  TrainOptions options = Options();
  options.max_iterations = iterations;
  options.model_directory = root ? path : "";
  options.communicator = communicator;
  EXPECT_TRUE(TrainEndToEnd(options, &model, &report, log, &error)) << error;
  return report;
}

// Checkpoints written by 2 ranks resume in one process at the logged loss, and the
// reverse; the log keeps one row per iteration.
TEST(MpiTrainingTest, CheckpointsResumeWithAnotherNumberOfRanks) {
  const Communicator& world = World();
  testing::SharedTempDir dir;
  const std::string path = dir.File("m");
  std::string error;
  if (world.is_root()) {
    EXPECT_TRUE(SaveModel(path, testing::PretrainedBar(3), &error)) << error;
  }
  TrainOptions options = Options();
  options.max_iterations = 3;
  options.communicator = &world;
  std::ostringstream log;
  EXPECT_TRUE(RunTrainJob(path, options, false, log, &error)) << error;
  if (world.is_root()) {
    const auto rows = testing::TrainingLogRows(path + "/train/log.csv");
    EXPECT_EQ(rows.size(), 4u);
    const TrainReport report = Resume(path, nullptr, 5);
    EXPECT_EQ(report.iterations_before, 3);
    std::printf("checkpoint of %d ranks resumed by one process: start loss %.17g, logged %.17g\n",
                world.size(), report.initial_loss, rows[3].second);
    EXPECT_NEAR(report.initial_loss, rows[3].second, 1e-9 * rows[3].second);
  }
  world.Barrier();
  const TrainReport report = Resume(path, &world, 6);
  if (world.is_root()) {
    const auto rows = testing::TrainingLogRows(path + "/train/log.csv");
    ASSERT_EQ(rows.size(), 7u);
    for (int i = 0; i <= 6; ++i) EXPECT_EQ(rows[i].first, i);
    EXPECT_EQ(report.iterations_before, 5);
    std::printf("checkpoint of one process resumed by %d ranks: start loss %.17g, logged %.17g\n",
                world.size(), report.initial_loss, rows[5].second);
    EXPECT_NEAR(report.initial_loss, rows[5].second, 1e-9 * rows[5].second);
  }
}

// More ranks than poses: the spare ranks own nothing and the run is the one-process run.
TEST(MpiTrainingTest, SpareRanksStayIdle) {
  const Communicator& world = World();
  const ActiveModel model = testing::PretrainedBar(1);
  TrainOptions options = Options();
  options.max_iterations = 3;
  std::ostringstream log;
  std::string error;
  ActiveModel one = model;
  TrainReport one_report;
  if (world.is_root()) {
    EXPECT_TRUE(TrainEndToEnd(options, &one, &one_report, log, &error)) << error;
  }
  options.communicator = &world;
  {
    EndToEndObjective probe(options, model);
    EXPECT_EQ(probe.owned_poses().size(), world.is_root() ? 1u : 0u);
    if (world.is_root()) {
      probe.StopWorkers(true);
    } else {
      EXPECT_TRUE(probe.Serve());
    }
  }
  ActiveModel many = model;
  TrainReport report;
  EXPECT_TRUE(TrainEndToEnd(options, &many, &report, log, &error)) << error;
  if (!world.is_root()) return;
  EXPECT_EQ(report.iterations, one_report.iterations);
  EXPECT_LE(Relative(many.decoder_params, one.decoder_params), 1e-10);
  EXPECT_LE(Relative(report.final_loss, one_report.final_loss), 1e-10);
}

// The scaling benchmark (jobs/mpi_benchmark.h) on all ranks: the model is read on every
// rank, a run on rank 0 alone and one on all, their speed-up and the reductions; only
// rank 0 prints. A model one rank cannot read fails on every rank, naming the path.
TEST(MpiTrainingTest, ScalingBenchmarkRunsAloneAndOnAllRanks) {
  const Communicator& world = World();
  testing::SharedTempDir dir;
  std::string error;
  if (world.is_root()) {
    EXPECT_TRUE(SaveModel(dir.File("m"), testing::PretrainedBar(3), &error)) << error;
  }
  world.Barrier();
  MpiBenchmarkOptions options;
  options.model = dir.File("m");
  options.iterations = 1;
  options.reduction_calls = 2;
  options.train = Options();
  std::ostringstream out;
  EXPECT_EQ(RunMpiBenchmark(options, &world, out, &error), JobStatus::kOk) << error;
  const std::string text = out.str();
  if (world.is_root()) {
    EXPECT_NE(text.find("\n1             1 "), std::string::npos) << text;
    EXPECT_NE(text.find("\n" + std::to_string(world.size()) + "             1 "),
              std::string::npos)
        << text;
    EXPECT_NE(text.find("best runs: " + std::to_string(world.size()) + " ranks vs 1"),
              std::string::npos)
        << text;
    EXPECT_NE(text.find("Broadcast (parameters)"), std::string::npos) << text;
  } else {
    EXPECT_TRUE(text.empty()) << text;
  }
  // Rank 1 looks in a folder that is not there.
  options.model = world.is_root() ? dir.File("m") : dir.File("elsewhere");
  std::ostringstream none;
  EXPECT_EQ(RunMpiBenchmark(options, &world, none, &error), JobStatus::kBadInput);
  EXPECT_NE(error.find("elsewhere"), std::string::npos) << error;
  EXPECT_TRUE(none.str().empty()) << none.str();
}

}  // namespace
}  // namespace aqs
