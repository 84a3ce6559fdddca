// Sequence fits in one process (jobs/fit_sequence.h): independent frames
// (warm_start = false) give each frame the result it gets alone, whatever comes before
// it, and resume like warm-started sequences.

#include "jobs/fit_sequence.h"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include <gtest/gtest.h>

#include "fit/latent_fit.h"
#include "mesh/mesh_io.h"
#include "prepare/volumetric_targets.h"
#include "testing/file_contents.h"
#include "testing/temp_dir.h"
#include "train/pretrain.h"
#include "util/fault_injection.h"
#include "util/text_split.h"
#include "testing/synthetic_muscles.h"
#include "util/matrix_io.h"

namespace aqs {
namespace {

using testing::ReadAll;

// frames.csv's rows by frame name, without the frame index (column 0) and the seconds
// (column 10), the only columns that may differ between runs of the same frames.
std::map<std::string, std::vector<std::string>> Rows(const std::string& csv) {
  std::map<std::string, std::vector<std::string>> rows;
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);
  while (std::getline(in, line)) {
    std::vector<std::string> cells = SplitFields(line);
    EXPECT_GT(cells.size(), 14u) << line;
    if (cells.size() <= 14) continue;
    cells[10] = "";
    cells[0] = "";
    rows[cells[1]] = cells;
  }
  return rows;
}

// A small pre-trained bar with 4 poses and an equilibrium stored per pose (so that fits
// can start from a training pose), and 3 held-out pose targets written as OBJs.
class FitSequenceTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir;
    testing::SyntheticMuscles data = testing::MakeSyntheticMuscles(4, 0, 0.3, 11);
    model_ = new ActiveModel(data.model);
    std::ostringstream log;
    std::string error;
    VolumetricTargetOptions targets;
    targets.num_threads = 1;
    ASSERT_TRUE(MakeVolumetricTargets(targets, model_, log, &error)) << error;
    PretrainOptions pretrain;
    pretrain.spec.latent_dim = 2;
    pretrain.spec.hidden_dims = {8};
    pretrain.spec.activation = Activation::kTanh;
    pretrain.field.node_spacing = 0.35;
    pretrain.max_iterations = 30;
    pretrain.log_every = 0;
    PretrainReport report;
    ASSERT_TRUE(Pretrain(pretrain, model_, &report, log, &error)) << error;
    LatentFitter fitter(*model_, Options().fit);
    for (int p = 0; p < model_->num_poses(); ++p) {
      Eigen::Matrix3Xd state, surface;
      ASSERT_TRUE(fitter.Simulate(model_->latents.col(p), &state, &surface, &error)) << error;
      model_->states.push_back(state);
    }
    const testing::SyntheticMuscles held_out = testing::MakeSyntheticMuscles(1, 3, 0.3, 23);
    for (size_t t = 0; t < held_out.test_surfaces.size(); ++t) {
      SurfaceMesh surface = model_->neutral;
      surface.vertices = held_out.test_surfaces[t];
      ASSERT_TRUE(WriteObj(Target(t), surface, &error)) << error;
    }
  }
  static void TearDownTestSuite() {
    delete dir_;
    delete model_;
  }

  static std::string Target(int t) { return dir_->File("t" + std::to_string(t) + ".obj"); }

  static FitSequenceOptions Options() {
    FitSequenceOptions options;
    options.model = "bar";
    options.fit.num_threads = 1;
    options.fit.max_iterations = 10;
    return options;
  }

  // Frames a, b, c (copies of targets 0, 1, 2 in folder `in`), fitted independently into
  // folder `out` once; the options of that run.
  static FitSequenceOptions FitThreeFrameCopies(const std::string& in, const std::string& out) {
    std::filesystem::create_directories(dir_->File(in));
    FitSequenceOptions options = Options();
    int t = 0;
    for (const char* name : {"a", "b", "c"}) {
      const std::string frame = dir_->File(in) + "/" + name + ".obj";
      std::filesystem::copy_file(Target(t++), frame);
      options.sequence += frame + ",";
    }
    options.output_dir = dir_->File(out);
    options.warm_start = false;
    std::ostringstream log;
    EXPECT_EQ(RunFitSequence(options, *model_, log).status, JobStatus::kOk) << log.str();
    return options;
  }

  // Fits targets `order` (indices) into output folder `out`.
  static FitSequenceResult Run(const std::vector<int>& order, const std::string& out,
                               bool warm_start) {
    FitSequenceOptions options = Options();
    for (int t : order) options.sequence += Target(t) + ",";
    options.output_dir = dir_->File(out);
    options.warm_start = warm_start;
    std::ostringstream log;
    FitSequenceResult result = RunFitSequence(options, *model_, log);
    EXPECT_EQ(result.status, JobStatus::kOk) << result.message << "\n" << log.str();
    return result;
  }

  static testing::TempDir* dir_;
  static ActiveModel* model_;
};

