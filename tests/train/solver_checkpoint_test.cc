// Solver checkpoints (train/solver_checkpoint.h) and pre-training's use of them: what
// they hold, when they are resumed and when not, and a pre-training killed between a
// checkpoint's two files.

#include "train/solver_checkpoint.h"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "jobs/learning_jobs.h"
#include "model/model_io.h"
#include "testing/fault_kill.h"
#include "testing/file_contents.h"
#include "testing/temp_dir.h"
#include "testing/training_fixtures.h"

namespace aqs {
namespace {

namespace fs = std::filesystem;

CheckpointKey SomeKey() {
  return {{"model", "00000000000000ab"},
          {"targets", "00000000000000cd"},
          {"options", "latent_dim=2 hidden=8"}};
}

SolverCheckpoint SomeCheckpoint(int iterations) {
  SolverCheckpoint checkpoint;
  checkpoint.key = SomeKey();
  checkpoint.iterations = iterations;
  checkpoint.seconds = 1.25 * iterations;
  checkpoint.loss = 1.0 / (3.0 + iterations);
  checkpoint.parameters = Eigen::VectorXd::LinSpaced(7, -1.0, 1.0 + iterations);
  return checkpoint;
}

// Reads from `folder` (the model's pretrain/ or a kept copy) the pre-training checkpoint
// of the model at `path` with `options`: ReadSolverCheckpoint with the model's key and
// parameter count. *key (if not null) receives the key. A model that cannot be read is a
// test failure.
bool ReadPretrainCheckpoint(const std::string& path, const std::string& folder,
                            const PretrainOptions& options, SolverCheckpoint* checkpoint,
                            std::string* why_not, CheckpointKey* key = nullptr) {
  ActiveModel model;
  std::string error;
  EXPECT_TRUE(LoadModel(path, &model, &error)) << error;
  const CheckpointKey model_key = PretrainCheckpointKey(options, model);
  if (key != nullptr) *key = model_key;
  return ReadSolverCheckpoint(folder, model_key,
                              static_cast<int>(model.decoder_params.size() + model.latents.size()),
                              checkpoint, why_not);
}

// The slots are written in turn; the checkpoint read is always the one last written,
// exactly (numbers round-trip).
TEST(SolverCheckpointTest, RoundTripsAndAlternatesSlots) {
  testing::TempDir dir;
  std::string error, why_not;
  SolverCheckpoint read;
  EXPECT_FALSE(ReadSolverCheckpoint(dir.path(), SomeKey(), 7, &read, &why_not));
  EXPECT_EQ(why_not, "");  // none: not an error
  for (int iterations : {4, 9, 13}) {
    ASSERT_TRUE(WriteSolverCheckpoint(dir.path(), SomeCheckpoint(iterations), &error)) << error;
    ASSERT_TRUE(ReadSolverCheckpoint(dir.path(), SomeKey(), 7, &read, &why_not)) << why_not;
    const SolverCheckpoint expected = SomeCheckpoint(iterations);
    EXPECT_EQ(read.iterations, iterations);
    EXPECT_EQ(read.seconds, expected.seconds);
    EXPECT_EQ(read.loss, expected.loss);
    EXPECT_EQ(read.parameters, expected.parameters);
  }
  EXPECT_TRUE(fs::exists(dir.File("parameters_a.bin")));
  EXPECT_TRUE(fs::exists(dir.File("parameters_b.bin")));
}

// A checkpoint of other options, another model, other targets or another parameter
// count is not resumed, and the reason says which.
TEST(SolverCheckpointTest, ACheckpointOfSomethingElseIsNotResumed) {
  testing::TempDir dir;
  std::string error, why_not;
  ASSERT_TRUE(WriteSolverCheckpoint(dir.path(), SomeCheckpoint(4), &error)) << error;
  SolverCheckpoint read;
  CheckpointKey key = SomeKey();
  key[2].second = "latent_dim=3 hidden=8";
  EXPECT_FALSE(ReadSolverCheckpoint(dir.path(), key, 7, &read, &why_not));
  EXPECT_NE(why_not.find("'options' differs (latent_dim=2 hidden=8; now latent_dim=3 "
                         "hidden=8)"),
            std::string::npos)
      << why_not;
  key = SomeKey();
  key[0].second = "00000000000000ff";
  EXPECT_FALSE(ReadSolverCheckpoint(dir.path(), key, 7, &read, &why_not));
  EXPECT_NE(why_not.find("'model' differs"), std::string::npos) << why_not;
  key = SomeKey();
  key[1].second = "00000000000000ff";
  EXPECT_FALSE(ReadSolverCheckpoint(dir.path(), key, 7, &read, &why_not));
  EXPECT_NE(why_not.find("'targets' differs"), std::string::npos) << why_not;
  key = SomeKey();
  key.push_back({"surfaces", "1"});
  EXPECT_FALSE(ReadSolverCheckpoint(dir.path(), key, 7, &read, &why_not));
  EXPECT_NE(why_not.find("'surfaces' differs (none; now 1)"), std::string::npos) << why_not;
  key = SomeKey();
  key.pop_back();  // the saved 'options' entry is not this run's
  EXPECT_FALSE(ReadSolverCheckpoint(dir.path(), key, 7, &read, &why_not));
  EXPECT_NE(why_not.find("checkpoint.txt: it has other key entries than this run's"),
            std::string::npos)
      << why_not;
  EXPECT_FALSE(ReadSolverCheckpoint(dir.path(), SomeKey(), 8, &read, &why_not));
  EXPECT_NE(why_not.find("7 parameters"), std::string::npos) << why_not;
}

// A damaged checkpoint (a line missing, its parameters file gone) is not resumed, and the
// reason names the file.
TEST(SolverCheckpointTest, ADamagedCheckpointNamesItsFile) {
  testing::TempDir dir;
  std::string error, why_not;
  ASSERT_TRUE(WriteSolverCheckpoint(dir.path(), SomeCheckpoint(4), &error)) << error;
  SolverCheckpoint read;
  fs::remove(dir.File("parameters_a.bin"));
  EXPECT_FALSE(ReadSolverCheckpoint(dir.path(), SomeKey(), 7, &read, &why_not));
  EXPECT_NE(why_not.find("parameters_a.bin"), std::string::npos) << why_not;
  std::ifstream in(dir.File("checkpoint.txt"));
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  text = text.substr(0, text.find("loss "));
  std::ofstream(dir.File("checkpoint.txt")) << text;
  EXPECT_FALSE(ReadSolverCheckpoint(dir.path(), SomeKey(), 7, &read, &why_not));
  EXPECT_NE(why_not.find("checkpoint.txt: no 'loss' line"), std::string::npos) << why_not;
}

class PretrainResumeTest : public ::testing::Test {
 protected:
  void SetUp() override {
    spec_.num_poses = 3;
    spec_.num_threads = 1;
    spec_.pretrain_iterations = 0;
    model_ = testing::PretrainedSyntheticBar(spec_);
    options_ = testing::SyntheticPretrainOptions(spec_);
    options_.checkpoint_directory = dir_.File("pretrain");
    options_.checkpoint_seconds = 0.0;
  }

