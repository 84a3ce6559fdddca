// Issue 12 ("Nothing lost, nothing silent"): every app refuses bad flags and bad input
// with exit status 1 and a message naming the flag or the file, never an abort, a hang,
// unbounded work or a silent wrong result; outputs in missing folders are refused
// before the work; exit status 2 still writes the outputs.
//
// The model-based cases use a small model made from the finger example (the rest and
// two actuated surfaces, prepared, pre-trained and trained by aqs_pipeline in about a
// second).

#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "testing/run_command.h"
#include "testing/source_data.h"
#include "mesh/mesh_io.h"
#include "testing/temp_dir.h"

namespace aqs {
namespace {

using testing::AppPath;
using testing::DataPath;
using testing::RunCommand;

namespace fs = std::filesystem;

// A bad-input case: flags (with {dir} and {finger} replaced), the exit status and a part
// of the message.
struct Case {
  std::string flags;
  int exit_code;
  std::string message;
};

std::string Replaced(std::string text, const std::string& dir) {
  const std::vector<std::pair<std::string, std::string>> keys = {
      {"{dir}", dir + "/"}, {"{finger}", DataPath("examples/finger/")}};
  for (const auto& [key, value] : keys) {
    for (size_t pos; (pos = text.find(key)) != std::string::npos;) text.replace(pos, key.size(), value);
  }
  return text;
}

// Runs `app` on each case (under a 60 s timeout: a hang fails the test instead of
// blocking it) and checks the exit status, the message and that nothing crashed.
void ExpectCases(const std::string& app, const std::string& common, const std::vector<Case>& cases,
                 const std::string& dir) {
  for (const Case& c : cases) {
    const std::string command =
        "timeout 60 " + AppPath(app) + " " + Replaced(common + " " + c.flags, dir);
    const testing::CommandResult run = RunCommand(command);
    EXPECT_EQ(run.exit_code, c.exit_code) << command << "\n" << run.output;
    EXPECT_NE(run.output.find(Replaced(c.message, dir)), std::string::npos)
        << command << "\n" << run.output;
    EXPECT_EQ(run.output.find("Check failed"), std::string::npos) << command << "\n" << run.output;
    EXPECT_EQ(run.output.find("terminate called"), std::string::npos) << command;
  }
}

std::string ReadAll(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// ---------------------------------------------------------------------------------
// Flags gflags itself refuses (unknown, ill-typed, out of the type's range, missing
// value): exit 1 with gflags' message naming the flag, in every app, before any work.

TEST(AqsValidationTest, EveryAppRefusesUnknownAndIllTypedFlags) {
  const std::vector<std::string> apps = {
      "aqs_simulate", "aqs_prepare",  "aqs_pretrain", "aqs_train",       "aqs_pipeline",
      "aqs_evaluate", "aqs_fit",      "aqs_collide",  "aqs_bench",       "aqs_bench_solve",
      "aqs_bench_train", "aqs_bench_fit", "aqs_bench_mpi"};
  const std::vector<Case> cases = {
      {"--no_such_flag=1", 1, "ERROR: unknown command line flag 'no_such_flag'"},
      {"--threads=abc", 1, "ERROR: illegal value 'abc' specified for int32 flag 'threads'"},
      {"--threads=9999999999", 1,
       "ERROR: illegal value '9999999999' specified for int32 flag 'threads'"},
      {"--threads=1.5", 1, "ERROR: illegal value '1.5' specified for int32 flag 'threads'"},
      {"--max_memory_gb=", 1, "ERROR: illegal value '' specified for double flag 'max_memory_gb'"},
      {"--max_memory_gb=1e400", 1,
       "ERROR: illegal value '1e400' specified for double flag 'max_memory_gb'"},
      {"--threads", 1, "ERROR: flag '--threads' is missing its argument"},
  };
  for (const std::string& app : apps) ExpectCases(app, "", cases, "");
}

// ---------------------------------------------------------------------------------
// aqs_simulate on meshes (no model).

TEST(AqsValidationTest, FlagfilesRefuseNamesNoAppHas) {
  // gflags passes over unknown names in a flagfile: a misspelt flag kept its default.
  // Another stage's flag is fine (the stages share a flagfile).
  testing::TempDir dir;
  dir.Write("typo.flags", "# a config\n--latent_dimm=3\n");
  dir.Write("shared.flags", "--neutral=n.obj\n--nomirror_poses\n--flagfile={dir}typo.flags\n");
  const std::string shared = Replaced(ReadAll(dir.File("shared.flags")), dir.path());
  dir.Write("shared.flags", shared);
  dir.Write("other.flags", "--neutral=n.obj\n--nomirror_poses\n");
  // A typo in a file that includes another (gflags remembers only the last file it
  // read), and line forms gflags drops in a flagfile, keeping the default: "--name
  // value", a non-bool flag without a value, a line that is not a flag (gflags reads it
  // as a filter and skips every later flag), a comment after a value (part of it).
  dir.Write("outer.flags", "--latent_dimm=3\n--flagfile={dir}other.flags\n");
  dir.Write("outer.flags", Replaced(ReadAll(dir.File("outer.flags")), dir.path()));
  dir.Write("space.flags", "--train_minutes 120\n");
  dir.Write("bare.flags", "--train_minutes\n");
  dir.Write("filter.flags", "threads=1\n--train_minutes=1\n");
  dir.Write("comment.flags", "--neutral=n.obj  # the rest face\n");
  // A flagfile that includes itself, directly or through another (gflags recursed until
  // its stack overflowed: a crash), a line of dashes only (an uncaught exception), and
  // --noNAME for a flag that is not a bool (gflags drops it in a flagfile).
  dir.Write("self.flags", Replaced("--threads=1\n--flagfile={dir}self.flags\n", dir.path()));
  dir.Write("ping.flags", Replaced("--flagfile={dir}pong.flags\n", dir.path()));
  dir.Write("pong.flags", Replaced("--threads=1\n--flagfile={dir}ping.flags\n", dir.path()));
  dir.Write("dashes.flags", "--\n");
  dir.Write("nothreads.flags", "--nothreads\n");
  ExpectCases("aqs_train", "--model={dir}missing",
              {
                  {"--flagfile={dir}self.flags", 1,
                   "--flagfile: {dir}self.flags includes itself ("},
                  {"--flagfile={dir}ping.flags", 1,
                   "--flagfile: {dir}ping.flags includes itself ("},
                  {"--flagfile={dir}dashes.flags", 1,
                   "{dir}dashes.flags:1: '--' is not a flag"},
                  {"--flagfile={dir}nothreads.flags", 1,
                   "{dir}nothreads.flags:1: --nothreads: --threads is not a bool flag"},
                  {"--flagfile={dir}typo.flags", 1,
                   "{dir}typo.flags:2: unknown flag --latent_dimm (no ActiveQS app has it)"},
                  {"--flagfile={dir}shared.flags", 1, "{dir}typo.flags:2: unknown flag"},
                  {"--flagfile={dir}other.flags", 1, "{dir}missing/model.txt"},
                  {"--flagfile={dir}outer.flags", 1, "{dir}outer.flags:1: unknown flag"},
                  {"--flagfile={dir}other.flags --flagfile={dir}typo.flags", 1,
                   "{dir}typo.flags:2: unknown flag"},
                  {"--flagfile={dir}typo.flags --flagfile={dir}other.flags", 1,
                   "{dir}typo.flags:2: unknown flag"},
                  {"--flagfile={dir}space.flags", 1,
                   "{dir}space.flags:1: --train_minutes: write --train_minutes=value"},
                  {"--flagfile={dir}bare.flags", 1,
                   "{dir}bare.flags:1: --train_minutes needs a value (--train_minutes=value)"},
                  {"--flagfile={dir}filter.flags", 1,
                   "{dir}filter.flags:1: 'threads=1' is not a flag"},
                  {"--flagfile={dir}comment.flags", 1,
                   "{dir}comment.flags:1: --neutral: a '#' comment after a value"},
              },
              dir.path());
}

TEST(AqsValidationTest, BenchmarksRefuseBadSizesBeforeAnyMeasurement) {
  testing::TempDir dir;
  ExpectCases("aqs_bench", "",
              {
                  {"--cubes=3,2000", 1,
                   "--cubes: a lattice of 2000 x 2000 x 2000 cubes is too large"},
                  {"--cubes=3,300", 1, "--max_memory_gb (8 GB) is below the estimated"},
                  {"--cubes=3 --amplitude=nan", 1, "--amplitude must be in (-1, 1) (is nan)"},
                  {"--cubes=3 --amplitude=5", 1, "--amplitude must be in (-1, 1) (is 5)"},
                  // Read whole: "12x" was 12.
                  {"--cubes=12x", 1, "--cubes takes positive integers, got '12x'"},
                  {"--cubes=3 --csv={dir}missing/b.csv", 1,
                   "--csv: {dir}missing/b.csv: cannot write here"},
                  // Solver flags the benchmark would ignore (they were accepted, even bad).
                  {"--cubes=3 --solver=foo", 1, "--solver does not apply here"},
                  {"--cubes=3 --newton_stall_steps=-7", 1, "--newton_stall_steps does not apply"},
              },
              dir.path());
  // Flags, before the model and the test set are read.
  ExpectCases("aqs_bench_fit", "--model={dir}m --output_dir={dir}out",
              {
                  {"--test_set={dir}set --marker_counts=20.5", 1,
                   "--marker_counts: '20.5' is not a whole number"},
                  {"--test_set={dir}set --marker_counts=20,20", 1, "20 is given twice"},
                  {"--test_set={dir}set --parts=,", 1, "--parts: no part given"},
                  {"--test_set={dir}set --marker_counts=, --parts=markers", 1,
                   "--marker_counts must list a count for the markers part"},
                  {"--test_set={dir}set --parts=markers --temporal_prior=0.1", 1,
                   "--temporal_prior applies to the sequence part (--parts=...,sequence)"},
              },
              dir.path());
  ExpectCases("aqs_bench_solve", "",
              {
                  {"--lattice=2000,2000,2000", 1, "is too large"},
                  {"--lattice=40x,4,4", 1, "--lattice must be three positive cube counts"},
                  {"--lattice=4,4,4 --spacing=nan", 1, "the lattice's spacing must be finite"},
                  {"--lattice=4,4,4 --spacing=-1", 1, "the lattice's spacing must be finite"},
                  {"--lattice=2,1,1 --spacing=1e-300", 1, "is beyond what doubles can hold"},
                  {"--lattice=2,1,1 --spacing=1e200", 1, "is beyond what doubles can hold"},
                  {"--lattice=4,4,4 --curl=5", 1, "--curl must be in [0, 1)"},
                  {"--lattice=4,4,4 --csv={dir}missing/b.csv", 1, "cannot write here"},
                  {"--lattice=4,4,4 --solver=lm", 1, "--solver does not apply here"},
                  {"--lattice=4,4,4 --springs", 1,
                   "--springs and --attachment_stiffness describe solves of --poses"},
                  {"--lattice=4,4,4 --attachment_stiffness=5", 1,
                   "--springs and --attachment_stiffness describe solves of --poses"},
              },
              dir.path());
}

TEST(AqsValidationTest, SimulateRefusesBadFlagsAndInputs) {
  testing::TempDir dir;
  const int elements = 7838;  // the finger
  std::string inverted, tiny;
  for (int e = 0; e < elements; ++e) {
    inverted += "-1 -1 -1 0 0 0\n";
    tiny += "1e-12 1e-12 1e-12 0 0 0\n";
  }
  dir.Write("inverted.txt", inverted);
  dir.Write("tiny.txt", tiny);
  ASSERT_EQ(::mkfifo(dir.File("fifo.msh").c_str(), 0600), 0);
  ASSERT_EQ(::symlink("/dev/zero", dir.File("zero.msh").c_str()), 0);
  dir.Write("oneline.mesh", std::string(3 << 20, '1'));
  dir.Write("hex.node", "4 3 0 0\n1 0 0 0\n2 0x1 0 0\n3 0 1 0\n4 0 0 1\n");
  dir.Write("hex.ele", "1 4 0\n1 1 2 3 4\n");
  const std::string finger = "--mesh={finger}finger.msh --fixed={finger}fixed.txt";
  ExpectCases("aqs_simulate", "",
              {
                  {finger + " --mu=inf --output={dir}x.mesh", 1, "--mu must be finite and > 0 (is inf)"},
                  {finger + " --threads=0 --output={dir}x.mesh", 1, "--threads must be in [1, 1024]"},
                  {finger + " --newton_stall_steps=-1 --output={dir}x.mesh", 1,
                   "--newton_stall_steps must be >= 0 (is -1)"},
                  {finger + " --tolerance=inf --output={dir}x.mesh", 1,
                   "--tolerance must be finite and > 0 (is inf)"},
                  {finger + " --newton_relative_force=nan --output={dir}x.mesh", 1,
                   "--newton_relative_force must be finite and >= 0 (is nan)"},
                  {finger + " --max_iterations=0 --output={dir}x.mesh", 1, "--max_iterations must be >= 1"},
                  {finger + " --mu=1e308 --output={dir}x.mesh", 1,
                   "the force scale 2 mean(mu V^(2/3)) of the mesh is inf"},
                  {finger + " --tolerance=1e-17 --output={dir}x.mesh", 1,
                   "--tolerance must be >= 1e-13 (is 1e-17)"},
                  // A solve that would stop where it starts ("converged", no iterations).
                  {finger + " --tolerance=1e300 --output={dir}x.mesh", 1,
                   "--tolerance must be at most 0.1 (is 1e+300)"},
                  // A mesh larger than the memory limit allows (it went straight to the
                  // factorization: bad_alloc or the OOM killer).
                  {finger + " --max_memory_gb=0.01 --output={dir}x.mesh", 1,
                   "--max_memory_gb (10 MB) is below the estimated"},
                  {finger + " --actuation={dir}inverted.txt --output={dir}x.mesh", 1,
                   "inverted.txt:1: 7838 of 7838 actuations are not positive definite"},
                  {finger + " --actuation={dir}tiny.txt --output={dir}x.mesh", 1,
                   "has eigenvalues 1e-12, 1e-12, 1e-12"},
                  {finger + " --output={dir}x.mesh,{dir}missing/x.vtu", 1,
                   "{dir}missing/x.vtu: cannot write here: the folder {dir}missing does not exist"},
                  {"--mesh={dir}fifo.msh --output={dir}x.mesh", 1,
                   "fifo.msh: is a FIFO (named pipe), not a regular file"},
                  {"--mesh={dir}zero.msh --output={dir}x.mesh", 1,
                   "zero.msh: is a character device, not a regular file"},
                  {"--mesh={dir}oneline.mesh --output={dir}x.mesh", 1,
                   "oneline.mesh:1: the line is longer than 1048576 bytes"},
                  {"--mesh={dir}hex.node --output={dir}x.mesh", 1,
                   "hex.node:3: expected the x coordinate (a finite number) as entry 2, got '0x1'"},
              },
              dir.path());
  // Refused before the work: not even the first output was written.
  EXPECT_FALSE(fs::exists(dir.File("x.mesh")));
}

// ---------------------------------------------------------------------------------
// The apps on a small trained model.

class AqsValidationModelTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir;
    const std::string finger = DataPath("examples/finger/");
    const std::string simulate = AppPath("aqs_simulate") + " --mesh=" + finger +
                                 "finger.msh --fixed=" + finger + "fixed.txt --threads=1";
    fs::create_directories(dir_->File("poses"));
    for (const std::string& command :
         {simulate + " --output=" + dir_->File("neutral.obj"),
          simulate + " --actuation=" + finger + "actuation.txt --output=" + dir_->File("poses/bend_x.obj"),
          simulate + " --actuation=" + finger + "actuation_y.txt --output=" + dir_->File("poses/bend_y.obj"),
          AppPath("aqs_pipeline") + " --neutral=" + dir_->File("neutral.obj") + " --poses=" +
              dir_->File("poses") + " --model=" + dir_->File("model") +
              " --spacing=0.5 --lattice=kuhn --fixed_box=-2,-2,-1,2,2,0.3 --latent_dim=2 "
              "--hidden=8 --grid_spacing=1.5 --pretrain_iterations=30 --train_iterations=2 "
              "--stages=prepare,pretrain,train --threads=1"}) {
      const testing::CommandResult run = RunCommand(command);
      ASSERT_EQ(run.exit_code, 0) << command << "\n" << run.output;
    }
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }

  // A fresh copy of the model (for cases that damage or rewrite it).
  static std::string CopyOfModel(const testing::TempDir& dir, const std::string& name) {
    const std::string path = dir.File(name);
    fs::copy(dir_->File("model"), path, fs::copy_options::recursive);
    return path;
  }

  static testing::TempDir* dir_;
};

testing::TempDir* AqsValidationModelTest::dir_ = nullptr;

// The standalone apps rerun as the pipeline's stages do (a kill campaign found that a
// rerun of a prepare, pretrain, train script deleted the training): aqs_prepare and
// aqs_pretrain with the model's own inputs and flags keep it with its learned state;
// with others, they refuse to discard it; --restart replaces it.
TEST_F(AqsValidationModelTest, RerunsOfPrepareAndPretrainKeepOrRefuseNotDiscardTraining) {
  testing::TempDir dir;
  const std::string model = CopyOfModel(dir, "m");
  const std::string checkpoint = ReadAll(model + "/learned/checkpoint.txt");
  ASSERT_NE(checkpoint.find("\niterations 2\n"), std::string::npos) << checkpoint;
  const std::string prepare = AppPath("aqs_prepare") + " --neutral=" + dir_->File("neutral.obj") +
                              " --poses=" + dir_->File("poses") + " --model=" + model +
                              " --spacing=0.5 --lattice=kuhn --fixed_box=-2,-2,-1,2,2,0.3 "
                              "--threads=1";
  testing::CommandResult run = RunCommand(prepare);
  EXPECT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("is the model of these inputs and flags"), std::string::npos)
      << run.output;
  const std::string pretrain = AppPath("aqs_pretrain") + " --model=" + model +
                               " --latent_dim=2 --hidden=8 --grid_spacing=1.5 "
                               "--pretrain_iterations=30 --threads=1";
  run = RunCommand(pretrain);
  EXPECT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("kept, with 2 training iterations since"), std::string::npos)
      << run.output;
  EXPECT_EQ(ReadAll(model + "/learned/checkpoint.txt"), checkpoint);
  // Other flags: refused, the training kept.
  run = RunCommand(prepare + " --spacing=0.6");
  EXPECT_EQ(run.exit_code, 1) << run.output;
  EXPECT_NE(run.output.find("would discard its learned state"), std::string::npos) << run.output;
  run = RunCommand(pretrain + " --hidden=9");
  EXPECT_EQ(run.exit_code, 1) << run.output;
  EXPECT_NE(run.output.find("which pre-training anew would discard"), std::string::npos)
      << run.output;
  EXPECT_EQ(ReadAll(model + "/learned/checkpoint.txt"), checkpoint);
  // --restart asks for it, and the log says what it discards.
  run = RunCommand(pretrain + " --hidden=9 --restart");
  EXPECT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("pretrain: --restart: the model's decoder and latents (2 training "
                            "iterations) are replaced by a new pre-training"),
            std::string::npos)
      << run.output;
  EXPECT_FALSE(fs::exists(model + "/train"));
  run = RunCommand(prepare + " --spacing=0.6 --restart");
  EXPECT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("prepare: --restart: the model at " + model +
                            " is replaced, with its learned state (pre-trained, 0 training "
                            "iterations), once its targets are made"),
            std::string::npos)
      << run.output;
  EXPECT_FALSE(fs::exists(model + "/learned"));
}