testing::TempDir* FitSequenceTest::dir_ = nullptr;
ActiveModel* FitSequenceTest::model_ = nullptr;

TEST_F(FitSequenceTest, IndependentFramesDependOnNothingButTheirTarget) {
  Run({0, 1, 2}, "forward", false);
  Run({2, 1}, "backward", false);  // another order, other frames before each
  Run({1}, "alone", false);
  const auto forward = Rows(dir_->File("forward/frames.csv"));
  const auto backward = Rows(dir_->File("backward/frames.csv"));
  const auto alone = Rows(dir_->File("alone/frames.csv"));
  ASSERT_EQ(forward.size(), 3u);
  ASSERT_EQ(backward.size(), 2u);
  ASSERT_EQ(alone.size(), 1u);
  for (const auto& [name, row] : backward) {
    EXPECT_EQ(row, forward.at(name)) << name;
    EXPECT_NE(row[12], "previous") << name << ": every frame chooses its own start";
    EXPECT_EQ(ReadAll(dir_->File("backward/" + name + ".obj")),
              ReadAll(dir_->File("forward/" + name + ".obj")))
        << name;
  }
  EXPECT_EQ(alone.at("t1"), forward.at("t1"));
  EXPECT_EQ(ReadAll(dir_->File("alone/t1.obj")), ReadAll(dir_->File("forward/t1.obj")));
  // Warm starts: the first frame is the same fit, the next ones start from the previous
  // frame's result (which is what makes them depend on the order).
  Run({0, 1, 2}, "warm", true);
  const auto warm = Rows(dir_->File("warm/frames.csv"));
  ASSERT_EQ(warm.size(), 3u);
  EXPECT_EQ(warm.at("t0"), forward.at("t0"));
  EXPECT_EQ(warm.at("t1")[12], "previous");
  EXPECT_EQ(warm.at("t2")[12], "previous");
}

TEST_F(FitSequenceTest, IndependentFramesResumeWithTheSameResults) {
  Run({0, 1, 2}, "whole", false);
  // A kill after frame 0's row was written.
  Run({0}, "resumed", false);
  const FitSequenceResult result = Run({0, 1, 2}, "resumed", false);
  EXPECT_EQ(result.frames_resumed, 1);
  EXPECT_EQ(result.frames_fitted, 2);
  EXPECT_EQ(Rows(dir_->File("resumed/frames.csv")), Rows(dir_->File("whole/frames.csv")));
  EXPECT_EQ(ReadAll(dir_->File("resumed/latents.bin")), ReadAll(dir_->File("whole/latents.bin")));
  for (const char* name : {"t0", "t1", "t2"}) {
    EXPECT_EQ(ReadAll(dir_->File("resumed/" + std::string(name) + ".obj")),
              ReadAll(dir_->File("whole/" + std::string(name) + ".obj")))
        << name;
  }
  // A damaged row (a figure that is not a number) is refused, naming its line, rather
  // than copied into the rewritten frames.csv.
  std::string csv = ReadAll(dir_->File("resumed/frames.csv"));
  const size_t row = csv.find('\n') + 1;  // frame 0's row
  size_t field = row;
  for (int c = 0; c < 6; ++c) field = csv.find(',', field) + 1;  // mean_error
  csv.replace(field, csv.find(',', field) - field, "nan");
  std::ofstream(dir_->File("resumed/frames.csv")) << csv;
  FitSequenceOptions options = Options();
  for (int t : {0, 1, 2}) options.sequence += Target(t) + ",";
  options.output_dir = dir_->File("resumed");
  options.warm_start = false;
  std::ostringstream log;
  const FitSequenceResult damaged = RunFitSequence(options, *model_, log);
  EXPECT_EQ(damaged.status, JobStatus::kBadInput);
  EXPECT_NE(damaged.message.find("frames.csv:2: a number of the row"), std::string::npos)
      << damaged.message;
}