  PretrainReport Run(int iterations, bool resume = true, ActiveModel* out = nullptr) {
    ActiveModel model = model_;
    PretrainOptions options = options_;
    options.max_iterations = iterations;
    options.resume = resume;
    PretrainReport report;
    std::ostringstream log;
    std::string error;
    EXPECT_TRUE(Pretrain(options, &model, &report, log, &error)) << error;
    if (out != nullptr) *out = model;
    return report;
  }

  SolverCheckpoint Saved() {
    SolverCheckpoint checkpoint;
    std::string why_not;
    const int count = static_cast<int>(model_.decoder_params.size() + model_.latents.size());
    EXPECT_TRUE(ReadSolverCheckpoint(options_.checkpoint_directory,
                                       PretrainCheckpointKey(options_, model_), count,
                                       &checkpoint, &why_not))
        << why_not;
    return checkpoint;
  }

  // Whether pretrain/log.csv has the rows of iterations 0..last, once each, in order.
  ::testing::AssertionResult LogRowsAreZeroTo(int last) {
    const auto rows =
        testing::TrainingLogRows(options_.checkpoint_directory + "/" + kPretrainRunLogName);
    std::string got;
    bool ok = static_cast<int>(rows.size()) == last + 1;
    for (size_t i = 0; i < rows.size(); ++i) {
      got += std::to_string(rows[i].first) + " ";
      ok = ok && rows[i].first == static_cast<int>(i);
    }
    if (ok) return ::testing::AssertionSuccess();
    return ::testing::AssertionFailure() << "log rows " << got << "; expected 0.." << last;
  }