TEST_F(AqsValidationModelTest, DamagedModelsAreRefusedNamingTheFile) {
  testing::TempDir dir;
  const std::string empty_fixed = CopyOfModel(dir, "empty_fixed");
  std::ofstream(empty_fixed + "/fixed.txt") << "";
  const std::string dir_fixed = CopyOfModel(dir, "dir_fixed");
  fs::remove(dir_fixed + "/fixed.txt");
  fs::create_directories(dir_fixed + "/fixed.txt");
  const std::string nan_latents = CopyOfModel(dir, "nan_latents");
  {
    std::fstream out(nan_latents + "/learned/latents.bin", std::ios::in | std::ios::out | std::ios::binary);
    out.seekp(24);
    const double nan = std::nan("");
    out.write(reinterpret_cast<const char*>(&nan), sizeof(nan));
  }
  // A pose surface far away, a decoder parameter of 1e154, one element 1e15 times stiffer,
  // a weight that is not barycentric.
  auto write_double = [](const std::string& path, long offset, double value) {
    std::fstream out(path, std::ios::in | std::ios::out | std::ios::binary);
    out.seekp(offset);
    out.write(reinterpret_cast<const char*>(&value), sizeof(value));
  };
  write_double(CopyOfModel(dir, "far_pose") + "/poses/0000.bin", 24 + 8 * 30, 1e300);
  write_double(CopyOfModel(dir, "stiff") + "/mu.bin", 24 + 8 * 5, 1e15);
  {
    const std::string decoder = CopyOfModel(dir, "huge_decoder") + "/learned/decoder.txt";
    std::string text = ReadAll(decoder);
    const size_t at = text.rfind('\n', text.size() - 2);  // the last parameter's line
    text = text.substr(0, at + 1) + "1e154\n";
    std::ofstream(decoder) << text;
    const std::string embedding = CopyOfModel(dir, "bad_weight") + "/embedding.txt";
    std::string lines = ReadAll(embedding);
    const size_t first = lines.find('\n') + 1;  // after the comment line
    const size_t space = lines.find(' ', first);
    lines.replace(space, lines.find(' ', space + 1) - space, " 2147483648");
    std::ofstream(embedding) << lines;
    // A prior centred far outside the training latents (every fit starts there).
    const std::string prior = CopyOfModel(dir, "far_prior") + "/learned/prior.txt";
    std::string prior_text = ReadAll(prior);
    const size_t mean = prior_text.find("latent_mean ");
    ASSERT_NE(mean, std::string::npos) << prior_text;
    prior_text.replace(mean, prior_text.find('\n', mean) - mean, "latent_mean 1e6 1e6");
    std::ofstream(prior) << prior_text;
    // A centre that is no training pose.
    const std::string centre = CopyOfModel(dir, "bad_centre") + "/learned/prior.txt";
    std::string centre_text = ReadAll(centre);
    const size_t centre_at = centre_text.find("center ");
    ASSERT_NE(centre_at, std::string::npos) << centre_text;
    centre_text.replace(centre_at, centre_text.find('\n', centre_at) - centre_at,
                        "center no_such_pose");
    std::ofstream(centre) << centre_text;
  }
  const std::string pose = " --target=" + dir_->File("poses/bend_x.obj") + " --output={dir}f.obj";
  ExpectCases("aqs_fit", "",
              {{"--model={dir}empty_fixed" + pose, 1, "empty_fixed/fixed.txt: lists no fixed vertices"},
               {"--model={dir}dir_fixed" + pose, 1, "dir_fixed/fixed.txt: is a directory"},
               {"--model={dir}nan_latents" + pose, 1,
                "nan_latents/learned/latents.bin: entry (0, 0) of the 2 x 2 matrix is not finite"},
               {"--model={dir}far_pose" + pose, 1, "far_pose/poses/0000.bin: point 10 ("},
               {"--model={dir}stiff" + pose, 1, "stiff/mu.bin: the stiffness ranges from 1 to 1e+15, a contrast above"},
               {"--model={dir}huge_decoder" + pose, 1,
                "huge_decoder/learned/decoder.txt: the decoder maps training pose 'bend_x' to "
                "actuations with entries up to"},
               {"--model={dir}bad_weight" + pose, 1,
                "bad_weight/embedding.txt: surface vertex 0: the weights must be barycentric"},
               {"--model={dir}bad_centre" + pose, 1,
                "bad_centre/learned/prior.txt: the priors are centred on 'no_such_pose'"},
               {"--model={dir}far_prior" + pose, 1,
                "far_prior/learned/prior.txt: the latent mean decodes to actuations with entries "
                "up to"}},
              dir.path());
  ExpectCases("aqs_simulate", "--pose=bend_x --output={dir}s.obj",
              {{"--model={dir}empty_fixed", 1, "empty_fixed/fixed.txt: lists no fixed vertices"}},
              dir.path());
  // A learned state without its decoder loaded as an untrained model, and the library's
  // next call aborted (the embedder's review).
  fs::remove(CopyOfModel(dir, "no_decoder") + "/learned/decoder.txt");
  ExpectCases("aqs_train", "--train_iterations=3",
              {{"--model={dir}nan_latents", 1, "nan_latents/learned/latents.bin: entry (0, 0)"},
               {"--model={dir}no_decoder", 1,
                "no_decoder/learned/decoder.txt: missing, but {dir}no_decoder/learned/latents.bin "
                "is there: the learned state is damaged"}},
              dir.path());
  EXPECT_FALSE(fs::exists(dir.File("f.obj")));
  EXPECT_FALSE(fs::exists(dir.File("s.obj")));
}