// The row a warm-started sequence continues from drives the next solve, so it is checked
// as a latent file is: a latent that is finite but decodes to absurd actuations is refused
// naming frames.csv and its line, before any solve (it ran for minutes to a solve that
// failed, naming nothing).
TEST_F(FitSequenceTest, AWarmResumeFromAnAbsurdRowIsRefusedNamingItsLine) {
  // A decoder with a linear part, so that a far latent decodes far (the fixture's tanh
  // network alone saturates).
  ActiveModel skip = *model_;
  PretrainOptions pretrain;
  pretrain.spec.latent_dim = 2;
  pretrain.spec.hidden_dims = {8};
  pretrain.spec.activation = Activation::kTanh;
  pretrain.spec.linear_skip = true;
  pretrain.field.node_spacing = 0.35;
  pretrain.max_iterations = 10;
  pretrain.log_every = 0;
  PretrainReport report;
  std::ostringstream log;
  std::string error;
  ASSERT_TRUE(Pretrain(pretrain, &skip, &report, log, &error)) << error;
  FitSequenceOptions options = Options();
  options.start.training_poses = false;  // the fixture's states are of its own decoder
  options.sequence = Target(0) + ",";
  options.output_dir = dir_->File("absurd");
  ASSERT_EQ(RunFitSequence(options, skip, log).status, JobStatus::kOk) << log.str();
  std::string csv = ReadAll(dir_->File("absurd/frames.csv"));
  size_t field = csv.find('\n') + 1;                                   // frame 0's row
  for (int c = 0; c < 14; ++c) field = csv.find(',', field) + 1;       // z0
  csv.replace(field, csv.find(',', field) - field, "1e6");
  std::ofstream(dir_->File("absurd/frames.csv"), std::ios::trunc) << csv;
  options.sequence = Target(0) + "," + Target(1) + ",";
  const FitSequenceResult result = RunFitSequence(options, skip, log);
  EXPECT_EQ(result.status, JobStatus::kBadInput);
  EXPECT_EQ(result.message.rfind(dir_->File("absurd") + "/frames.csv:2: the latent decodes to "
                                                        "actuations with entries up to ",
                                 0),
            0u)
      << result.message;
  EXPECT_EQ(result.frames_fitted, 0);
}