  testing::TempDir dir_;
  testing::SyntheticBarSpec spec_;
  ActiveModel model_;
  PretrainOptions options_;
};

// A run writes a checkpoint at every iteration (checkpoint_seconds 0) and holds its
// last point; the next run with a larger budget starts there, at the loss saved, and
// counts the iterations before it; with the budget used up it adds none; without
// resume it starts anew.
TEST_F(PretrainResumeTest, ResumesAtTheCheckpointAndCountsItsIterations) {
  ActiveModel first;
  const PretrainReport fresh = Run(6, true, &first);
  EXPECT_EQ(fresh.iterations_before, 0);
  EXPECT_EQ(fresh.iterations, 6);
  EXPECT_GE(fresh.checkpoints, 6);
  const SolverCheckpoint saved = Saved();
  EXPECT_EQ(saved.iterations, 6);
  EXPECT_EQ(saved.loss, fresh.final_loss);
  const Eigen::Index np = first.decoder_params.size();
  EXPECT_EQ(saved.parameters.head(np), first.decoder_params);
  EXPECT_EQ(saved.parameters.tail(first.latents.size()),
            Eigen::Map<const Eigen::VectorXd>(first.latents.data(), first.latents.size()));

  ActiveModel same;
  const PretrainReport used_up = Run(6, true, &same);
  EXPECT_EQ(used_up.iterations_before, 6);
  EXPECT_EQ(used_up.iterations, 6);
  EXPECT_EQ(same.decoder_params, first.decoder_params);

  EXPECT_TRUE(LogRowsAreZeroTo(6));

  const PretrainReport resumed = Run(10);
  EXPECT_EQ(resumed.iterations_before, 6);
  EXPECT_EQ(resumed.iterations, 10);
  EXPECT_NEAR(resumed.initial_loss, saved.loss, 1e-12 * saved.loss);
  EXPECT_LT(resumed.final_loss, saved.loss);
  EXPECT_EQ(Saved().iterations, 10);
  EXPECT_TRUE(LogRowsAreZeroTo(10));
  const auto rows =
      testing::TrainingLogRows(options_.checkpoint_directory + "/" + kPretrainRunLogName);
  EXPECT_EQ(rows[6].second, saved.loss);
  EXPECT_EQ(rows[10].second, resumed.final_loss);

  const PretrainReport anew = Run(3, /*resume=*/false);
  EXPECT_EQ(anew.iterations_before, 0);
  EXPECT_NEAR(anew.initial_loss, fresh.initial_loss, 1e-12 * fresh.initial_loss);
  EXPECT_EQ(Saved().iterations, 3);
  std::printf("pre-training: fresh %.6e -> %.6e (6 iterations), resumed %.6e -> %.6e (4 more)\n",
              fresh.initial_loss, fresh.final_loss, resumed.initial_loss, resumed.final_loss);
}

// A checkpoint whose numbers are finite but not the point it recorded (a damaged slot) is
// refused, naming it: resumed, it failed every run with a message about the decoder's
// output scale.
TEST_F(PretrainResumeTest, ACheckpointWhoseNumbersGiveAnotherLossIsRefused) {
  Run(4);
  testing::ScaleCheckpointParameters(options_.checkpoint_directory, 1.5);
  ActiveModel model = model_;
  PretrainOptions options = options_;
  options.max_iterations = 8;
  PretrainReport report;
  std::ostringstream log;
  std::string error;
  EXPECT_FALSE(Pretrain(options, &model, &report, log, &error));
  EXPECT_EQ(error.rfind("the checkpoint in " + options_.checkpoint_directory +
                            " resumed gives a loss of ",
                        0),
            0u)
      << error;
  EXPECT_NE(error.find(": it is damaged; pre-train anew without resuming it"), std::string::npos)
      << error;
  options.resume = false;
  EXPECT_TRUE(Pretrain(options, &model, &report, log, &error)) << error;
  EXPECT_EQ(report.iterations_before, 0);
}

TEST(SameLossTest, EqualToAMillionthAndFinite) {
  EXPECT_TRUE(SameLoss(1.0, 1.0));
  EXPECT_TRUE(SameLoss(1.0 + 5e-7, 1.0));
  EXPECT_FALSE(SameLoss(1.0 + 2e-6, 1.0));
  EXPECT_TRUE(SameLoss(0.0, 0.0));
  EXPECT_FALSE(SameLoss(1e-300, 0.0));
  EXPECT_FALSE(SameLoss(std::nan(""), 1.0));
  EXPECT_FALSE(SameLoss(INFINITY, INFINITY));
}

// A run its time budget stops has the log row and the checkpoint of the iteration it
// stopped at (the budget was checked before the row was written, so the row was lost and
// the next run said rows were missing from a log nobody had touched).
TEST_F(PretrainResumeTest, ARunTheBudgetStopsLogsItsLastIteration) {
  const PretrainReport timed = Run(6);
  ASSERT_EQ(timed.iterations, 6);
  // About three and a half iterations' time: the budget ends the run a few in.
  options_.max_seconds = 3.5 * timed.seconds / 6;
  const PretrainReport stopped = Run(1000, /*resume=*/false);
  std::printf("budget %.3g s: stopped after %d iterations\n", options_.max_seconds,
              stopped.iterations);
  ASSERT_LT(stopped.iterations, 1000);
  EXPECT_EQ(Saved().iterations, stopped.iterations);
  EXPECT_TRUE(LogRowsAreZeroTo(stopped.iterations));
}

// Other options (here the seed of the decoder's weights) do not resume the checkpoint,
// and do not destroy it either: it is kept with its log, and a run of its own options
// takes it back and resumes it (each key's kept apart); without a folder to keep them
// in, it is removed.
TEST_F(PretrainResumeTest, OtherOptionsStartAnewAndKeepTheEarlierCheckpoint) {
  options_.kept_checkpoints_directory = dir_.File("kept");
  Run(4);
  const SolverCheckpoint first = Saved();
  options_.seed = 2;
  const PretrainReport other = Run(5);
  EXPECT_EQ(other.iterations_before, 0);
  EXPECT_EQ(other.iterations, 5);
  options_.seed = 1;
  const PretrainReport again = Run(6);
  EXPECT_EQ(again.iterations_before, 4);
  EXPECT_EQ(again.iterations, 6);
  EXPECT_TRUE(LogRowsAreZeroTo(6));
  options_.seed = 2;
  const PretrainReport back = Run(7);
  EXPECT_EQ(back.iterations_before, 5);
  EXPECT_TRUE(LogRowsAreZeroTo(7));
  // Without a folder to keep them in, a run that starts anew removes the checkpoint.
  options_.kept_checkpoints_directory.clear();
  options_.seed = 1;
  EXPECT_EQ(Run(3).iterations_before, 0);
  options_.seed = 2;
  EXPECT_EQ(Run(3).iterations_before, 0);
  EXPECT_EQ(first.iterations, 4);
}

// MoveSolverCheckpointAside and RestoreKeptCheckpoint: nothing to move without a
// checkpoint; a second move of the same key replaces the first's; another key's is kept
// beside it; at most kMaxKeptCheckpoints are kept, the oldest go.
TEST(SolverCheckpointTest, KeptCheckpointsAreOnePerKeyAndComeBack) {
  testing::TempDir dir;
  const std::string kept = dir.File("kept");
  std::string error;
  bool moved = true;
  ASSERT_TRUE(MoveSolverCheckpointAside(dir.path(), kept, {"log.csv"}, &moved, &error)) << error;
  EXPECT_FALSE(moved);
  EXPECT_FALSE(fs::exists(kept));
  auto write = [&](int iterations, const std::string& option) {
    SolverCheckpoint checkpoint = SomeCheckpoint(iterations);
    checkpoint.key.back().second = option;
    ASSERT_TRUE(WriteSolverCheckpoint(dir.path(), checkpoint, &error)) << error;
    std::ofstream(dir.File("log.csv")) << "log of " << iterations << "\n";
  };
  auto key = [](const std::string& option) {
    CheckpointKey k = SomeKey();
    k.back().second = option;
    return k;
  };
  for (int iterations : {4, 9}) {
    write(iterations, "a");
    ASSERT_TRUE(MoveSolverCheckpointAside(dir.path(), kept, {"log.csv", "absent.csv"}, &moved,
                                          &error))
        << error;
    EXPECT_TRUE(moved);
    SolverCheckpoint read;
    std::string why_not;
    EXPECT_FALSE(ReadSolverCheckpoint(dir.path(), key("a"), 7, &read, &why_not));
    EXPECT_TRUE(why_not.empty()) << why_not;
    const std::string folder = kept + "/" + KeptCheckpointName(key("a"));
    ASSERT_TRUE(ReadSolverCheckpoint(folder, key("a"), 7, &read, &why_not)) << why_not;
    EXPECT_EQ(read.iterations, iterations);
    EXPECT_EQ(testing::ReadAll(folder + "/log.csv"),
              "log of " + std::to_string(iterations) + "\n");
  }
  write(5, "b");
  ASSERT_TRUE(MoveSolverCheckpointAside(dir.path(), kept, {"log.csv"}, &moved, &error)) << error;
  // Both keys kept; "a" comes back (9 iterations, its log), "c" has none.
  bool restored = true;
  ASSERT_TRUE(RestoreKeptCheckpoint(dir.path(), kept, key("c"), {"log.csv"}, &restored, &error))
      << error;
  EXPECT_FALSE(restored);
  ASSERT_TRUE(RestoreKeptCheckpoint(dir.path(), kept, key("a"), {"log.csv"}, &restored, &error))
      << error;
  EXPECT_TRUE(restored);
  SolverCheckpoint read;
  std::string why_not;
  ASSERT_TRUE(ReadSolverCheckpoint(dir.path(), key("a"), 7, &read, &why_not)) << why_not;
  EXPECT_EQ(read.iterations, 9);
  EXPECT_EQ(testing::ReadAll(dir.File("log.csv")), "log of 9\n");
  EXPECT_FALSE(fs::exists(kept + "/" + KeptCheckpointName(key("a"))));
  EXPECT_TRUE(fs::exists(kept + "/" + KeptCheckpointName(key("b")) + "/checkpoint.txt"));
  // Four more keys: the three newest stay.
  ASSERT_TRUE(RemoveSolverCheckpoint(dir.path(), &error)) << error;
  for (const char* option : {"d", "e", "f", "g"}) {
    write(1, option);
    ASSERT_TRUE(MoveSolverCheckpointAside(dir.path(), kept, {}, &moved, &error)) << error;
  }
  int folders = 0;
  for (const auto& entry : fs::directory_iterator(kept)) folders += entry.is_directory();
  EXPECT_EQ(folders, kMaxKeptCheckpoints);
  EXPECT_TRUE(fs::exists(kept + "/" + KeptCheckpointName(key("g"))));
  EXPECT_FALSE(fs::exists(kept + "/" + KeptCheckpointName(key("b"))));
}

// aqs_pretrain's library call killed (SIGKILL) after the parameters of its second
// checkpoint are written and before checkpoint.txt names them: the first checkpoint is
// whole (its own slot), and the next run resumes it, at its loss. Saving the model at the
// end removes the checkpoint.
TEST(PretrainKillTest, AKilledRunResumesItsLastWholeCheckpoint) {
  testing::TempDir dir;
  const std::string path = dir.File("m");
  ASSERT_NO_FATAL_FAILURE(testing::WritePretrainedSyntheticModel(path, 3, 11, 8, 2));
  ASSERT_EQ(testing::RunProgram({AQS_KILL_AT, "solver_checkpoint:parameters_written", "1",
                                 path, "8", "pretrain"}),
            "killed");
  testing::SyntheticBarSpec spec;
  spec.num_threads = 1;
  spec.pretrain_iterations = 8;
  PretrainOptions options = testing::SyntheticPretrainOptions(spec);
  std::string error, why_not;
  SolverCheckpoint saved;
  ASSERT_TRUE(ReadPretrainCheckpoint(path, path + "/pretrain", options, &saved, &why_not))
      << why_not;
  EXPECT_EQ(saved.iterations, 1);
  std::ostringstream log;
  ASSERT_TRUE(RunPretrainJob(path, options, nullptr, log, &error)) << error;
  EXPECT_NE(log.str().find("resuming after iteration 1 "), std::string::npos) << log.str();
  char start[64];
  std::snprintf(start, sizeof(start), "iterations, loss %.6g -> ", saved.loss);
  EXPECT_NE(log.str().find(start), std::string::npos) << start << "\n" << log.str();
  EXPECT_FALSE(fs::exists(path + "/pretrain/checkpoint.txt"));
  // The log went into the saved model, whole: rows 0..8 once each (the killed run had
  // logged row 2 past its checkpoint of iteration 1).
  const auto rows = testing::TrainingLogRows(path + "/pretrain/log.csv");
  ASSERT_EQ(rows.size(), 9u);
  for (int i = 0; i <= 8; ++i) EXPECT_EQ(rows[i].first, i);
  EXPECT_EQ(rows[1].second, saved.loss);
  ActiveModel done;
  ASSERT_TRUE(LoadModel(path, &done, &error)) << error;
}

// A pre-training stopped in a model's folder leaves the model's pretrain/log.csv, its
// decoder's, as it was (the running log is kept apart: it replaced the model's at the
// start). A run that starts anew (--restart) moves the earlier run's checkpoint out of
// pretrain/ at once (into MODEL.aqs-pretrain-kept): killed before its own first
// checkpoint, it left the old one for the next run to resume, beside a log of its own.
TEST(PretrainKillTest, AStoppedRunKeepsTheModelsLogAndARestartKeepsTheOldCheckpoint) {
  testing::TempDir dir;
  const std::string path = dir.File("m");
  ASSERT_NO_FATAL_FAILURE(testing::WritePretrainedSyntheticModel(path, 3, 11, 8, 2));
  ASSERT_EQ(testing::RunProgram({AQS_KILL_AT, "none", "0", path, "4", "pretrain"}), "exit 0");
  const std::string model_log = testing::ReadAll(path + "/pretrain/log.csv");
  ASSERT_EQ(testing::TrainingLogRows(path + "/pretrain/log.csv").size(), 5u);
  testing::SyntheticBarSpec spec;
  spec.num_threads = 1;
  const PretrainOptions options = testing::SyntheticPretrainOptions(spec);
  auto saved_checkpoint = [&](SolverCheckpoint* saved) {
    std::string why_not;
    return ReadPretrainCheckpoint(path, path + "/pretrain", options, saved, &why_not);
  };
  // Killed while it writes its third checkpoint: those of iterations 1 and 2 are whole.
  ASSERT_EQ(testing::RunProgram({AQS_KILL_AT, "solver_checkpoint:parameters_written", "2", path,
                                 "8", "pretrain"}),
            "killed");
  SolverCheckpoint saved;
  ASSERT_TRUE(saved_checkpoint(&saved));
  EXPECT_EQ(saved.iterations, 2);
  EXPECT_EQ(testing::ReadAll(path + "/pretrain/log.csv"), model_log);
  // A restart killed while it writes its first checkpoint.
  ASSERT_EQ(testing::RunProgram({AQS_KILL_AT, "solver_checkpoint:parameters_written", "0", path,
                                 "8", "pretrain_restart"}),
            "killed");
  EXPECT_FALSE(saved_checkpoint(&saved)) << "iteration " << saved.iterations;
  EXPECT_EQ(testing::ReadAll(path + "/pretrain/log.csv"), model_log);
  // The abandoned checkpoint was kept, not deleted: the next run of its options takes
  // it back and resumes it, runs to the end, and the model saves and loads (the kept
  // checkpoints are not in the model's folder).
  std::ostringstream log;
  std::string error;
  ASSERT_TRUE(RunPretrainJob(path, options, nullptr, log, &error)) << error;
  EXPECT_NE(log.str().find("pretrain: resuming after iteration 2 "), std::string::npos)
      << log.str();
  ActiveModel done;
  EXPECT_TRUE(LoadModel(path, &done, &error)) << error;
}

// A restart killed while it moves the earlier run's checkpoint aside (after the copies
// into the staging folder, after the removal of an earlier kept copy of its key (here
// none), after the rename, before checkpoint.txt is removed): the checkpoint is whole in
// pretrain/ (and after the rename a whole copy in the kept folder too), the next run of
// its options resumes it, and no kept copy or staging folder of its key stays behind.
TEST(PretrainKillTest, ARestartKilledWhileItMovesTheCheckpointAsideLosesNothing) {
  testing::TempDir dir;
  const std::string original = dir.File("m");
  ASSERT_NO_FATAL_FAILURE(testing::WritePretrainedSyntheticModel(original, 3, 11, 8, 2));
  ASSERT_EQ(testing::RunProgram({AQS_KILL_AT, "solver_checkpoint:parameters_written", "2",
                                 original, "8", "pretrain"}),
            "killed");
  testing::SyntheticBarSpec spec;
  spec.num_threads = 1;
  spec.pretrain_iterations = 8;
  const PretrainOptions options = testing::SyntheticPretrainOptions(spec);
  for (const char* point : {"checkpoint_aside:copied", "checkpoint_aside:old_removed",
                            "checkpoint_aside:renamed"}) {
    SCOPED_TRACE(point);
    const std::string path = dir.File(std::string("m_") + (std::strchr(point, ':') + 1));
    fs::copy(original, path, fs::copy_options::recursive);
    ASSERT_FALSE(fs::exists(KeptPretrainCheckpointsPath(path)));
    ASSERT_EQ(testing::RunProgram({AQS_KILL_AT, point, "0", path, "8", "pretrain_restart"}),
              "killed");
    std::string error, why_not;
    CheckpointKey key;
    SolverCheckpoint read;
    ASSERT_TRUE(ReadPretrainCheckpoint(path, path + "/pretrain", options, &read, &why_not, &key))
        << why_not;
    const std::string kept = KeptPretrainCheckpointsPath(path) + "/" + KeptCheckpointName(key);
    EXPECT_EQ(read.iterations, 2);
    if (std::string(point) == "checkpoint_aside:renamed") {
      // In both places: the copy is whole too.
      ASSERT_TRUE(ReadPretrainCheckpoint(path, kept, options, &read, &why_not)) << why_not;
      EXPECT_EQ(read.iterations, 2);
    } else {
      EXPECT_FALSE(fs::exists(kept));
      EXPECT_TRUE(fs::exists(kept + ".tmp"));
    }
    std::ostringstream log;
    ASSERT_TRUE(RunPretrainJob(path, options, nullptr, log, &error)) << error;
    EXPECT_NE(log.str().find("pretrain: resuming after iteration 2 "), std::string::npos)
        << log.str();
    ActiveModel done;
    EXPECT_TRUE(LoadModel(path, &done, &error)) << error;
    // Resumed from pretrain/: no copy of the key stays kept, to be taken back by a later
    // pre-training of these options that would otherwise start anew.
    EXPECT_FALSE(fs::exists(kept));
    EXPECT_FALSE(fs::exists(kept + ".tmp"));
  }
}

}  // namespace
}  // namespace aqs