TEST_F(AqsValidationModelTest, FitRefusesBadFlagsTargetsAndOutputs) {
  testing::TempDir dir;
  const std::string pose_path = dir_->File("poses/bend_x.obj");
  SurfaceMesh pose;
  std::string error;
  ASSERT_TRUE(ReadObj(pose_path, &pose, &error)) << error;
  // Coordinates of about 1e154: their squares overflow.
  SurfaceMesh huge = pose;
  huge.vertices.row(0) *= 1e154;
  ASSERT_TRUE(WriteObj(dir.File("huge.obj"), huge, &error)) << error;
  // One vertex too many (the last one repeated; the faces are the neutral's).
  SurfaceMesh extra = pose;
  extra.vertices.conservativeResize(3, pose.num_vertices() + 1);
  extra.vertices.col(pose.num_vertices()) = pose.vertices.col(0);
  ASSERT_TRUE(WriteObj(dir.File("extra.obj"), extra, &error)) << error;
  // One vertex too few: the last one dropped, with the faces that use it.
  {
    std::istringstream in(ReadAll(pose_path));
    const std::string last = std::to_string(pose.num_vertices());
    std::string text, line;
    int vertices = 0;
    while (std::getline(in, line)) {
      if (line.rfind("v ", 0) == 0 && ++vertices == pose.num_vertices()) continue;
      if (line.rfind("f ", 0) == 0) {
        std::istringstream face(line.substr(2));
        bool uses_last = false;
        for (std::string corner; face >> corner;) {
          uses_last |= corner.substr(0, corner.find('/')) == last;
        }
        if (uses_last) continue;
      }
      text += line + "\n";
    }
    dir.Write("fewer.obj", text);
  }
  // The same without faces (the test sets' pose format): still a pose, not a scan.
  {
    std::string text;
    std::istringstream in(ReadAll(dir.File("fewer.obj")));
    for (std::string line; std::getline(in, line);) {
      if (line.rfind("f ", 0) != 0) text += line + "\n";
    }
    dir.Write("fewer_points.obj", text);
  }
  // A scan whose PLY header counts fewer points than it holds.
  std::string ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                    "property float z\nend_header\n0 0 1\n0 0 2\n0 0 3\n0 0 4\n";
  dir.Write("extra.ply", ply);
  const std::string common = "--model=" + dir_->File("model") + " --output={dir}f.obj";
  const std::string target = " --target=" + pose_path;
  ExpectCases("aqs_fit", common,
              {
                  {target + " --fit_regularization=nan", 1, "--fit_regularization must be in [0, 1e+06] (is nan)"},
                  {target + " --fit_regularization=-1", 1, "--fit_regularization must be in [0, 1e+06] (is -1)"},
                  {target + " --max_distance=-1", 1, "--max_distance must be >= 0"},
                  {target + " --max_distance=nan", 1, "--max_distance must be >= 0"},
                  {target + " --rounds=0", 1, "--rounds must be in [1, 10000] (is 0)"},
                  {target + " --temporal_prior=0.1", 1,
                   "--temporal_prior pulls a sequence's frame toward the one before it: it "
                   "applies to a --sequence, not to one --target"},
                  {target + " --rounds=-1", 1, "--rounds must be in [1, 10000] (is -1)"},
                  {target + " --fit_coarse_points=-1", 1, "--fit_coarse_points must be in [0, 100000000] (is -1)"},
                  {target + " --fit_tolerance=0", 1, "--fit_tolerance must be finite and > 0 (is 0)"},
                  {target + " --fit_tolerance=nan", 1, "--fit_tolerance must be finite and > 0 (is nan)"},
                  {target + " --threads=0", 1, "--threads must be in [1, 1024] (is 0)"},
                  {target + " --newton_stall_steps=-3", 1,
                   "--newton_stall_steps must be >= 0 (is -3)"},
                  {target + " --fit_tolerance=1", 1, "--fit_tolerance must be at most 0.1 (is 1)"},
                  // Below one point the cap multiplied the priors (1e-300: Ceres failed).
                  {target + " --prior_points_cap=1e-300", 1,
                   "--prior_points_cap must be <= 0 (no cap) or >= 1 point (is 1e-300)"},
                  {target + " --landmark_weight=1e300", 1,
                   "--landmark_weight must be in [0, 1e+06]"},
                  {target + " --max_memory_gb=nan", 1,
                   "--max_memory_gb must be finite and > 0 (is nan)"},
                  {target + " --compare_to=" + pose_path + " --compare_vertices=0:99999", 1,
                   "--compare_vertices: comparison vertex 1098 is outside"},
                  {target + " --target_kind=scan", 1, "--target_kind must be auto, pose, markers or points"},
                  {target + " --latent_output={dir}missing/z.txt", 1,
                   "{dir}missing/z.txt: cannot write here: the folder {dir}missing does not exist"},
                  {" --target={dir}huge.obj", 1,
                   "huge.obj: point 0 (2.774e+154 -0.003239 4.143) is 2.774e+154 from the model, more than 1000 times"},
                  {" --target={dir}extra.obj", 1,
                   "extra.obj: a surface with 1099 vertices, but the model's surface has 1098"},
                  {" --target={dir}extra.obj", 1, "pass --target_kind=points"},
                  {" --target={dir}fewer.obj", 1,
                   "fewer.obj: a surface with 1097 vertices, but the model's surface has 1098"},
                  {" --target={dir}fewer_points.obj", 1,
                   "fewer_points.obj: a surface with 1097 vertices, but the model's surface has"},
                  {" --target={dir}extra.ply", 1, "extra.ply:11: data after the last of the header's elements"},
              },
              dir.path());
  // Refused before the work: the surface was not written either.
  EXPECT_FALSE(fs::exists(dir.File("f.obj")));
  // As a point cloud, on request, the surface with a vertex too many is fitted.
  ExpectCases("aqs_fit", common, {{" --target={dir}extra.obj --target_kind=points", 0, "wrote "}},
              dir.path());
  EXPECT_TRUE(fs::exists(dir.File("f.obj")));
  // A pose with the second start: the log says whether it was kept.
  ExpectCases("aqs_fit", common,
              {{target + " --fit_coarse_points=3", 0, "second start through 3 of the points: "}},
              dir.path());
}