// The temporal prior pulls every frame after the first toward the one before it (here
// strongly), is part of the folder's key, resumes from the last frame done as an
// unstopped run goes on, and needs warm starts.
TEST_F(FitSequenceTest, ATemporalPriorPullsEachFrameTowardTheOneBefore) {
  auto track = [&](const std::string& out, double temporal_prior, int max_frames) {
    FitSequenceOptions options = Options();
    for (int t : {0, 1, 2}) options.sequence += Target(t) + ",";
    options.output_dir = dir_->File(out);
    options.temporal_prior = temporal_prior;
    options.max_frames = max_frames;
    std::ostringstream log;
    const FitSequenceResult result = RunFitSequence(options, *model_, log);
    EXPECT_EQ(result.status, JobStatus::kOk) << result.message << "\n" << log.str();
    Eigen::MatrixXd latents;
    std::string error;
    EXPECT_TRUE(ReadMatrixFile(options.output_dir + "/latents.bin", 2, -1, &latents, &error))
        << error;
    return latents;
  };
  const Eigen::MatrixXd free = track("untimed", 0.0, -1);
  const Eigen::MatrixXd held = track("timed", 10.0, -1);
  EXPECT_LT((free.col(0) - held.col(0)).norm(), 1e-9) << "the first frame has no frame before";
  for (int f = 1; f < 3; ++f) {
    SCOPED_TRACE(f);
    const double free_step = (free.col(f) - free.col(f - 1)).norm();
    const double held_step = (held.col(f) - held.col(f - 1)).norm();
    std::printf("frame %d: latent step %.4g, with the temporal prior %.4g\n", f, free_step,
                held_step);
    EXPECT_LT(held_step, 0.8 * free_step);
  }
  // Stopped after two frames, then resumed: the third frame is pulled toward the second
  // as in the run that was not stopped.
  track("timed_resumed", 10.0, 2);
  const Eigen::MatrixXd resumed = track("timed_resumed", 10.0, -1);
  EXPECT_LT((resumed - held).norm(), 1e-6 * (1.0 + held.norm()));
  // Frames fitted without it are not taken for frames with it.
  FitSequenceOptions options = Options();
  for (int t : {0, 1, 2}) options.sequence += Target(t) + ",";
  options.output_dir = dir_->File("untimed");
  options.temporal_prior = 10.0;
  std::ostringstream log;
  FitSequenceResult other = RunFitSequence(options, *model_, log);
  EXPECT_EQ(other.status, JobStatus::kBadInput);
  EXPECT_NE(other.message.find("key.txt"), std::string::npos) << other.message;
  options.output_dir = dir_->File("timed_independent");
  options.warm_start = false;
  other = RunFitSequence(options, *model_, log);
  EXPECT_EQ(other.status, JobStatus::kBadInput);
  EXPECT_NE(other.message.find("temporal_prior pulls a frame toward the previous one"),
            std::string::npos)
      << other.message;
}

// Frames of another model or other fit options are refused, never mixed with this
// run's (output_dir/key.txt); the same options resume.
TEST_F(FitSequenceTest, FramesOfOtherOptionsAreRefused) {
  Run({0}, "keyed", false);
  FitSequenceOptions options = Options();
  for (int t : {0, 1}) options.sequence += Target(t) + ",";
  options.output_dir = dir_->File("keyed");
  options.warm_start = false;
  options.fit.latent_prior *= 2;
  std::ostringstream log;
  const FitSequenceResult other = RunFitSequence(options, *model_, log);
  EXPECT_EQ(other.status, JobStatus::kBadInput);
  EXPECT_NE(other.message.find("its frames were fitted with another model or other fit "
                               "options (key.txt)"),
            std::string::npos)
      << other.message;
  EXPECT_EQ(Rows(dir_->File("keyed/frames.csv")).size(), 1u) << "nothing written";
  const FitSequenceResult same = Run({0, 1}, "keyed", false);
  EXPECT_EQ(same.frames_resumed, 1);
  EXPECT_EQ(same.frames_fitted, 1);
}

