// Training checkpoints under kill -9: the learned state on disk is always one whole
// checkpoint, a resumed run starts at the logged loss of the iteration it resumes from,
// and train/log.csv keeps one row per iteration.

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "jobs/learning_jobs.h"
#include "model/model_directory.h"
#include "model/model_io.h"
#include "testing/fault_kill.h"
#include "testing/file_contents.h"
#include "testing/temp_dir.h"
#include "testing/training_fixtures.h"
#include "train/trainer.h"
#include "util/fault_injection.h"

namespace aqs {
namespace {

namespace fs = std::filesystem;

// True if the log has exactly the rows 0..last, once each, in order.
::testing::AssertionResult RowsAreZeroTo(const std::vector<std::pair<int, double>>& rows, int last) {
  std::string got;
  for (const auto& row : rows) got += std::to_string(row.first) + " ";
  bool ok = static_cast<int>(rows.size()) == last + 1;
  for (int i = 0; ok && i <= last; ++i) ok = rows[i].first == i;
  if (ok) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "log rows " << got << "; expected 0.." << last;
}

class CheckpointResumeTest : public ::testing::Test {
 protected:
  void SetUp() override {
    path_ = dir_.File("m");
    ASSERT_NO_FATAL_FAILURE(testing::WritePretrainedSyntheticModel(path_, 3, 11, 8, 20));
    options_.num_threads = 1;
    options_.log_every = 0;
    options_.model_directory = path_;
  }

  // aqs_train's library call up to `iterations` in all.
  bool Train(int iterations, bool restart = false) {
    TrainOptions options = options_;
    options.max_iterations = iterations;
    std::ostringstream log;
    std::string error;
    const bool ok = RunTrainJob(path_, options, restart, log, &error);
    EXPECT_TRUE(ok) << error << "\n" << log.str();
    return ok;
  }

  // Resumes training (taking the lock cleans up after the killed run) and returns the
  // report: its initial loss is the resumed start loss.
  TrainReport Resume(int iterations) {
    PathLock lock;
    std::ostringstream log;
    std::string error;
    TrainReport report;
    EXPECT_TRUE(LockModelForWriting(path_, &log, &lock, &error)) << error;
    ActiveModel model;
    EXPECT_TRUE(LoadModel(path_, &model, &error)) << error;
    TrainOptions options = options_;
    options.max_iterations = iterations;
    EXPECT_TRUE(TrainEndToEnd(options, &model, &report, log, &error)) << error;
    return report;
  }

  int SavedIterations() {
    ActiveModel model;
    std::string error;
    EXPECT_TRUE(LoadModel(path_, &model, &error)) << error;
    return model.checkpoint.iterations;
  }

  std::string LogPath() const { return path_ + "/train/log.csv"; }

  // Trains up to `iterations` in a fresh process killed (SIGKILL) at the
  // `occurrence`-th time it reaches `point` (tests/train/kill_at_main.cc).
  std::string TrainKilledAt(const std::string& point, int occurrence, int iterations) {
    return testing::RunProgram({AQS_KILL_AT, point, std::to_string(occurrence), path_,
                                std::to_string(iterations)});
  }