TEST_F(AqsValidationModelTest, OutputsLeaveTheInputsAndTheModelAlone) {
  // An output that is an input file, or inside the model directory, is refused before
  // any work: it would overwrite the target, or leave the model unloadable.
  testing::TempDir dir;
  const std::string model = CopyOfModel(dir, "model");
  fs::copy_file(dir_->File("poses/bend_x.obj"), dir.File("t.obj"));
  const std::string target_before = ReadAll(dir.File("t.obj"));
  const std::string neutral_before = ReadAll(model + "/neutral.obj");
  fs::create_directories(dir.File("seq"));
  fs::copy_file(dir_->File("poses/bend_x.obj"), dir.File("seq/a.obj"));
  // A frame whose name holds a comma would break frames.csv's columns (and its resume).
  fs::create_directories(dir.File("comma"));
  fs::copy_file(dir_->File("poses/bend_x.obj"), dir.File("comma/a,b.obj"));
  const std::string m = "--model=" + model;
  ExpectCases("aqs_fit", m,
              {
                  {"--target={dir}t.obj --output={dir}t.obj", 1,
                   "{dir}t.obj: is the input file {dir}t.obj itself"},
                  {"--target={dir}t.obj --output={dir}./t.obj", 1, "is the input file"},
                  {"--target={dir}t.obj --output=" + model + "/neutral.obj", 1,
                   "is inside the input folder " + model},
                  {"--target={dir}t.obj --output={dir}f.obj --latent_output=" + model + "/z.txt", 1,
                   "is inside the input folder"},
                  // Two outputs at one path: the latent file replaced the surface.
                  {"--target={dir}t.obj --output={dir}f.obj --latent_output={dir}f.obj", 1,
                   "{dir}f.obj: given for two outputs"},
                  {"--target={dir}t.obj --output={dir}f.obj --output_volume={dir}./f.obj", 1,
                   "{dir}./f.obj: given for two outputs"},
                  {"--sequence={dir}seq --output_dir={dir}seq", 1, "is the folder of the frame"},
                  {"--sequence={dir}seq --output_dir=" + model + "/fits", 1,
                   "is inside the input folder"},
                  {"--sequence={dir}comma --output_dir={dir}out", 1,
                   "a,b.obj: the frame name (the file's name) 'a,b' contains ','"},
              },
              dir.path());
  ExpectCases("aqs_simulate", m + " --pose=bend_x",
              {{"--output=" + model + "/mesh.mesh", 1, "is inside the input folder"},
               {"--output={dir}s.obj,{dir}s.obj", 1, "{dir}s.obj: given for two outputs"}},
              dir.path());
  ExpectCases("aqs_collide", m + " --pose=bend_x",
              {{"--output={dir}c.obj --report=" + model + "/r.txt", 1,
                "is inside the input folder"},
               {"--obstacles={dir}t.obj --output={dir}t.obj", 1, "is the input file"},
               {"--output={dir}c.obj --output_before={dir}c.obj", 1,
                "{dir}c.obj: given for two outputs"}},
              dir.path());
  // Nor may an input lie in a folder the evaluation empties (they were deleted).
  fs::create_directories(dir.File("ev2/fitted"));
  fs::copy_file(dir_->File("poses/bend_x.obj"), dir.File("ev2/fitted/t.obj"));
  fs::create_directories(dir.File("ev3/budget"));
  const std::string kept_model = CopyOfModel(dir, "ev3/budget/model");
  ExpectCases("aqs_evaluate", "",
              {{m + " --output_dir={dir}ev2 --test_poses={dir}ev2/fitted/t.obj", 1,
                "{dir}ev2/fitted/t.obj"},
               {"--model=" + kept_model + " --output_dir={dir}ev3", 1, kept_model}},
              dir.path());
  EXPECT_TRUE(fs::exists(dir.File("ev2/fitted/t.obj")));
  EXPECT_TRUE(fs::exists(kept_model + "/model.txt"));
  ExpectCases("aqs_evaluate", m,
              {{"--output_dir=" + model, 1, "is inside the input folder"},
               // A baseline too large for memory, before any fit (it aborted in training).
               {"--output_dir={dir}ev --baseline_hidden=100000,100000", 1,
                "--baseline_hidden: the auto-encoder baseline would take about"},
               // A linear or untrained auto-encoder would pass for the network baseline.
               {"--output_dir={dir}ev --baseline_hidden=", 1,
                "--baseline_hidden takes positive widths or 'decoder', got '' (no hidden"},
               // An empty item is a typo, as in --hidden (it was dropped).
               {"--output_dir={dir}ev --baseline_hidden=,", 1,
                "--baseline_hidden has an empty width in ','"},
               {"--output_dir={dir}ev --baseline_hidden=64,,64", 1,
                "--baseline_hidden has an empty width in '64,,64'"},
               {"--output_dir={dir}ev --baseline_iterations=0", 1,
                "--baseline_iterations must be >= 1 (is 0)"},
               {"--output_dir={dir}ev --baseline_checkpoint_seconds=nan", 1,
                "--baseline_checkpoint_seconds must be finite and >= 0 (is nan)"}},
              dir.path());
  // Refused before the output folder is touched (the baseline too large for memory was
  // refused after an earlier run's outputs were deleted).
  EXPECT_FALSE(fs::exists(dir.File("ev")));
  // Flags of the other mode are refused, not dropped without a word.
  ExpectCases("aqs_simulate", m + " --pose=bend_x --output={dir}s.obj",
              {{"--gradient={dir}g.txt", 1, "--gradient and --initial do not apply"},
               {"--initial={dir}t.obj", 1, "--gradient and --initial do not apply"}},
              dir.path());
  ExpectCases("aqs_fit", m + " --sequence={dir}seq --output_dir={dir}out",
              {{"--initial_latent={dir}z.txt", 1, "--initial_latent applies to one --target"},
               {"--temporal_prior=-1", 1, "--temporal_prior must be finite and >= 0 (is -1)"},
               {"--temporal_prior=0.1 --sequence_warm_start=false", 1,
                "--temporal_prior pulls a frame toward the previous one: it needs warm-started "
                "frames (--sequence_warm_start)"},
               {"--output_uncertainty={dir}u.ply", 1, "--output_uncertainty applies to one"},
               {"--compare_to={dir}t.obj", 1, "--compare_to applies to one --target"}},
              dir.path());
  EXPECT_FALSE(fs::exists(dir.File("g.txt")));
  EXPECT_FALSE(fs::exists(dir.File("out")));
  EXPECT_EQ(ReadAll(dir.File("t.obj")), target_before);
  EXPECT_EQ(ReadAll(model + "/neutral.obj"), neutral_before);
  EXPECT_FALSE(fs::exists(dir.File("seq/frames.csv")));
  // The model still loads: nothing was written into it.
  ExpectCases("aqs_simulate", m + " --pose=bend_x", {{"--output={dir}s.obj", 0, "wrote "}},
              dir.path());
}

