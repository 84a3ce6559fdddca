// aqs_train's distributed-run input that needs no MPI to test: --mpi (or an MPI
// launcher's environment) in a build without MPI stops with a message and exit 1; a
// model whose learned state belongs to another model is refused.

#include <cstdlib>
#include <filesystem>
#include <sstream>

#include <gtest/gtest.h>

#include "testing/training_fixtures.h"

#include "model/model_io.h"
#include "prepare/volumetric_targets.h"
#include "testing/run_command.h"
#include "testing/synthetic_muscles.h"
#include "testing/temp_dir.h"
#include "train/pretrain.h"

namespace aqs {
namespace {

namespace fs = std::filesystem;
using testing::AppPath;
using testing::CommandResult;
using testing::RunCommand;

// A small pre-trained synthetic bar; `seed` picks its poses.
void WriteModel(const std::string& path, unsigned seed) {
  testing::WritePretrainedSyntheticModel(path, 2, seed, 4, 5);
}

TEST(AqsTrainDistributedInputTest, MpiWantedButNotBuiltExitsOne) {
  testing::TempDir dir;
  const std::string model = dir.File("m");
  WriteModel(model, 5);
#if AQS_TESTS_WITH_MPI
  // Built with MPI: --mpi alone runs as the only rank of a one-process MPI job.
  const CommandResult run =
      RunCommand("OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_btl=self,vader " +
                 AppPath("aqs_train") + " --mpi --model=" + model + " --train_iterations=1 --threads=1");
  EXPECT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("train iter     1/1"), std::string::npos) << run.output;
#else
  CommandResult run = RunCommand(AppPath("aqs_train") + " --mpi --model=" + model);
  EXPECT_EQ(run.exit_code, 1) << run.output;
  EXPECT_NE(run.output.find("aqs_train: error: --mpi: this ActiveQS was built without MPI"),
            std::string::npos) << run.output;
  EXPECT_EQ(run.output.find("train: 2 poses"), std::string::npos) << run.output;
  // As one of the processes mpirun starts (its environment says so).
  for (const char* variable : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE"}) {
    run = RunCommand(std::string(variable) + "=2 " + AppPath("aqs_train") + " --model=" + model);
    EXPECT_EQ(run.exit_code, 1) << run.output;
    EXPECT_NE(run.output.find("started by an MPI launcher as one of 2 processes, but this "
                              "ActiveQS was built without MPI"),
              std::string::npos) << run.output;
  }
  for (const char* app : {"aqs_pipeline", "aqs_evaluate"}) {
    run = RunCommand(AppPath(app) + " --mpi --model=" + model);
    EXPECT_EQ(run.exit_code, 1) << app << ": " << run.output;
    EXPECT_NE(run.output.find("built without MPI"), std::string::npos) << run.output;
  }
#endif
}

TEST(AqsTrainDistributedInputTest, LearnedStateOfAnotherModelExitsOne) {
  testing::TempDir dir;
  WriteModel(dir.File("a"), 5);
  WriteModel(dir.File("b"), 6);
  fs::remove_all(dir.File("a/learned"));
  fs::copy(dir.File("b/learned"), dir.File("a/learned"), fs::copy_options::recursive);
  const CommandResult run = RunCommand(AppPath("aqs_train") + " --model=" + dir.File("a") +
                                       " --train_iterations=1 --threads=1");
  EXPECT_EQ(run.exit_code, 1) << run.output;
  EXPECT_NE(run.output.find(dir.File("a/learned/checkpoint.txt") +
                            ": the learned state belongs to another model"),
            std::string::npos) << run.output;
  EXPECT_EQ(run.output.find("train: 2 poses"), std::string::npos) << run.output;
}

}  // namespace
}  // namespace aqs