// A frame whose target file was rewritten with other numbers after it was fitted is
// fitted again, and so are the frames after it (targets.txt); the frames before it are
// kept. Here frame b's file is given the surface of another pose.
TEST_F(FitSequenceTest, AFrameWhoseTargetChangedIsFittedAgain) {
  const std::string in = dir_->File("retarget_in");
  const FitSequenceOptions options = FitThreeFrameCopies("retarget_in", "retargeted");
  ASSERT_FALSE(::testing::Test::HasFailure());
  Run({0, 1, 2}, "retarget_reference", false);
  std::filesystem::copy_file(Target(2), in + "/b.obj",
                             std::filesystem::copy_options::overwrite_existing);
  std::ostringstream log;
  const FitSequenceResult result = RunFitSequence(options, *model_, log);
  ASSERT_EQ(result.status, JobStatus::kOk) << result.message << "\n" << log.str();
  EXPECT_EQ(result.frames_resumed, 1);
  EXPECT_EQ(result.frames_fitted, 2);
  EXPECT_NE(log.str().find("frame 1 (b): its target differs from the one it was fitted to"),
            std::string::npos)
      << log.str();
  EXPECT_EQ(ReadAll(dir_->File("retargeted/b.obj")),
            ReadAll(dir_->File("retarget_reference/t2.obj")))
      << "b is fitted to its new target";
  std::vector<std::string> b_row = Rows(dir_->File("retargeted/frames.csv")).at("b");
  std::vector<std::string> t2_row = Rows(dir_->File("retarget_reference/frames.csv")).at("t2");
  b_row[1] = t2_row[1] = "";
  EXPECT_EQ(b_row, t2_row);
  // Unchanged targets: all frames are done.
  std::ostringstream again_log;
  EXPECT_EQ(RunFitSequence(options, *model_, again_log).frames_resumed, 3) << again_log.str();
}

// What WatchTargetsInstall saw: the frames with a row in frames.csv when targets.txt
// first changed from g_targets_before (in g_sequence_folder).
std::string g_sequence_folder, g_targets_before;
bool g_targets_changed = false;
std::vector<std::string> g_rows_at_targets;
Eigen::Index g_latent_columns_at_targets = -1;
bool g_frame_c_at_targets = false;

void WatchTargetsInstall(const char* point) {
  if (std::string(point) != "atomic_file:renamed" || g_targets_changed) return;
  if (ReadAll(g_sequence_folder + "/targets.txt") == g_targets_before) return;
  g_targets_changed = true;
  for (const auto& [name, row] : Rows(g_sequence_folder + "/frames.csv")) {
    g_rows_at_targets.push_back(name);
  }
  Eigen::MatrixXd track;
  std::string error;
  if (ReadMatrixFile(g_sequence_folder + "/latents.bin", -1, -1, &track, &error)) {
    g_latent_columns_at_targets = track.cols();
  }
  g_frame_c_at_targets = std::filesystem::exists(g_sequence_folder + "/c.obj");
}

// frames.csv is cut back to the frames done before targets.txt records new targets, also
// past a frame whose OBJ is missing (frames.csv's rows after it are not read as done, and
// a later frame's may be of an old target: a run killed after targets.txt is written
// would otherwise keep them as fits of the new one). latents.bin is cut back with it,
// and the OBJs of the frames not done go (they had stayed until the frames were fitted
// again: a kill in between left latents and OBJs of old targets beside 1 row).
TEST_F(FitSequenceTest, RowsPastAMissingFrameGoBeforeNewTargetsAreRecorded) {
  const std::string in = dir_->File("cutback_in");
  const FitSequenceOptions options = FitThreeFrameCopies("cutback_in", "cutback");
  ASSERT_FALSE(::testing::Test::HasFailure());
  ASSERT_EQ(Rows(options.output_dir + "/frames.csv").size(), 3u);
  std::filesystem::remove(options.output_dir + "/b.obj");
  std::filesystem::copy_file(Target(0), in + "/c.obj",
                             std::filesystem::copy_options::overwrite_existing);
  g_sequence_folder = options.output_dir;
  g_targets_before = ReadAll(options.output_dir + "/targets.txt");
  const FaultHook previous = SetFaultHookForTesting(&WatchTargetsInstall);
  std::ostringstream log;
  const FitSequenceResult result = RunFitSequence(options, *model_, log);
  SetFaultHookForTesting(previous);
  ASSERT_EQ(result.status, JobStatus::kOk) << result.message << "\n" << log.str();
  EXPECT_EQ(result.frames_resumed, 1);
  EXPECT_EQ(result.frames_fitted, 2);
  ASSERT_TRUE(g_targets_changed);
  EXPECT_EQ(g_rows_at_targets, std::vector<std::string>{"a"});
  EXPECT_EQ(g_latent_columns_at_targets, 1);
  EXPECT_FALSE(g_frame_c_at_targets);
}