TEST_F(AqsValidationModelTest, TargetsInAnotherUnitAreRefused) {
  // A target in millimetres for a model in centimetres (x 10) is refused before the
  // fit, which ran on for minutes towards it; a scan no start reaches is named as such.
  testing::TempDir dir;
  SurfaceMesh pose;
  std::string error;
  ASSERT_TRUE(ReadObj(dir_->File("poses/bend_x.obj"), &pose, &error)) << error;
  SurfaceMesh scaled = pose;
  scaled.vertices *= 10.0;
  ASSERT_TRUE(WriteObj(dir.File("mm.obj"), scaled, &error)) << error;
  fs::create_directories(dir.File("seq"));
  ASSERT_TRUE(WriteObj(dir.File("seq/f0.obj"), scaled, &error)) << error;
  std::ostringstream markers, ply;
  ply << "ply\nformat ascii 1.0\nelement vertex " << pose.num_vertices()
      << "\nproperty double x\nproperty double y\nproperty double z\nend_header\n";
  for (int v = 0; v < pose.num_vertices(); ++v) {
    const Eigen::Vector3d p = scaled.vertices.col(v);
    if (v % 10 == 0) markers << v << " " << p.x() << " " << p.y() << " " << p.z() << "\n";
    ply << p.x() << " " << p.y() << " " << p.z() << "\n";
  }
  dir.Write("mm.txt", markers.str());
  dir.Write("mm.ply", ply.str());
  SurfaceMesh shifted = pose;
  shifted.vertices.row(2).array() += 0.01;  // no start's surface within 1e-4 of it
  ASSERT_TRUE(WriteObj(dir.File("shifted.obj"), shifted, &error)) << error;
  const std::string unit = "is it in another unit (millimetres for centimetres?) or frame?";
  ExpectCases("aqs_fit", "--model=" + dir_->File("model") + " --output={dir}f.obj",
              {
                  {"--target={dir}mm.obj", 1, "{dir}mm.obj: its points lie a median"},
                  {"--target={dir}mm.obj", 1, unit},
                  {"--target={dir}mm.txt", 1, "{dir}mm.txt: its points lie a median"},
                  {"--target={dir}mm.ply", 1, "from the model's nearest vertices"},
                  {"--target={dir}shifted.obj --target_kind=points --max_distance=1e-4",
                   2, "fewer than 3 of the scan's 1098 points lie within --max_distance"},
                  // Scales that small were legal, and every scan point weighed alike and
                  // next to nothing (the fit stayed at its start) or none was matched.
                  {"--target={dir}shifted.obj --target_kind=points --robust_scale=1e-300", 1,
                   "--robust_scale must be 0 (no robust weights) or at least 1e-06 times the "
                   "model's size ("},
                  {"--target={dir}shifted.obj --target_kind=points --max_distance=1e-300", 1,
                   "--max_distance must be 0 (no cap) or at least 1e-06 times the model's size"},
              },
              dir.path());
  ExpectCases("aqs_fit", "--model=" + dir_->File("model"),
              {{"--sequence={dir}seq --output_dir={dir}out", 1, "f0.obj: its points lie a median"},
               {"--sequence={dir}seq --output_dir={dir}out --robust_scale=1e-300", 1,
                "--robust_scale must be 0 (no robust weights) or at least 1e-06 times"}},
              dir.path());
  EXPECT_FALSE(fs::exists(dir.File("f.obj")));
}

