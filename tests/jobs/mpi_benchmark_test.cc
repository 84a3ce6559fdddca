// The MPI scaling benchmark as a library call (jobs/mpi_benchmark.h), in one process:
// its options, the model checks, and the rows it prints. Its runs on several ranks are
// in tests/dist (MPI builds).

#include "jobs/mpi_benchmark.h"

#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "model/model_io.h"
#include "testing/temp_dir.h"
#include "testing/training_fixtures.h"

namespace aqs {
namespace {

TEST(MpiBenchmarkTest, OptionsNameTheBadField) {
  MpiBenchmarkOptions options;
  std::string error;
  EXPECT_FALSE(options.Validate(&error));
  EXPECT_EQ(error, "model is required");
  options.model = "m";
  EXPECT_TRUE(options.Validate(&error)) << error;
  options.repeats = 0;
  EXPECT_FALSE(options.Validate(&error));
  EXPECT_EQ(error.rfind("repeats", 0), 0u) << error;
  options.repeats = 1;
  options.reduction_calls = 0;
  EXPECT_FALSE(options.Validate(&error));
  EXPECT_EQ(error.rfind("reduction_calls", 0), 0u) << error;
  options.reduction_calls = 1;
  options.train.num_threads = 0;
  EXPECT_FALSE(options.Validate(&error));
  EXPECT_EQ(error.rfind("train.num_threads", 0), 0u) << error;
}

TEST(MpiBenchmarkTest, OneProcessPrintsItsRunsAndReductions) {
  testing::SyntheticBarSpec spec;
  spec.num_poses = 3;
  const ActiveModel model = testing::PretrainedSyntheticBar(spec);
  testing::TempDir dir;
  std::string error;
  ASSERT_TRUE(SaveModel(dir.File("m"), model, &error)) << error;
  MpiBenchmarkOptions options;
  options.model = dir.File("m");
  options.iterations = 1;
  options.repeats = 2;
  options.reduction_calls = 3;
  options.train.num_threads = 1;
  std::ostringstream out;
  ASSERT_EQ(RunMpiBenchmark(options, nullptr, out, &error), JobStatus::kOk) << error;
  const std::string text = out.str();
  EXPECT_EQ(text.rfind("machine ", 0), 0u) << text;
  EXPECT_NE(text.find("3 poses"), std::string::npos) << text;
  // One process: two runs on rank 0 alone, no run "on all ranks", no speed-up.
  size_t rows = 0;
  for (size_t at = text.find("\n1             1 "); at != std::string::npos;
       at = text.find("\n1             1 ", at + 1)) {
    ++rows;
  }
  EXPECT_EQ(rows, 2u) << text;
  EXPECT_EQ(text.find("speed-up"), std::string::npos) << text;
  const std::string decoder_size = std::to_string(model.decoder->num_parameters());
  EXPECT_NE(text.find("SumToRoot (gradient)         " +
                      std::string(10 - decoder_size.size(), ' ') + decoder_size),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("Broadcast (parameters)"), std::string::npos) << text;
  EXPECT_NE(text.find(" (after)\n"), std::string::npos) << text;
}

TEST(MpiBenchmarkTest, UnreadableOrUntrainedModelsAreBadInput) {
  testing::TempDir dir;
  MpiBenchmarkOptions options;
  options.model = dir.File("missing");
  std::ostringstream out;
  std::string error;
  EXPECT_EQ(RunMpiBenchmark(options, nullptr, out, &error), JobStatus::kBadInput);
  EXPECT_NE(error.find("missing"), std::string::npos) << error;

  ActiveModel untrained = testing::PretrainedSyntheticBar(testing::SyntheticBarSpec());
  untrained.decoder.reset();
  ASSERT_TRUE(SaveModel(dir.File("u"), untrained, &error)) << error;
  options.model = dir.File("u");
  EXPECT_EQ(RunMpiBenchmark(options, nullptr, out, &error), JobStatus::kBadInput);
  EXPECT_NE(error.find("not pre-trained"), std::string::npos) << error;
  EXPECT_TRUE(out.str().empty()) << out.str();
}

}  // namespace
}  // namespace aqs