// Fails every fit's minimizer once the file g_fail_after exists (here frame 0's OBJ: the
// fits of the frames after it, however many minimizer runs frame 0's fit makes).
std::string g_fail_after;
bool FailAfterAFileIsWritten(const char* point) {
  return std::string(point) == "latent_fit:minimizer" && std::filesystem::exists(g_fail_after);
}

// A warm-started sequence stops at a frame whose minimizer failed: that frame has neither
// row nor OBJ (no result, not a fit that did not converge), and no frame starts from it.
TEST_F(FitSequenceTest, AWarmFrameWhoseMinimizerFailedStopsTheSequence) {
  g_fail_after = dir_->File("failed_minimizer/t0.obj");
  const FailureHook previous = SetFailureHookForTesting(&FailAfterAFileIsWritten);
  FitSequenceOptions options = Options();
  for (int t : {0, 1, 2}) options.sequence += Target(t) + ",";
  options.output_dir = dir_->File("failed_minimizer");
  options.warm_start = true;
  std::ostringstream log;
  const FitSequenceResult result = RunFitSequence(options, *model_, log);
  SetFailureHookForTesting(previous);
  // The second frame is no result: not written as a fit that did not converge, and no
  // frame starts from it.
  EXPECT_EQ(result.status, JobStatus::kNotConverged) << log.str();
  EXPECT_NE(result.message.find(Target(1) + ": the fit failed: the minimizer failed (test)"),
            std::string::npos)
      << result.message;
  EXPECT_EQ(result.frames_fitted, 1) << log.str();
  const auto rows = Rows(dir_->File("failed_minimizer/frames.csv"));
  EXPECT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows.count("t0"), 1u);
  EXPECT_TRUE(std::filesystem::exists(dir_->File("failed_minimizer/t0.obj")));
  EXPECT_FALSE(std::filesystem::exists(dir_->File("failed_minimizer/t1.obj")));
  EXPECT_FALSE(std::filesystem::exists(dir_->File("failed_minimizer/t2.obj")));
}