TEST_F(AqsValidationModelTest, ExitTwoStillWritesTheOutputs) {
  testing::TempDir dir;
  // One Ceres iteration from rest cannot reach 1e-12 (--solver=lm): exit 2, and the surface is written.
  ExpectCases("aqs_simulate",
              "--model=" + dir_->File("model") + " --pose=bend_x --from_rest --max_iterations=1 "
              "--tolerance=1e-12 --solver=lm --newton_relative_force=0 --output={dir}s.obj,{dir}s.vtu",
              {{"", 2, "the equilibrium was not reached"}}, dir.path());
  SurfaceMesh surface;
  std::string error;
  ASSERT_TRUE(ReadObj(dir.File("s.obj"), &surface, &error)) << error;
  EXPECT_TRUE(surface.vertices.allFinite());
  EXPECT_NE(ReadAll(dir.File("s.vtu")).find("displacement"), std::string::npos);
}

TEST_F(AqsValidationModelTest, LearningAppsRefuseBadFlags) {
  testing::TempDir dir;
  const std::string model = CopyOfModel(dir, "m");
  const std::string before = ReadAll(model + "/learned/decoder.txt");
  ExpectCases("aqs_pretrain", "--model={dir}m",
              {
                  {"--latent_dim=2147483647", 1,
                   "--latent_dim must be in [1, 4096] (is 2147483647)"},
                  {"--hidden=100000,100000", 1, "--hidden: the decoder would have 1e+10 parameters"},
                  {"--hidden=1000000", 1, "--max_memory_gb (8 GB) is below the estimated"},
                  {"--hidden=1000000", 1, "that pre-training needs"},
                  {"--grid_spacing=1e-9", 1, "--grid_spacing 1e-09 gives the control grid a spacing"},
                  {"--grid_spacing_factor=0", 1, "--grid_spacing_factor must be finite and > 0 (is 0)"},
                  {"--grid_spacing_factor=-1", 1, "--grid_spacing_factor must be finite and > 0 (is -1)"},
                  {"--grid_spacing_factor=1e-6", 1, "--grid_spacing_factor 1e-06 gives the control grid"},
                  {"--output_scale=0", 1, "--output_scale must be in [1e-06, 1e+06] (is 0)"},
                  {"--output_scale=nan", 1, "--output_scale must be in [1e-06, 1e+06] (is nan)"},
                  {"--output_scale=-1", 1, "--output_scale must be in [1e-06, 1e+06] (is -1)"},
                  // Legal before, useless: every actuation I, every gradient 0.
                  {"--output_scale=1e-300", 1,
                   "--output_scale must be in [1e-06, 1e+06] (is 1e-300)"},
                  {"--latent_regularization=-1", 1, "--latent_regularization must be in [0, 1e+06] (is -1)"},
                  {"--train_tolerance=0", 1, "--train_tolerance must be finite and > 0"},
                  // A training flag of a shared flagfile, before pre-training (it was
                  // ignored until aqs_train read it).
                  {"--energy_regularization=nan", 1, "--energy_regularization must be"},
                  {"--hidden=8,,8", 1, "--hidden has an empty width in '8,,8'"},
                  {"--pretrain_checkpoint_seconds=-1", 1,
                   "--pretrain_checkpoint_seconds must be finite and >= 0 (is -1)"},
                  {"--pretrain_minutes=-1", 1,
                   "--pretrain_minutes must be finite and >= 0 (is -1)"},
                  // Inf in seconds: named in the flag's unit (it said max_seconds ... inf).
                  {"--pretrain_minutes=1e307", 1,
                   "--pretrain_minutes must be finite and >= 0 (is 1e+307)"},
                  {"--pretrain_latents=poses", 1,
                   "--pretrain_latents must be targets or surfaces, got 'poses'"},
                  // (--restart: the model here was pre-trained with other flags and trained.)
                  {"--output_scale=1e308 --restart", 1,
                   "--output_scale must be in [1e-06, 1e+06] (is 1e+308)"},
              },
              dir.path());
  ExpectCases("aqs_train", "--model={dir}m --train_iterations=3",
              {
                  {"--latent_regularization=-1", 1, "--latent_regularization must be in [0, 1e+06] (is -1)"},
                  {"--latent_regularization=1e308", 1, "--latent_regularization must be in [0, 1e+06] (is 1e+308)"},
                  {"--train_tolerance=1e-17", 1,
                   "--train_tolerance must be >= 1e-13 (is 1e-17): below, the force test meets round-off"},
                  {"--latent_dim=5", 1, "--latent_dim=5 was asked for, but the model's decoder has latent_dim=2"},
                  {"--hidden=8,8", 1, "--hidden=8,8 was asked for, but the model's decoder has hidden_dims=8"},
                  {"--activation=tanh", 1, "--activation=tanh was asked for"},
                  {"--train_restarts=-1", 1, "--train_restarts must be >= 0"},
                  {"--train_minutes=-1", 1, "--train_minutes must be finite and >= 0 (is -1)"},
                  {"--max_memory_gb=-5", 1, "--max_memory_gb must be finite and > 0 (is -5)"},
                  {"--checkpoint_every=0", 1, "--checkpoint_every must be >= 1"},
                  {"--adjoint_tolerance=0", 1, "--adjoint_tolerance must be in [1e-14, 0.01] (is 0)"},
                  {"--adjoint_tolerance=0.5", 1, "--adjoint_tolerance must be in [1e-14, 0.01] (is 0.5)"},
              },
              dir.path());
  // Every stage is checked before the first runs: a typo must not cost a trained model.
  ExpectCases("aqs_pipeline",
              "--model={dir}m --neutral=" + dir_->File("neutral.obj") + " --poses=" +
                  dir_->File("poses") + " --spacing=0.5 --fixed_box=-2,-2,-1,2,2,0.3",
              {
                  {"--stages=prepare,pretrian", 1, "--stages: unknown stage 'pretrian'"},
                  {"--stages=train,prepare", 1, "--stages: 'prepare' after a later stage"},
                  {"--stages=train,train", 1, "'train' after a later stage or twice"},
                  {"--stages=", 1, "--stages: no stage given"},
                  // Without a model (it said "pretrain: /model.txt: cannot open file").
                  {"--stages=pretrain --model=", 1, "pretrain: --model is required"},
                  {"--stages=train --model=", 1, "train: --model is required"},
                  // A bad training flag, before prepare replaces the model.
                  {"--stages=prepare,pretrain,train --train_minutes=-1", 1,
                   "train: --train_minutes must be finite and >= 0 (is -1)"},
                  {"--stages=prepare,evaluate --baseline_iterations=-1", 1, "evaluate: "},
              },
              dir.path());
  EXPECT_EQ(ReadAll(model + "/learned/decoder.txt"), before) << "the model was not touched";
  // The model's own architecture, given explicitly, trains.
  ExpectCases("aqs_train", "--model={dir}m --train_iterations=3",
              {{"--latent_dim=2 --hidden=8 --activation=elu", 0, "train: 3 iterations"}}, dir.path());
}