  testing::TempDir dir_;
  std::string path_;
  TrainOptions options_;
};

// Killed inside the checkpoint of iteration 3 (writing its files, before and after its
// learned state is put in place): the model holds checkpoint 2 or 3, and the resumed
// run starts at the loss logged for that iteration. (From checkpoint 1, the run writes
// the log once, then 6 files per checkpoint: decoder, latents, 3 states, checkpoint.txt.)
TEST_F(CheckpointResumeTest, ResumeAfterKillStartsAtTheLoggedLoss) {
  for (const char* point : {"atomic_file:written", "staging:filled", "staging:exchanged"}) {
    SCOPED_TRACE(point);
    ASSERT_TRUE(Train(1, /*restart=*/true));
    const int occurrence = std::string(point) == "atomic_file:written" ? 9 : 1;
    ASSERT_EQ(TrainKilledAt(point, occurrence, 8), "killed");
    const int saved = SavedIterations();
    EXPECT_GE(saved, 2);
    EXPECT_LE(saved, 3);
    const std::vector<std::pair<int, double>> rows = testing::TrainingLogRows(LogPath());
    ASSERT_GT(static_cast<int>(rows.size()), saved);
    const double logged = rows[saved].second;
    const TrainReport report = Resume(saved + 2);
    EXPECT_EQ(report.iterations_before, saved);
    std::printf("killed at %s: resumed after %d iterations, start loss %.17g, logged %.17g "
                "(relative difference %.1e)\n",
                point, saved, report.initial_loss, logged,
                std::abs(report.initial_loss - logged) / logged);
    EXPECT_NEAR(report.initial_loss, logged, 1e-9 * logged);
    EXPECT_TRUE(RowsAreZeroTo(testing::TrainingLogRows(LogPath()), saved + 2));
    EXPECT_EQ(fs::directory_iterator(dir_.path())->path().filename(), "m");
    EXPECT_EQ(std::distance(fs::directory_iterator(dir_.path()), fs::directory_iterator()), 1);
    EXPECT_FALSE(fs::exists(path_ + "/learned.aqs-tmp" + std::to_string(getpid())));
  }
}

// A run that ended normally saved its last point; the next run resumes at its logged loss.
TEST_F(CheckpointResumeTest, ResumeAfterAFinishedRunStartsAtTheLoggedLoss) {
  ASSERT_TRUE(Train(3));
  const std::vector<std::pair<int, double>> rows = testing::TrainingLogRows(LogPath());
  ASSERT_TRUE(RowsAreZeroTo(rows, 3));
  const TrainReport report = Resume(5);
  EXPECT_EQ(report.iterations_before, 3);
  std::printf("resumed after a finished run: start loss %.17g, logged %.17g\n",
              report.initial_loss, rows[3].second);
  EXPECT_NEAR(report.initial_loss, rows[3].second, 1e-9 * rows[3].second);
  EXPECT_TRUE(RowsAreZeroTo(testing::TrainingLogRows(LogPath()), 5));
  // The seconds column counts on across the runs (it started at 0 again in the resumed
  // run, going backwards).
  std::istringstream lines(testing::ReadAll(LogPath()));
  std::string line;
  std::getline(lines, line);  // the header
  double previous = -1.0;
  int count = 0;
  while (std::getline(lines, line)) {
    std::istringstream fields(line);
    std::string field;
    for (int k = 0; k < 7; ++k) std::getline(fields, field, ',');
    const double seconds = std::stod(field);
    EXPECT_GE(seconds, previous) << "row " << count << ": " << line;
    previous = seconds;
    ++count;
  }
  EXPECT_EQ(count, 6);
}

// Checkpoints fall on the multiples of checkpoint_every counted over all runs, as the
// latent refits do: a run resumed from iteration 4 (a run that stopped on its budget or
// its cap) saves at 6, not at 7 (4 + 3); never at its start point.
TEST(CheckpointScheduleTest, CheckpointsFallOnMultiplesOfAllIterations) {
  EXPECT_TRUE(CheckpointDue(3, 3, 3));   // a fresh run
  EXPECT_TRUE(CheckpointDue(6, 2, 3));   // resumed from 4
  EXPECT_FALSE(CheckpointDue(7, 3, 3));
  EXPECT_FALSE(CheckpointDue(6, 0, 3));  // resumed at 6: its start point
  EXPECT_FALSE(CheckpointDue(0, 0, 1));
  EXPECT_TRUE(CheckpointDue(5, 1, 1));
  EXPECT_FALSE(CheckpointDue(6, 2, 0));  // never
}

// A periodic latent refit runs after its iteration's checkpoint. A run resumed at that
// checkpoint refits first (it used to go on without the refit, on another path), and a
// checkpoint saved after the refit (a run that ended in it) is not refitted twice. Every
// refit ends a solve, so a run resumed at a refit follows the uninterrupted one.
TEST_F(CheckpointResumeTest, AResumedRunDoesTheLatentRefitDueAtItsCheckpoint) {
  options_.latent_refit_iterations = 2;
  options_.latent_refit_every = 2;
  const std::string whole_path = dir_.File("whole");
  fs::copy(path_, whole_path, fs::copy_options::recursive);
  auto run = [&](const std::string& path, int iterations) {
    ActiveModel model;
    std::ostringstream log;
    std::string error;
    TrainReport report;
    EXPECT_TRUE(LoadModel(path, &model, &error)) << error;
    TrainOptions options = options_;
    options.model_directory = path;
    options.max_iterations = iterations;
    EXPECT_TRUE(TrainEndToEnd(options, &model, &report, log, &error)) << error;
    return report;
  };
  const TrainReport whole = run(whole_path, 4);
  EXPECT_EQ(whole.latent_refits, 2);  // before iterations 0 and 2
  const TrainReport first = run(path_, 2);
  EXPECT_EQ(first.latent_refits, 1);
  const TrainReport resumed = run(path_, 4);
  EXPECT_EQ(resumed.iterations_before, 2);
  EXPECT_EQ(resumed.latent_refits, 1);
  std::printf("4 iterations with refits every 2: %.17g; resumed after 2: %.17g\n",
              whole.final_loss, resumed.final_loss);
  // (Not to the last digit: the resumed run's equilibria are solved again from the saved
  // ones, to the solver's tolerance. Without the refit the loss went 0.0076 -> 0.0086.)
  EXPECT_NEAR(resumed.final_loss, whole.final_loss, 1e-5 * whole.final_loss);
  // A checkpoint that includes the refit of its iteration.
  ActiveModel model;
  std::string error;
  ASSERT_TRUE(LoadModel(path_, &model, &error)) << error;
  EXPECT_EQ(model.checkpoint.latent_refit_at, 2);
  model.checkpoint.latent_refit_at = 4;
  ASSERT_TRUE(SaveLearnedState(path_, model, &error)) << error;
  EXPECT_EQ(run(path_, 6).latent_refits, 0);
  // A run whose time budget ends in its first refit saves it (iteration 0, refitted), and
  // the next run does not refit again (it did, every run, before any iteration).
  const std::string fresh = dir_.File("fresh");
  fs::copy(whole_path, fresh, fs::copy_options::recursive);
  ASSERT_TRUE(LoadModel(fresh, &model, &error)) << error;
  model.checkpoint = TrainingCheckpoint();
  ASSERT_TRUE(SaveLearnedState(fresh, model, &error)) << error;
  options_.max_seconds = 1e-6;
  EXPECT_EQ(run(fresh, 4).latent_refits, 1);
  ASSERT_TRUE(LoadModel(fresh, &model, &error)) << error;
  EXPECT_EQ(model.checkpoint.iterations, 0);
  EXPECT_EQ(model.checkpoint.latent_refit_at, 0);
  options_.max_seconds = 0.0;
  EXPECT_EQ(run(fresh, 1).latent_refits, 0);
}

// The checkpoint records the loss's weights; a run resumed with others says so (its loss
// column changes meaning), one with the same says nothing.
TEST_F(CheckpointResumeTest, AResumeWithOtherLossWeightsIsNoted) {
  ASSERT_TRUE(Train(2));
  ActiveModel model;
  std::string error;
  ASSERT_TRUE(LoadModel(path_, &model, &error)) << error;
  EXPECT_EQ(model.checkpoint.loss_weights, "latent 0.001 energy 0 decoder 0");
  auto resume = [&](int iterations) {
    TrainOptions options = options_;
    options.max_iterations = iterations;
    std::ostringstream log;
    EXPECT_TRUE(RunTrainJob(path_, options, false, log, &error)) << error;
    return log.str();
  };
  EXPECT_EQ(resume(3).find("other loss weights"), std::string::npos);
  options_.energy_regularization = 0.1;
  const std::string noted = resume(4);
  EXPECT_NE(noted.find("train: note: the 3 iterations done were trained with other loss weights "
                       "(latent 0.001 energy 0 decoder 0; now latent 0.001 energy 0.1 decoder "
                       "0): the loss column of train/log.csv changes meaning after iteration 3"),
            std::string::npos)
      << noted;
  ASSERT_TRUE(LoadModel(path_, &model, &error)) << error;
  EXPECT_EQ(model.checkpoint.loss_weights, "latent 0.001 energy 0.1 decoder 0");
}

// The log's last two columns are the cost of each row's evaluations per pose; over a run
// they add up to the factorizations and CG solves the objective counted (the final
// evaluation after the last row excepted).
TEST_F(CheckpointResumeTest, LogRowsCountFactorizationsPerPose) {
  ActiveModel model;
  std::string error;
  ASSERT_TRUE(LoadModel(path_, &model, &error)) << error;
  TrainOptions options = options_;
  options.max_iterations = 4;
  TrainReport report;
  std::ostringstream log;
  ASSERT_TRUE(TrainEndToEnd(options, &model, &report, log, &error)) << error;
  std::ifstream in(LogPath());
  std::string line;
  std::getline(in, line);
  EXPECT_NE(line.find(",function_evaluations,factorizations_per_pose,cg_solves_per_pose"),
            std::string::npos)
      << line;
  double factorizations = 0, cg_solves = 0;
  int rows = 0;
  while (std::getline(in, line)) {
    std::vector<double> values;
    std::stringstream fields(line);
    std::string field;
    while (std::getline(fields, field, ',')) values.push_back(std::stod(field));
    ASSERT_EQ(values.size(), 10u) << line;
    EXPECT_GE(values[8], 0.0);
    EXPECT_GE(values[9], 0.0);
    // Every iteration solves equilibria and adjoints: by factorizing or by CG.
    if (rows > 0) {
      EXPECT_GT(values[8] + values[9], 0.0) << line;
    }
    factorizations += values[8] * model.num_poses();
    cg_solves += values[9] * model.num_poses();
    ++rows;
  }
  EXPECT_EQ(rows, 5);
  EXPECT_GT(factorizations, 0.0);
  EXPECT_NEAR(factorizations, report.iteration_cost.factorizations, 1e-3);
  EXPECT_NEAR(cg_solves, report.iteration_cost.reused_solves, 1e-3);
}

// Killed before the first checkpoint: no duplicated row 0 after the next run.
TEST_F(CheckpointResumeTest, KillBeforeTheFirstCheckpointDoesNotDuplicateRowZero) {
  ASSERT_EQ(TrainKilledAt("staging:created", 0, 5), "killed");
  EXPECT_EQ(SavedIterations(), 0);
  EXPECT_TRUE(RowsAreZeroTo(testing::TrainingLogRows(LogPath()), 1));  // rows 0 and 1, no checkpoint yet
  ASSERT_TRUE(Train(3));
  EXPECT_TRUE(RowsAreZeroTo(testing::TrainingLogRows(LogPath()), 3));
}

// An empty (damaged) checkpoint.txt stops training with a message naming it and leaves
// the log alone; --restart starts the count and the log again.
TEST_F(CheckpointResumeTest, EmptyCheckpointDoesNotTruncateTheLog) {
  ASSERT_TRUE(Train(3));
  std::ifstream before_in(LogPath());
  const std::string before((std::istreambuf_iterator<char>(before_in)), {});
  std::ofstream(path_ + "/learned/checkpoint.txt").close();
  TrainOptions options = options_;
  options.max_iterations = 6;
  std::ostringstream log;
  std::string error;
  EXPECT_FALSE(RunTrainJob(path_, options, false, log, &error));
  EXPECT_NE(error.find(path_ + "/learned/checkpoint.txt: no 'iterations N' line"),
            std::string::npos) << error;
  std::ifstream after_in(LogPath());
  EXPECT_EQ(std::string((std::istreambuf_iterator<char>(after_in)), {}), before);
  // Deleting the damaged file counts from 0 again, with a new log.
  fs::remove(path_ + "/learned/checkpoint.txt");
  ASSERT_TRUE(Train(2));
  EXPECT_TRUE(RowsAreZeroTo(testing::TrainingLogRows(LogPath()), 2));
  ASSERT_TRUE(Train(1, /*restart=*/true));
  EXPECT_TRUE(RowsAreZeroTo(testing::TrainingLogRows(LogPath()), 1));
}

// A log cut apart from the model (here to its first two rows) is kept as it is, the run
// says which rows are missing, and training resumes after the checkpoint.
TEST_F(CheckpointResumeTest, AShortLogIsReportedAndTrainingResumes) {
  ASSERT_TRUE(Train(4));
  std::ifstream in(LogPath());
  std::string header, row0, row1;
  std::getline(in, header);
  std::getline(in, row0);
  std::getline(in, row1);
  in.close();
  std::ofstream(LogPath()) << header << "\n" << row0 << "\n" << row1 << "\n";
  TrainOptions options = options_;
  options.max_iterations = 5;
  std::ostringstream log;
  std::string error;
  ASSERT_TRUE(RunTrainJob(path_, options, false, log, &error)) << error;
  EXPECT_NE(log.str().find("train/log.csv has rows up to iteration 1, but the checkpoint is of "
                           "iteration 4 (the log was cut or replaced apart from the model): "
                           "its rows 2 to 4 are missing"),
            std::string::npos)
      << log.str();
  EXPECT_EQ(SavedIterations(), 5);
  const std::vector<std::pair<int, double>> rows = testing::TrainingLogRows(LogPath());
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(rows.back().first, 5);
}

// A last row whose seconds are negative (rows that are not numbers are cut as damaged) is
// said, not read as 0 in silence.
TEST_F(CheckpointResumeTest, ALastRowWithoutSecondsIsReported) {
  ASSERT_TRUE(Train(2));
  std::string text = testing::ReadAll(LogPath());
  const size_t last = text.rfind('\n', text.size() - 2) + 1;
  size_t field = last;
  for (int c = 0; c < 6; ++c) field = text.find(',', field) + 1;  // seconds
  text.replace(field, text.find(',', field) - field, "-5");
  std::ofstream(LogPath(), std::ios::trunc) << text;
  TrainOptions options = options_;
  options.max_iterations = 3;
  std::ostringstream log;
  std::string error;
  ASSERT_TRUE(RunTrainJob(path_, options, false, log, &error)) << error;
  EXPECT_NE(log.str().find("train: warning: the last row of " + LogPath() +
                           " has no seconds >= 0 (its 7th field): the log's seconds start "
                           "again at 0"),
            std::string::npos)
      << log.str();
  EXPECT_EQ(SavedIterations(), 3);
}

// A file of the user's inside learned/, which a checkpoint would delete, stops training
// before any work; pre-training likewise refuses a model holding foreign files.
// What WatchModelInstall saw: at the last directory installed (a staged directory taking
// its place), whether the model at g_model_path had its pre-training record.
std::string g_model_path;
int g_installs = 0;
bool g_record_at_last_install = false;

void WatchModelInstall(const char* point) {
  const std::string p(point);
  if (p != "staging:exchanged" && p != "staging:installed") return;
  ++g_installs;
  g_record_at_last_install = fs::exists(g_model_path + "/pretrain/key.txt");
}

// A pre-trained model takes the folder's place with its record (pretrain/key.txt) in
// it: the record was written after the model, and a kill or a full disk in between
// left a pre-trained model the next run pre-trained again, from iteration 0 (its
// checkpoint went with the old folder).
TEST_F(CheckpointResumeTest, APretrainedModelIsInstalledWithItsRecord) {
  PretrainOptions options = testing::SyntheticPretrainOptions(testing::SyntheticBarSpec());
  options.max_iterations = 2;
  g_model_path = path_;
  g_installs = 0;
  const FaultHook previous = SetFaultHookForTesting(&WatchModelInstall);
  std::ostringstream log;
  std::string error;
  const bool ok = RunPretrainJob(path_, options, nullptr, log, &error, false);
  SetFaultHookForTesting(previous);
  ASSERT_TRUE(ok) << error << "\n" << log.str();
  EXPECT_GE(g_installs, 1);
  EXPECT_TRUE(g_record_at_last_install);
  EXPECT_TRUE(fs::exists(path_ + "/pretrain/log.csv"));
}

TEST_F(CheckpointResumeTest, ForeignFilesStopTheJobsBeforeTheWork) {
  ASSERT_TRUE(Train(1));
  std::ofstream(path_ + "/learned/notes.txt") << "mine";
  TrainOptions options = options_;
  options.max_iterations = 3;
  std::ostringstream log;
  std::string error;
  EXPECT_FALSE(RunTrainJob(path_, options, false, log, &error));
  EXPECT_NE(error.find("(learned/notes.txt); a checkpoint would delete them"), std::string::npos)
      << error;
  EXPECT_EQ(log.str().find("train:"), std::string::npos) << log.str();
  EXPECT_FALSE(RunPretrainJob(path_, PretrainOptions(), nullptr, log, &error));
  EXPECT_NE(error.find("(learned/notes.txt); replacing the model would delete them"),
            std::string::npos) << error;
  EXPECT_EQ(log.str().find("pretrain:"), std::string::npos) << log.str();
  EXPECT_TRUE(fs::exists(path_ + "/learned/notes.txt"));
  EXPECT_TRUE(RowsAreZeroTo(testing::TrainingLogRows(LogPath()), 1));
}

}  // namespace
}  // namespace aqs