// Independent frames go on past a frame that cannot be fitted (here a scan shifted
// beyond every start's reach): its row says converged -1 with "nan" figures, it has no
// OBJ, the frames after it are fitted (as they are alone), and the run ends
// kNotConverged, counting it. A rerun takes the failed frame as done; a warm-started run
// in the folder fits it again.
TEST_F(FitSequenceTest, IndependentFramesGoOnPastAFrameThatCannotBeFitted) {
  const Eigen::Matrix3Xd& neutral = model_->neutral.vertices;
  const double size = (neutral.rowwise().maxCoeff() - neutral.rowwise().minCoeff()).norm();
  std::string error;
  std::vector<std::string> scans;
  for (int t = 0; t < 3; ++t) {
    SurfaceMesh target;
    ASSERT_TRUE(ReadObj(Target(t), &target, &error)) << error;
    SurfaceMesh scan;  // every other vertex, as a point cloud
    scan.vertices.resize(3, (target.vertices.cols() + 1) / 2);
    for (Eigen::Index i = 0; i < scan.vertices.cols(); ++i) {
      scan.vertices.col(i) = target.vertices.col(2 * i);
    }
    if (t == 1) {  // half the model's size across its thinnest extent
      Eigen::Index thin = 0;
      (neutral.rowwise().maxCoeff() - neutral.rowwise().minCoeff()).minCoeff(&thin);
      scan.vertices.row(thin).array() += 0.5 * size;
    }
    scans.push_back(dir_->File("s" + std::to_string(t) + ".obj"));
    ASSERT_TRUE(WriteObj(scans.back(), scan, &error)) << error;
  }
  auto run = [&](const std::vector<int>& order, const std::string& out, bool warm_start) {
    FitSequenceOptions options = Options();
    options.target_kind = "points";
    options.points.max_distance = 0.05 * size;
    for (int t : order) options.sequence += scans[t] + ",";
    options.output_dir = dir_->File(out);
    options.warm_start = warm_start;
    std::ostringstream log;
    FitSequenceResult result = RunFitSequence(options, *model_, log);
    std::printf("%s", log.str().c_str());
    return result;
  };
  // An earlier run's OBJ of the frame that cannot be fitted (its frames.csv deleted to
  // start over): removed, as the failed row says there is none.
  std::filesystem::create_directories(dir_->File("gaps"));
  std::ofstream(dir_->File("gaps/s1.obj")) << "v 0 0 0\n";
  const FitSequenceResult result = run({0, 1, 2}, "gaps", false);
  EXPECT_EQ(result.status, JobStatus::kNotConverged);
  EXPECT_EQ(result.frames_fitted, 3);
  EXPECT_EQ(result.frames_failed, 1);
  EXPECT_NE(result.message.find("1 of 3 frames could not be fitted (the first in this run: " +
                                scans[1] + ": no start"),
            std::string::npos)
      << result.message;
  EXPECT_TRUE(std::filesystem::exists(dir_->File("gaps/s0.obj")));
  EXPECT_FALSE(std::filesystem::exists(dir_->File("gaps/s1.obj")));
  EXPECT_TRUE(std::filesystem::exists(dir_->File("gaps/s2.obj")));
  const auto rows = Rows(dir_->File("gaps/frames.csv"));
  ASSERT_EQ(rows.count("s1"), 1u);
  const std::vector<std::string>& failed = rows.at("s1");
  EXPECT_EQ(failed[11], "-1");
  EXPECT_EQ(failed[12], "none");
  for (size_t c : {5u, 6u, 7u, 8u, 14u}) EXPECT_EQ(failed[c], "nan") << c;
  const FitSequenceResult alone_result = run({0, 2}, "gaps_alone", false);
  EXPECT_EQ(alone_result.status, JobStatus::kOk) << alone_result.message;
  const auto alone = Rows(dir_->File("gaps_alone/frames.csv"));
  EXPECT_EQ(rows.at("s0"), alone.at("s0"));
  EXPECT_EQ(rows.at("s2"), alone.at("s2"));
  Eigen::MatrixXd track;
  ASSERT_TRUE(ReadMatrixFile(dir_->File("gaps/latents.bin"), 2, 3, &track, &error)) << error;
  EXPECT_TRUE(track.col(1).array().isNaN().all());
  EXPECT_TRUE(track.col(2).allFinite());

  const FitSequenceResult again = run({0, 1, 2}, "gaps", false);
  EXPECT_EQ(again.status, JobStatus::kNotConverged);
  EXPECT_EQ(again.frames_resumed, 3);
  EXPECT_EQ(again.frames_fitted, 0);
  EXPECT_NE(again.message.find("1 of 3 frames could not be fitted (in an earlier run)"),
            std::string::npos)
      << again.message;

  const FitSequenceResult warm = run({0, 1, 2}, "gaps", true);
  EXPECT_EQ(warm.frames_resumed, 1);
  EXPECT_EQ(warm.status, JobStatus::kNotConverged);
  // From s0's result no scan point is near either: that fit fails too (it used to end
  // "converged" where it started, with 0 points and error 0).
  EXPECT_NE(warm.message.find(scans[1] + ": fewer than 3 of the scan's"), std::string::npos)
      << warm.message;

  // Scan fits measure to the neutral's faces, which the model's fingerprint leaves out:
  // frames fitted against other faces are not taken (the key holds the faces).
  const Eigen::Matrix3Xi faces = model_->neutral.triangles;
  model_->neutral.triangles.row(1).swap(model_->neutral.triangles.row(2));  // turned inside out
  const FitSequenceResult other_faces = run({0, 2}, "gaps_alone", false);
  model_->neutral.triangles = faces;
  EXPECT_EQ(other_faces.status, JobStatus::kBadInput);
  EXPECT_NE(other_faces.message.find("fitted with another model or other fit options"),
            std::string::npos)
      << other_faces.message;
}

}  // namespace
}  // namespace aqs