TEST_F(AqsValidationModelTest, PrepareAndCollideRefuseBadFlags) {
  testing::TempDir dir;
  const std::string prepare = "--neutral=" + dir_->File("neutral.obj") + " --poses=" +
                              dir_->File("poses") + " --model={dir}p --fixed_box=-2,-2,-1,2,2,0.3";
  ExpectCases("aqs_prepare", prepare,
              {
                  {"--spacing=0.5 --attachment_stiffness=0", 1, "--attachment_stiffness must be finite and > 0 (is 0)"},
                  {"--spacing=0.5 --attachment_stiffness=-1", 1, "--attachment_stiffness must be finite and > 0 (is -1)"},
                  {"--spacing=0.5 --attachment_stiffness=nan", 1, "--attachment_stiffness must be finite and > 0 (is nan)"},
                  {"--spacing=0.5 --attachment_stiffness=2147483647", 1, "--attachment_stiffness must be in [0, 1e+08] (is 2.14748e+09)"},
                  {"--spacing=0.5 --inverted_targets=reflect", 1,
                   "--inverted_targets=reflect: expected exact or mirror"},
                  {"--spacing=0.5 --prepare_tolerance=nan", 1, "--prepare_tolerance must be finite and > 0"},
                  {"--spacing=-1", 1, "--spacing must be finite and > 0 (is -1)"},
                  {"--spacing=0.5 --mu=1e300", 1, "--mu must be in [1e-12, 1e+12] (is 1e+300)"},
                  {"--spacing=0.5 --fixed_box=-100,-100,-100,100,100,100", 1,
                   "is fixed, at rest or driven by a bone: nothing can move"},
                  {"--spacing=0.5 --bone_region=-2,-2,-1,2,2,0.3", 1,
                   "--bone_region and --bone_poses describe a bone: they need --bone_mesh"},
                  {"--spacing=0.5 --tet_mesh=" + dir_->File("model/mesh.mesh"), 1,
                   "give --spacing (a lattice is made) or --tet_mesh (that mesh is used)"},
                  {"--spacing=0.5 --mu=0", 1, "--mu must be in [1e-12, 1e+12] (is 0)"},
                  {"--spacing=0.005", 1, "--max_memory_gb (8 GB) is below the estimated 636 GB that meshing the neutral needs (a lattice of 2.54e+09 elements"},
                  {"--spacing=0.2 --max_memory_gb=0.001", 1, "--max_memory_gb (1 MB) is below the estimated"},
                  {"--spacing=0.5 --bone_mesh=" + dir_->File("neutral.obj") +
                       " --bone_poses={dir}missing/{pose}.obj --bone_region=-2,-2,-1,2,2,0.3",
                   1, "its pose surfaces (the pattern '{dir}missing/{pose}.obj') exist for none of the 2 poses"},
                  {"--spacing=0.5 --bone_mesh=" + dir_->File("neutral.obj") +
                       " --bone_poses={dir}teeth.obj --bone_region=-2,-2,-1,2,2,0.3",
                   1, "--bone_poses must contain '{pose}'"},
                  {"--spacing=0.5 --threads=0", 1, "--threads must be in [1, 1024] (is 0)"},
                  {"--spacing=0.5 --mirror_poses=w", 1, "--mirror_poses must be x, y or z"},
                  {"--spacing=0.5 --mirror_poses=x --mirror_tolerance=0", 1, "--mirror_tolerance must be in ["},
                  {"--spacing=0.5 --mirror_poses=x --mirror_plane=inf", 1, "--mirror_plane must be finite"},
                  {"--spacing=0.5 --mirror_poses=x --mirror_plane=100", 1, "the neutral surface is not mirror-symmetric (--mirror_poses): vertex 0 has no mirror image"},
                  {"--spacing=0.5 --halfway_poses --halfway_min_bone_motion=-1", 1,
                   "--halfway_min_bone_motion must be finite and in (0, 1] (is -1)"},
                  {"--spacing=0.5 --halfway_poses --halfway_min_bone_motion=nan", 1,
                   "--halfway_min_bone_motion must be finite and in (0, 1]"},
                  // Flags of a stage left off are refused, not dropped.
                  {"--spacing=0.5 --mirror_plane=1", 1,
                   "--mirror_plane describes --mirror_poses: it needs it"},
                  {"--spacing=0.5 --mirror_tolerance=0.01", 1,
                   "--mirror_tolerance describes --mirror_poses: it needs it"},
                  {"--spacing=0.5 --mirror_plane=1 --mirror_tolerance=0.01", 1,
                   "--mirror_plane and --mirror_tolerance describe --mirror_poses: they need it"},
                  {"--spacing=0.5 --halfway_min_bone_motion=0.1", 1,
                   "--halfway_min_bone_motion describes --halfway_poses: it needs it"},
                  {"--spacing=0.5 --bone_clearance=0.5", 1,
                   "--bone_clearance describes a bone: it needs --bone_mesh"},
                  {"--spacing=0.5 --bone_name=skull", 1,
                   "--bone_name describes a bone: it needs --bone_mesh"},
                  {"--spacing=0.5 --cut_margin=0.2", 1,
                   "--cut_margin describes --cut: it needs it"},
                  // Malformed boxes and cuts name their flag (three flags take boxes).
                  {"--spacing=0.5 --keep_box=1,2,3", 1, "--keep_box: box '1,2,3'"},
                  {"--spacing=0.5 --fixed_box=1,2,3", 1, "--fixed_box: box '1,2,3'"},
                  {"--spacing=0.5 --cut=bad", 1, "--cut: cut 'bad'"},
              },
              dir.path());
  EXPECT_FALSE(fs::exists(dir.File("p"))) << "nothing written";
  dir.Write("far.obj", "v 1e9 0 0\nv 1e9 1 0\nv 1e9 0 1\nf 1 2 3\n");
  dir.Write("flat.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n");  // three points on a line
  ExpectCases("aqs_collide", "--model=" + dir_->File("model") + " --pose=bend_x --output={dir}c.obj",
              {
                  {"--contact_vertices=5:3", 1, "--contact_vertices: vertex range '5:3'"},
                  {"--self_contact=false", 1, "no contact to resolve: give --obstacles"},
                  {"--path_steps=100000", 1, "--path_steps must be in [0, 256] (is 100000)"},
                  {"--contact_rounds=1000", 1, "--contact_rounds must be in [1, 64] (is 1000)"},
                  {"--thickness=nan", 1, "--thickness must be finite and > 0 (is nan)"},
                  {"--contact_tolerance=0", 1, "--contact_tolerance must be finite and > 0"},
                  {"--report={dir}missing/r.txt", 1, "{dir}missing/r.txt: cannot write here"},
                  {"--search_radius=1e308", 1,
                   "--search_radius (1e+308) is more than 1000 times the model's size"},
                  {"--obstacles='" + dir_->File("neutral.obj") + " vertices=0:3 vertices=0:2'", 1,
                   "'vertices=' is given twice"},
                  {"--obstacles=,,", 1, "an empty item (between commas)"},
                  {"--obstacles={dir}far.obj", 1, "far.obj: point 0 ("},
                  {"--obstacles={dir}flat.obj", 1,
                   "flat.obj: triangle 0 (vertices 1, 2, 3, 1-based) has no area"},
              },
              dir.path());
  EXPECT_FALSE(fs::exists(dir.File("c.obj")));
}

}  // namespace
}  // namespace aqs
