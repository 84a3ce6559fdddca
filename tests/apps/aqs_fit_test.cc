// aqs_fit, aqs_simulate --model, aqs_evaluate and aqs_collide on a small model trained from the
// synthetic-muscle bar by aqs_pipeline.

#include <unistd.h>

#include <csignal>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <random>

#include <gtest/gtest.h>

#include "io/latent_io.h"
#include "mesh/mesh_io.h"
#include "mesh/ply_io.h"
#include "testing/file_contents.h"
#include "testing/run_command.h"
#include "testing/synthetic_muscles.h"
#include "testing/temp_dir.h"
#include "util/path_lock.h"

namespace aqs {
namespace {

using testing::AppPath;
using testing::RunCommand;

class AqsFitTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir;
    data_ = new testing::SyntheticMuscles(testing::MakeSyntheticMuscles(6, 2, 0.3, 13));
    std::string error;
    ASSERT_TRUE(WriteObj(dir_->File("neutral.obj"), data_->model.neutral, &error)) << error;
    std::filesystem::create_directories(dir_->File("poses"));
    for (const TrainingPose& pose : data_->model.poses) {
      SurfaceMesh surface = data_->model.neutral;
      surface.vertices = pose.surface;
      ASSERT_TRUE(WriteObj(dir_->File("poses/" + pose.name + ".obj"), surface, &error));
    }
    for (size_t t = 0; t < data_->test_surfaces.size(); ++t) {
      SurfaceMesh surface = data_->model.neutral;
      surface.vertices = data_->test_surfaces[t];
      ASSERT_TRUE(WriteObj(dir_->File("test" + std::to_string(t) + ".obj"), surface, &error));
    }
    std::ofstream(dir_->File("run.flags"))
        << "--neutral=" << dir_->File("neutral.obj") << "\n--poses=" << dir_->File("poses")
        << "\n--model=" << dir_->File("model") << "\n--spacing=0.2\n--lattice=kuhn\n"
        << "--fixed_box=-1,-1,-1,0.01,1,1\n--latent_dim=3\n--hidden=16\n--grid_spacing=0.3\n"
        << "--activation=tanh\n--pretrain_iterations=60\n--train_iterations=10\n"
        << "--test_poses=" << dir_->File("test0.obj") << "," << dir_->File("test1.obj")
        << "\n--output_dir=" << dir_->File("evaluation") << "\n--baseline_iterations=50\n";
    const testing::CommandResult run =
        RunCommand(AppPath("aqs_pipeline") + " --flagfile=" + dir_->File("run.flags"));
    ASSERT_EQ(run.exit_code, 0) << run.output;
    pipeline_output_ = new std::string(run.output);
  }
  static void TearDownTestSuite() {
    delete dir_;
    delete data_;
    delete pipeline_output_;
  }

  std::string Fit(const std::string& flags) {
    return AppPath("aqs_fit") + " --model=" + dir_->File("model") + " " + flags;
  }

  static testing::TempDir* dir_;
  static testing::SyntheticMuscles* data_;
  static std::string* pipeline_output_;
};

testing::TempDir* AqsFitTest::dir_ = nullptr;
testing::SyntheticMuscles* AqsFitTest::data_ = nullptr;
std::string* AqsFitTest::pipeline_output_ = nullptr;

TEST_F(AqsFitTest, EvaluationTablesAndFieldsAreWritten) {
  EXPECT_NE(pipeline_output_->find("| test pose |"), std::string::npos) << *pipeline_output_;
  EXPECT_TRUE(std::filesystem::exists(dir_->File("evaluation/evaluation.md")));
  // The report states how the auto-encoder baseline was trained (issue 15: fair baselines).
  std::ifstream md_file(dir_->File("evaluation/evaluation.md"));
  std::stringstream md;
  md << md_file.rdbuf();
  EXPECT_NE(md.str().find("The auto-encoder trained "), std::string::npos) << md.str();
  EXPECT_NE(md.str().find(" L-BFGS iterations with scaled steps from seed 1, loss "), std::string::npos)
      << md.str();
  // The held-out poses are not training poses: no warning.
  EXPECT_EQ(md.str().find("**Warning:**"), std::string::npos) << md.str();
  std::ifstream csv(dir_->File("evaluation/evaluation.csv"));
  int lines = 0;
  std::map<std::string, int> methods;
  for (std::string line; std::getline(csv, line);) {
    ++lines;
    const size_t a = line.find(','), b = line.find(',', a + 1), c = line.find(',', b + 1);
    if (a != std::string::npos && c != std::string::npos) {
      ++methods[line.substr(0, a) + " " + line.substr(b + 1, c - b - 1)];
    }
  }
  // header, 4 methods (physics, auto-encoder, PCA about the mean and about the neutral)
  // and the neutral reference x (6 training + 2 held-out), and the error budget: floor
  // and after pre-training for the training poses, floor for the held-out ones
  EXPECT_EQ(lines, 1 + 5 * (6 + 2) + 2 * 6 + 2);
  EXPECT_EQ(methods["test pca_neutral"], 2);
  EXPECT_EQ(methods["train floor"], 6);
  EXPECT_EQ(methods["train pretrain"], 6);
  EXPECT_EQ(methods["test floor"], 2);
  for (const char* method : {"physics", "autoencoder", "pca", "pca_neutral", "floor"}) {
    EXPECT_TRUE(std::filesystem::exists(dir_->File(std::string("evaluation/fields/test0_") + method + ".ply")))
        << method;
  }
  EXPECT_TRUE(std::filesystem::exists(dir_->File("evaluation/fitted/test0_target.obj")));
  EXPECT_TRUE(std::filesystem::exists(dir_->File("evaluation/budget/training_errors.bin")));
  // The budget in the logs of pretrain, train and evaluate, and its record in the model.
  EXPECT_NE(pipeline_output_->find("(b) after pretrain"), std::string::npos) << *pipeline_output_;
  EXPECT_NE(pipeline_output_->find("train: error budget"), std::string::npos);
  EXPECT_NE(pipeline_output_->find("| train pose | neutral | (a) floor | (b) after pre-training"),
            std::string::npos);
  EXPECT_TRUE(std::filesystem::exists(dir_->File("model/pretrain/surface_errors.txt")));
  // Pre-training's log went into the model; its checkpoint, and the auto-encoder
  // baseline's, are gone once their jobs ended.
  EXPECT_TRUE(std::filesystem::exists(dir_->File("model/pretrain/log.csv")));
  EXPECT_FALSE(std::filesystem::exists(dir_->File("model/pretrain/checkpoint.txt")));
  EXPECT_FALSE(std::filesystem::exists(dir_->File("evaluation/autoencoder_checkpoint")));
  EXPECT_FALSE(std::filesystem::exists(dir_->File("model.aqs-targets")));
  // The report: written, or a message that says what is missing (a Python without
  // matplotlib); never a failed evaluation.
  const bool written = std::filesystem::exists(dir_->File("evaluation/index.html"));
  EXPECT_TRUE(written || pipeline_output_->find("lacks matplotlib or numpy") != std::string::npos)
      << *pipeline_output_;
  if (written) {
    EXPECT_TRUE(std::filesystem::exists(dir_->File("evaluation/images/held_out/test0.png")));
    EXPECT_TRUE(std::filesystem::exists(dir_->File("evaluation/images/training_curve.png")));
    EXPECT_TRUE(std::filesystem::exists(dir_->File("evaluation/images/pretraining_curve.png")));
    EXPECT_TRUE(std::filesystem::exists(dir_->File("evaluation/images/budget.png")));
  }
}

// The evaluation writes only into a new or empty folder or an evaluation's: another
// folder is refused, its fitted/ left alone (it was emptied, recursively); and an
// earlier run's page and pictures go when this run writes none (--report=false: they
// had stayed, numbers of another run beside this run's tables).
TEST_F(AqsFitTest, EvaluationEmptiesOnlyAnEvaluationsFolder) {
  namespace fs = std::filesystem;
  const std::string command = AppPath("aqs_evaluate") + " --model=" + dir_->File("model") +
                              " --test_poses=" + dir_->File("test0.obj") +
                              " --baseline_iterations=5 --error_budget=false "
                              "--write_fields=false --report=false --output_dir=";
  const std::string user = dir_->File("user_folder");
  fs::create_directories(user + "/fitted");
  std::ofstream(user + "/fitted/mine.obj") << "v 0 0 0\n";
  const testing::CommandResult refused = RunCommand(command + user);
  EXPECT_EQ(refused.exit_code, 1) << refused.output;
  EXPECT_NE(refused.output.find(user + ": holds files, but no evaluation's"), std::string::npos)
      << refused.output;
  EXPECT_TRUE(fs::exists(user + "/fitted/mine.obj"));
  const std::string folder = dir_->File("evaluation_again");
  testing::CommandResult run = RunCommand(command + folder);
  ASSERT_EQ(run.exit_code, 0) << run.output;
  std::ofstream(folder + "/index.html") << "an earlier run's page\n";
  fs::create_directories(folder + "/images/held_out");
  std::ofstream(folder + "/images/held_out/test0.png") << "an earlier run's picture\n";
  run = RunCommand(command + folder);
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_FALSE(fs::exists(folder + "/index.html"));
  EXPECT_FALSE(fs::exists(folder + "/images"));
  EXPECT_TRUE(fs::exists(folder + "/evaluation.md"));
  // While the report runs, the held-out fits are still kept (a run killed then takes
  // them; they were removed before the report, and the rerun fitted every pose again);
  // they go once it is done. The "report" here lists the store.
  const std::string probe = dir_->Write("probe.sh", "ls \"$2/held_out_fits\" > \"$2/probe.txt\"\n");
  const std::string reported = dir_->File("evaluation_probed");
  run = RunCommand(command + reported + " --report=true --python=/bin/sh --report_script=" +
                   probe);
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(testing::ReadAll(reported + "/probe.txt").find("key.txt"), std::string::npos)
      << testing::ReadAll(reported + "/probe.txt");
  EXPECT_FALSE(fs::exists(reported + "/held_out_fits"));
}

// Held-out fits start from the best of the mean training latent and the training poses'
// latents, for the physics model and the auto-encoder alike: a "held-out" pose that is
// a training pose starts, for both, from that pose; with --held_out_starts=false both
// start from the mean latent.
TEST_F(AqsFitTest, EvaluationStartsHeldOutFitsFromTheBestTrainingPose) {
  const std::string pose = data_->model.poses.back().name;
  for (const bool starts : {true, false}) {
    const std::string out = dir_->File(starts ? "eval_starts" : "eval_mean");
    const testing::CommandResult run = RunCommand(
        AppPath("aqs_evaluate") + " --model=" + dir_->File("model") + " --test_poses=" +
        dir_->File("poses/" + pose + ".obj") + " --output_dir=" + out +
        " --baseline_iterations=50 --error_budget=false --write_fields=false --report=false" +
        " --held_out_starts=" + (starts ? "true" : "false"));
    ASSERT_EQ(run.exit_code, 0) << run.output;
    std::ifstream md_file(out + "/evaluation.md");
    std::stringstream md;
    md << md_file.rdbuf();
    const std::string expected =
        starts ? " " + pose + " from " + pose + " / " + pose + "."
               : " " + pose + " from mean latent / mean latent.";
    EXPECT_NE(md.str().find(expected), std::string::npos) << expected << "\n" << md.str();
    // The report and the log say that this pose is not held out.
    const std::string warning = "held-out pose '" + pose + "' is within ";
    const std::string which = " of the training pose '" + pose + "' (it moves ";
    EXPECT_NE(md.str().find("**Warning:** " + warning), std::string::npos) << md.str();
    EXPECT_NE(md.str().find(which), std::string::npos) << md.str();
    EXPECT_NE(run.output.find("warning: " + warning), std::string::npos) << run.output;
    EXPECT_NE(run.output.find(starts ? "iterations from " + pose + ", auto-encoder from " + pose
                                     : "iterations from mean latent, auto-encoder from mean latent"),
              std::string::npos)
        << run.output;
  }
}

// --baseline_hidden and --baseline_linear_skip give the auto-encoder its own layout, and
// the report says so beside the decoder's; bad values exit 1 naming the flag. (And an
// earlier run's per-pose files do not survive a run.)
TEST_F(AqsFitTest, EvaluationTakesTheAutoencodersOwnLayout) {
  const std::string pose = data_->model.poses.back().name;
  const std::string command =
      AppPath("aqs_evaluate") + " --model=" + dir_->File("model") + " --test_poses=" +
      dir_->File("poses/" + pose + ".obj") + " --output_dir=" + dir_->File("eval_layout") +
      " --baseline_iterations=20 --error_budget=false --write_fields=false --report=false";
  // An earlier run's per-pose outputs in the folder: gone after this run, which writes
  // none (no fields, no budget), so that no report draws them.
  // A killed run's temporary files (of a process that is gone) go too; others stay.
  const std::vector<std::string> killed = {
      "eval_layout/evaluation.md.tmp999999999",
      "eval_layout/autoencoder_checkpoint/parameters_a.bin.tmp999999999",
      "eval_layout/held_out_fits/0000.bin.tmp999999999",
      "eval_layout/held_out_fits/10000.txt.tmp999999999"};
  // (An evaluation's folder: its first run marked it.)
  for (const std::string& stale :
       {std::string("eval_layout/.aqs-evaluation"),
        std::string("eval_layout/fitted/old_physics.obj"),
        std::string("eval_layout/fields/old.ply"),
        std::string("eval_layout/budget/training_errors.bin"),
        std::string("eval_layout/notes.txt.tmp999999999"), killed[0], killed[1], killed[2],
        killed[3]}) {
    std::filesystem::create_directories(std::filesystem::path(dir_->File(stale)).parent_path());
    std::ofstream(dir_->File(stale)) << "stale\n";
  }
  const testing::CommandResult run = RunCommand(command + " --baseline_hidden=4,3");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  for (const std::string& stale : killed) {
    EXPECT_FALSE(std::filesystem::exists(dir_->File(stale))) << stale;
    EXPECT_NE(run.output.find("cleanup: removed " + dir_->File(stale) + ", left by process "
                              "999999999"),
              std::string::npos)
        << run.output;
  }
  EXPECT_TRUE(std::filesystem::exists(dir_->File("eval_layout/notes.txt.tmp999999999")));
  EXPECT_FALSE(std::filesystem::exists(dir_->File("eval_layout/fitted/old_physics.obj")));
  EXPECT_FALSE(std::filesystem::exists(dir_->File("eval_layout/fields/old.ply")));
  EXPECT_FALSE(std::filesystem::exists(dir_->File("eval_layout/budget")));
  std::ifstream md_file(dir_->File("eval_layout/evaluation.md"));
  std::stringstream md;
  md << md_file.rdbuf();
  EXPECT_NE(
      md.str().find("surface-only decoder with hidden layers 4,3 (the physics decoder's: 16)"),
      std::string::npos)
      << md.str();
  EXPECT_EQ(md.str().find("linear skip"), std::string::npos) << md.str();
  const testing::CommandResult skip = RunCommand(command + " --baseline_linear_skip=true");
  ASSERT_EQ(skip.exit_code, 0) << skip.output;
  std::ifstream skip_file(dir_->File("eval_layout/evaluation.md"));
  std::stringstream skip_md;
  skip_md << skip_file.rdbuf();
  EXPECT_NE(skip_md.str().find("the same network layout and a linear skip (the physics decoder "
                               "has none)"),
            std::string::npos)
      << skip_md.str();
  const testing::CommandResult bad = RunCommand(command + " --baseline_hidden=4,0");
  EXPECT_EQ(bad.exit_code, 1) << bad.output;
  EXPECT_NE(bad.output.find("--baseline_hidden takes positive widths or 'decoder', got '0'"),
            std::string::npos)
      << bad.output;
  const testing::CommandResult bad_skip = RunCommand(command + " --baseline_linear_skip=yes");
  EXPECT_EQ(bad_skip.exit_code, 1) << bad_skip.output;
  EXPECT_NE(
      bad_skip.output.find("--baseline_linear_skip must be true, false or decoder, got 'yes'"),
      std::string::npos)
      << bad_skip.output;
}

TEST_F(AqsFitTest, FitsAPoseAndSimulatesTheLatentBack) {
  const testing::CommandResult fit =
      RunCommand(Fit("--target=" + dir_->File("test0.obj") + " --output=" + dir_->File("fit.obj") +
                     " --latent_output=" + dir_->File("z.txt") + " --output_volume=" +
                     dir_->File("fit.vtu") + " --compare_to=" + dir_->File("test0.obj") +
                     " --compare_vertices=0:10"));
  ASSERT_EQ(fit.exit_code, 0) << fit.output;
  EXPECT_NE(fit.output.find("target " + dir_->File("test0.obj") + ": pose"), std::string::npos)
      << fit.output;
  EXPECT_NE(fit.output.find("work: "), std::string::npos) << "the solver work" << fit.output;
  SurfaceMesh fitted, back;
  std::string error;
  ASSERT_TRUE(ReadObj(dir_->File("fit.obj"), &fitted, &error)) << error;
  EXPECT_EQ(fitted.num_vertices(), data_->model.neutral.num_vertices());
  EXPECT_EQ(fitted.triangles, data_->model.neutral.triangles) << "the neutral's faces";
  // The comparison with the target itself: the fit's error over the first 10 vertices.
  const double first_ten =
      (fitted.vertices.leftCols(10) - data_->test_surfaces[0].leftCols(10)).colwise().norm().mean();
  double reported = -1;
  const size_t at = fit.output.find("over 10 vertices: mean ");
  ASSERT_NE(at, std::string::npos) << fit.output;
  reported = std::stod(fit.output.substr(at + 23));
  EXPECT_NEAR(reported, first_ten, 1e-5 + 1e-4 * first_ten) << fit.output;
  // The latent decodes and simulates to the same surface.
  const testing::CommandResult sim = RunCommand(
      AppPath("aqs_simulate") + " --model=" + dir_->File("model") + " --latent=" +
      dir_->File("z.txt") + " --output=" + dir_->File("back.obj"));
  ASSERT_EQ(sim.exit_code, 0) << sim.output;
  ASSERT_TRUE(ReadObj(dir_->File("back.obj"), &back, &error)) << error;
  EXPECT_LT((back.vertices - fitted.vertices).cwiseAbs().maxCoeff(), 1e-5);
  // And a training pose by name.
  const testing::CommandResult pose = RunCommand(
      AppPath("aqs_simulate") + " --model=" + dir_->File("model") + " --pose=train_2 --output=" +
      dir_->File("p.obj"));
  EXPECT_EQ(pose.exit_code, 0) << pose.output;
  EXPECT_EQ(pose.output.find("--mu"), std::string::npos) << pose.output;
  // --mu (a mesh-mode flag) is not used with a model: said, not silently ignored.
  const testing::CommandResult mu = RunCommand(
      AppPath("aqs_simulate") + " --model=" + dir_->File("model") + " --pose=train_2 --mu=5" +
      " --output=" + dir_->File("p.obj"));
  EXPECT_EQ(mu.exit_code, 0) << mu.output;
  EXPECT_NE(mu.output.find("note: --mu is not used with --model"), std::string::npos)
      << mu.output;
}

// The training benchmark runs with the energy term (as the demo trains) and refuses a
// negative weight, naming the flag.
TEST_F(AqsFitTest, TrainingBenchmarkTakesTheEnergyTerm) {
  const std::string bench = AppPath("aqs_bench_train") + " --model=" + dir_->File("model") +
                            " --iterations=2 --modes=per_pose --energy_regularization=";
  const testing::CommandResult run = RunCommand(bench + "0.1");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("per_pose"), std::string::npos) << run.output;
  const testing::CommandResult bad = RunCommand(bench + "-1");
  EXPECT_EQ(bad.exit_code, 1) << bad.output;
  EXPECT_NE(bad.output.find("--energy_regularization must be in"), std::string::npos)
      << bad.output;
}

TEST_F(AqsFitTest, MarkersAndPointCloudTargets) {
  // Markers: 12 vertices of the held-out surface.
  std::ofstream markers(dir_->File("markers.txt"));
  markers << "# vertex x y z\n";
  for (int v = 0; v < data_->model.neutral.num_vertices(); v += 8) {
    const Eigen::Vector3d p = data_->test_surfaces[1].col(v);
    markers << v << " " << p.x() << " " << p.y() << " " << p.z() << "\n";
  }
  markers.close();
  testing::CommandResult run = RunCommand(
      Fit("--target=" + dir_->File("markers.txt") + " --output=" + dir_->File("m.obj") +
          " --output_uncertainty=" + dir_->File("m_std.ply")));
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find(": markers"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("uncertainty: noise sigma"), std::string::npos) << run.output;
  Eigen::Matrix3Xd std_points;
  std::string error;
  ASSERT_TRUE(ReadPointCloud(dir_->File("m_std.ply"), &std_points, &error)) << error;
  EXPECT_EQ(std_points.cols(), data_->model.neutral.num_vertices());
  // A scan of 3 points cannot say how uncertain a fit of 3 parameters is: the earlier
  // fit's file must not stay to pass for this one's.
  std::ofstream(dir_->File("three.ply"))
      << "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      << "property float z\nend_header\n1.0 0.5 0.5\n1.2 0.5 0.5\n1.4 0.4 0.5\n";
  run = RunCommand(Fit("--target=" + dir_->File("three.ply") + " --output=" +
                       dir_->File("three.obj") +
                       " --output_uncertainty=" + dir_->File("m_std.ply")));
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("uncertainty: not available"), std::string::npos) << run.output;
  EXPECT_FALSE(std::filesystem::exists(dir_->File("m_std.ply"))) << run.output;
  run = RunCommand(Fit("--target=" + dir_->File("markers.txt") + " --output=" +
                       dir_->File("m.obj") + " --output_uncertainty=" + dir_->File("m_std.obj")));
  EXPECT_EQ(run.exit_code, 1) << run.output;
  EXPECT_NE(run.output.find("--output_uncertainty must be a .ply"), std::string::npos)
      << run.output;
  // A point cloud: shuffled points of part of the surface, as a PLY.
  std::vector<int> order;
  for (int v = 0; v < data_->model.neutral.num_vertices(); ++v) {
    if (data_->model.neutral.vertices(0, v) > 0.8) order.push_back(v);
  }
  std::shuffle(order.begin(), order.end(), std::mt19937(1));
  std::ofstream ply(dir_->File("scan.ply"));
  ply << "ply\nformat ascii 1.0\nelement vertex " << order.size()
      << "\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
  for (int v : order) ply << data_->test_surfaces[1].col(v).transpose() << "\n";
  ply.close();
  run = RunCommand(Fit("--target=" + dir_->File("scan.ply") + " --output=" + dir_->File("s.obj") +
                       " --max_distance=0.5 --robust_scale=0.05"));
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find(": points"), std::string::npos) << run.output;
  EXPECT_EQ(run.output.find("at each matching round"), std::string::npos) << run.output;
  // Compared with the pose it samples: the error over the vertices the scan sees (those
  // with x > 0.8, each a scan point itself, and neighbours within 2 spacings) splits
  // along the pose's normals and across them.
  run = RunCommand(Fit("--target=" + dir_->File("scan.ply") + " --output=" + dir_->File("s.obj") +
                       " --max_distance=0.5 --robust_scale=0.05 --compare_to=" +
                       dir_->File("test1.obj")));
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const size_t seen_at = run.output.find("  of them, ");
  ASSERT_NE(seen_at, std::string::npos) << run.output;
  const int seen = std::stoi(run.output.substr(seen_at + 11));
  EXPECT_GE(seen, static_cast<int>(order.size())) << run.output;
  EXPECT_LT(seen, data_->model.neutral.num_vertices()) << run.output;
  EXPECT_NE(run.output.find("within 2 scan spacings of a scan point: mean "), std::string::npos)
      << run.output;
  EXPECT_NE(run.output.find("(what a scan measures), across them"), std::string::npos)
      << run.output;
  // --match_rounds: rounds of matching with fixed correspondences (2 here).
  run = RunCommand(Fit("--target=" + dir_->File("scan.ply") + " --output=" + dir_->File("s.obj") +
                       " --max_distance=0.5 --robust_scale=0.05 --match_rounds --rounds=2"));
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("at each matching round"), std::string::npos) << run.output;
  // The scan with landmarks (the markers above): the log reports their distance.
  run = RunCommand(Fit("--target=" + dir_->File("scan.ply") + " --output=" + dir_->File("s.obj") +
                       " --max_distance=0.5 --landmarks=" + dir_->File("markers.txt") +
                       " --landmark_weight=2"));
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("landmarks: 12 (weight 2), mean distance"), std::string::npos)
      << run.output;
}

// Writes a markers file of `surface` on every 8th surface vertex.
void WriteMarkers(const std::string& path, const Eigen::Matrix3Xd& surface) {
  std::ofstream out(path);
  for (int v = 0; v < surface.cols(); v += 8) {
    out << v << " " << surface(0, v) << " " << surface(1, v) << " " << surface(2, v) << "\n";
  }
}

std::vector<std::string> ReadLines(const std::string& path) {
  std::ifstream in(path);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

TEST_F(AqsFitTest, MarkerSequenceWritesEveryFrameAndResumesAfterAKill) {
  namespace fs = std::filesystem;
  const std::string seq = dir_->File("seq"), out = dir_->File("seq_out");
  fs::create_directories(seq);
  for (int f = 0; f < 4; ++f) {
    WriteMarkers(seq + "/frame_" + std::to_string(f) + ".txt", data_->model.poses[f].surface);
  }
  const std::string command = Fit("--sequence=" + seq + " --output_dir=" + out);
  testing::CommandResult run = RunCommand(command);
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("frames/s, ETA"), std::string::npos) << run.output;
  for (int f = 0; f < 4; ++f) {
    EXPECT_TRUE(fs::exists(out + "/frame_" + std::to_string(f) + ".obj")) << f;
  }
  EXPECT_TRUE(fs::exists(out + "/latents.bin"));
  std::vector<std::string> rows = ReadLines(out + "/frames.csv");
  ASSERT_EQ(rows.size(), 5u) << "a header and a row per frame";
  EXPECT_EQ(rows[4].rfind("3,frame_3,markers,", 0), 0u) << rows[4];
  // A kill after frame 3's OBJ was written but before its row: the row is missing.
  {
    std::ofstream csv(out + "/frames.csv");
    for (int i = 0; i < 4; ++i) csv << rows[i] << "\n";
  }
  run = RunCommand(command);
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("resuming at frame 3 (frame_3): 3 frames done"), std::string::npos)
      << run.output;
  EXPECT_NE(run.output.find("fitted 1 frames"), std::string::npos) << run.output;
  EXPECT_EQ(ReadLines(out + "/frames.csv").size(), 5u);
  // A kill while frame 2's OBJ was being written: its row is there (from before) but the
  // OBJ is not, and its temporary file is left (of a process that is gone); frames 2 and
  // 3 are fitted again, and the temporary file removed.
  fs::rename(out + "/frame_2.obj", out + "/frame_2.obj.tmp999999999");
  run = RunCommand(command);
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("resuming at frame 2"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("cleanup: removed " + out + "/frame_2.obj.tmp999999999, left by "
                            "process 999999999"),
            std::string::npos)
      << run.output;
  EXPECT_FALSE(fs::exists(out + "/frame_2.obj.tmp999999999"));
  EXPECT_NE(run.output.find("fitted 2 frames"), std::string::npos) << run.output;
  // Nothing left to do.
  run = RunCommand(command);
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("all 4 frames were done already"), std::string::npos) << run.output;
  // Another sequence into the same folder is refused.
  const std::string other = dir_->File("seq_other");
  fs::create_directories(other);
  WriteMarkers(other + "/a.txt", data_->model.poses[0].surface);
  run = RunCommand(Fit("--sequence=" + other + " --output_dir=" + out));
  EXPECT_EQ(run.exit_code, 1) << run.output;
  EXPECT_NE(run.output.find("frames.csv:2: frame 0 is 'frame_0', but this sequence's is 'a'"),
            std::string::npos) << run.output;
  // While another process holds the folder's writers' lock, a second run is refused
  // before it writes anything.
  const std::string lock_file = PathLock::LockFileOf(out);
  const int holder = testing::StartCommand({"/usr/bin/flock", lock_file, "sleep", "60"},
                                           dir_->File("holder.txt"));
  ASSERT_GT(holder, 0);
  for (int i = 0; i < 100 && !fs::exists(lock_file); ++i) ::usleep(50000);
  ::usleep(200000);  // flock(1) takes the lock right after creating the file
  const auto csv_before = ReadLines(out + "/frames.csv");
  run = RunCommand(command);
  ::kill(holder, SIGKILL);
  testing::WaitForCommand(holder);
  EXPECT_EQ(run.exit_code, 1) << run.output;
  EXPECT_NE(run.output.find("the sequence folder " + out + " is in use by another process"),
            std::string::npos)
      << run.output;
  EXPECT_EQ(ReadLines(out + "/frames.csv"), csv_before);
}

TEST_F(AqsFitTest, ScanSequenceTakesOneLandmarksFilePerFrame) {
  namespace fs = std::filesystem;
  const std::string d = dir_->File("scan_seq");
  fs::create_directories(d);
  // Two scans (every vertex beyond x = 0.8 of a test surface) and, for each, landmarks
  // taken from another pose: with a large weight the fit follows them.
  for (int frame = 0; frame < 2; ++frame) {
    const Eigen::Matrix3Xd& surface = data_->test_surfaces[frame];
    std::ofstream ply(d + "/scan" + std::to_string(frame) + ".ply");
    std::vector<int> kept;
    for (int v = 0; v < surface.cols(); ++v) {
      if (data_->model.neutral.vertices(0, v) > 0.8) kept.push_back(v);
    }
    ply << "ply\nformat ascii 1.0\nelement vertex " << kept.size()
        << "\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
    for (int v : kept) ply << surface.col(v).transpose() << "\n";
    ply.close();
    WriteMarkers(d + "/landmarks" + std::to_string(frame) + ".txt",
                 data_->model.poses[3 + frame].surface);
  }
  const std::string scans = " --sequence=" + d + "/scan0.ply," + d + "/scan1.ply";
  const std::string landmarks = " --landmarks=" + d + "/landmarks0.txt," + d + "/landmarks1.txt";
  testing::CommandResult run =
      RunCommand(Fit(scans + " --max_distance=0.5 --output_dir=" + d + "/plain"));
  ASSERT_EQ(run.exit_code, 0) << run.output;
  run = RunCommand(Fit(scans + landmarks + " --landmark_weight=100 --max_distance=0.5 " +
                       "--output_dir=" + d + "/landmarks"));
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("with landmarks from"), std::string::npos) << run.output;
  // The same landmark files spelled otherwise: the same run (the key held the spelling).
  const testing::CommandResult respelled = RunCommand(
      Fit(scans + " --landmarks=" + d + "/./landmarks0.txt," + d + "/./landmarks1.txt" +
          " --landmark_weight=100 --max_distance=0.5 --output_dir=" + d + "/landmarks"));
  EXPECT_EQ(respelled.exit_code, 0) << respelled.output;
  EXPECT_NE(respelled.output.find("all 2 frames were done already"), std::string::npos)
      << respelled.output;
  // Its first frame alone: refused, saying the folder holds a longer sequence.
  const testing::CommandResult prefix = RunCommand(
      Fit(" --sequence=" + d + "/scan0.ply, --landmarks=" + d + "/landmarks0.txt," +
          " --landmark_weight=100 --max_distance=0.5 --output_dir=" + d + "/landmarks"));
  EXPECT_EQ(prefix.exit_code, 1) << prefix.output;
  EXPECT_NE(prefix.output.find("frame 1 (scan1) is done, but this sequence has 1 frames"),
            std::string::npos)
      << prefix.output;
  for (int frame = 0; frame < 2; ++frame) {
    SurfaceMesh plain, pulled;
    std::string error;
    const std::string name = "/scan" + std::to_string(frame) + ".obj";
    ASSERT_TRUE(ReadObj(d + "/plain" + name, &plain, &error)) << error;
    ASSERT_TRUE(ReadObj(d + "/landmarks" + name, &pulled, &error)) << error;
    const Eigen::Matrix3Xd& toward = data_->model.poses[3 + frame].surface;
    double plain_distance = 0, pulled_distance = 0;
    for (int v = 0; v < toward.cols(); v += 8) {
      plain_distance += (plain.vertices.col(v) - toward.col(v)).norm();
      pulled_distance += (pulled.vertices.col(v) - toward.col(v)).norm();
    }
    EXPECT_LT(pulled_distance, 0.5 * plain_distance) << "frame " << frame;
  }
}

TEST_F(AqsFitTest, BadSequencesFailNamingTheFileAndLine) {
  namespace fs = std::filesystem;
  const std::string d = dir_->File("bad_seq");
  fs::create_directories(d);
  WriteMarkers(d + "/good.txt", data_->model.poses[0].surface);
  std::ofstream(d + "/repeated.txt") << "3 0 0 0\n# comment\n3 1 1 1\n";
  std::ofstream(d + "/outside.txt") << "5 0 0 0\n99999 0 0 0\n";
  std::ofstream(d + "/remote.txt") << "5 0 0 0\n6 1e200 0 0\n";
  std::ofstream(d + "/empty.ply") << "ply\nformat ascii 1.0\nelement vertex 0\n"
                                     "property float x\nproperty float y\nproperty float z\n"
                                     "end_header\n";
  std::ofstream(d + "/scan.ply") << "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                                    "property float y\nproperty float z\nend_header\n"
                                    "0 0 0\n1 0 0\n0 1 0\n";
  SurfaceMesh small;
  small.vertices = Eigen::Matrix3Xd::Random(3, 10);
  std::string error;
  ASSERT_TRUE(WriteObj(d + "/small.obj", small, &error));
  std::ofstream(d + "/mixed.txt") << "# frames\ngood.txt\nscan.ply\n";
  std::ofstream(d + "/poses.txt") << dir_->File("test0.obj") << "\nsmall.obj\n";
  const std::string out = " --output_dir=" + dir_->File("bad_seq_out");
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"--sequence=" + d + "/good.txt," + d + "/repeated.txt",
       "repeated.txt:3: vertex 3 is given again (first on line 1)"},
      {"--sequence=" + d + "/good.txt," + d + "/outside.txt",
       "outside.txt:2: surface vertex 99999 is outside"},
      {"--sequence=" + d + "/mixed.txt",
       "mixed.txt:3: " + d + "/scan.ply: a points target, but the sequence's first frame " + d +
           "/good.txt is a markers target"},
      {"--sequence=" + d + "/poses.txt",
       "poses.txt:2: " + d + "/small.obj: 10 vertices, but the model's surface (and the first "
       "frame's) has"},
      {"--sequence=" + d + "/poses.txt --target_kind=pose",
       "poses.txt:2: " + d + "/small.obj: 10 vertices, but the model's surface (and the first "
       "frame's) has"},
      {"--sequence=" + d + "/scan.ply," + d + "/empty.ply", "empty.ply: the file has no points"},
      {"--sequence=" + d + "/nothing*.txt", "matches no target files"},
      // One markers file is a list to --sequence; the message says how to give one file.
      {"--sequence=" + d + "/good.txt", "for a single target file write '" + d + "/good.txt,'"},
      // Errors about --landmarks name it, not the sequence.
      {"--sequence=" + d + "/scan.ply --landmarks=" + d + "/nolandmarks*.txt",
       "--landmarks='" + d + "/nolandmarks*.txt' matches no landmarks files"},
      // The outputs in the landmarks' folder would be taken for landmarks on a rerun.
      {"--sequence=" + d + "/scan.ply --landmarks=" + d + "/good.txt, --output_dir=" + d,
       d + ": is the folder of the landmarks file " + d + "/good.txt"},
      {"--sequence=" + d + "/good.txt", "--output_dir are required"},
      {"--sequence=" + d + "/good.txt, --landmarks=" + d + "/good.txt,",
       "landmarks go with a sequence of point clouds (scans), but"},
      {"--sequence=" + d + "/scan.ply --landmarks=" + d + "/good.txt," + d + "/good.txt",
       "2 landmark files for the 1 frames of"},
      {"--sequence=" + d + "/scan.ply --landmarks=" + d + "/outside.txt,",
       "outside.txt:2: surface vertex 99999 is outside"},
      // A landmark no solve reaches: refused as bad input naming the file (it ended the
      // run with exit 2, "fewer than 3 of the scan's points lie within --max_distance").
      {"--sequence=" + d + "/scan.ply --landmarks=" + d + "/remote.txt,",
       "remote.txt: point 1 (1e+200 0 0) is"},
  };
  for (const auto& [flags, message] : cases) {
    const bool own_output = message.find("output_dir") != std::string::npos ||
                            flags.find("--output_dir") != std::string::npos;
    const std::string command = Fit(flags + (own_output ? "" : out));
    const testing::CommandResult run = RunCommand(command);
    EXPECT_EQ(run.exit_code, 1) << command << "\n" << run.output;
    EXPECT_NE(run.output.find(message), std::string::npos) << command << "\n" << run.output;
  }
}

TEST_F(AqsFitTest, MalformedTargetsFailClearly) {
  WriteMarkers(dir_->File("markers.txt"), data_->test_surfaces[1]);
  WriteMarkers(dir_->File("markers_x10.txt"), 10.0 * data_->test_surfaces[1]);
  std::ofstream(dir_->File("bad_markers.txt")) << "3 0.1 0.2\n";
  std::ofstream(dir_->File("far_markers.txt")) << "99999 0 0 0\n";
  std::ofstream(dir_->File("bad.ply")) << "ply\nformat ascii 1.0\nelement vertex 5\n"
                                           "property float x\nend_header\n1\n";
  SurfaceMesh small;
  small.vertices = Eigen::Matrix3Xd::Random(3, 10);
  std::string error;
  ASSERT_TRUE(WriteObj(dir_->File("small.obj"), small, &error));
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"--target=" + dir_->File("bad_markers.txt"), "bad_markers.txt:1: expected 'vertex x y z'"},
      {"--target=" + dir_->File("far_markers.txt"), "far_markers.txt:1: surface vertex 99999"},
      {"--target=" + dir_->File("bad.ply"), "bad.ply"},
      {"--target=" + dir_->File("small.obj") + " --target_kind=pose",
       "small.obj: 10 vertices, but the model's surface has"},
      {"--target=" + dir_->File("missing.obj"), "missing.obj"},
      {"--target=" + dir_->File("x.xyz"), "cannot tell the target kind"},
      {"--target=" + dir_->File("test0.obj") + " --target_kind=cloud", "--target_kind must be"},
      {"--target=" + dir_->File("test0.obj") + " --compare_to=" + dir_->File("small.obj"),
       "small.obj: 10 vertices, but the model's surface has"},
      {"--target=" + dir_->File("test0.obj") + " --compare_to=" + dir_->File("test0.obj") +
       " --compare_vertices=0:99999", "comparison vertex"},
      {"--target=" + dir_->File("test0.obj") + " --landmarks=" + dir_->File("markers.txt"),
       "markers.txt: --landmarks go with a point cloud (a scan), but"},
      {"--target=" + dir_->File("test0.obj") + " --target_kind=points --landmarks=" +
       dir_->File("far_markers.txt"), "far_markers.txt:1: surface vertex 99999"},
      {"--target=" + dir_->File("test0.obj") + " --target_kind=points --landmarks=" +
       dir_->File("markers.txt") + " --landmark_weight=-1", "--landmark_weight must be"},
      // A sequence's flags, and comparison vertices without a comparison, would be
      // dropped without a word.
      {"--target=" + dir_->File("test0.obj") + " --output_dir=" + dir_->File("never"),
       "--output_dir applies to a --sequence, not to one --target"},
      {"--target=" + dir_->File("test0.obj") + " --sequence_warm_start=false",
       "--sequence_warm_start applies to a --sequence, not to one --target"},
      {"--target=" + dir_->File("test0.obj") + " --compare_vertices=0:10",
       "--compare_to, which is not given"},
      // Landmarks in another unit (ten times the model's), as any target would be.
      {"--target=" + dir_->File("test0.obj") + " --target_kind=points --landmarks=" +
       dir_->File("markers_x10.txt"), "markers_x10.txt: its points lie a median"},
  };
  for (const auto& [flags, message] : cases) {
    const testing::CommandResult run = RunCommand(Fit(flags + " --output=" + dir_->File("o.obj")));
    EXPECT_EQ(run.exit_code, 1) << flags << "\n" << run.output;
    EXPECT_NE(run.output.find(message), std::string::npos) << flags << "\n" << run.output;
  }
  const testing::CommandResult sequence_landmarks =
      RunCommand(Fit("--sequence=" + dir_->File("test0.obj") + " --output_dir=" +
                     dir_->File("seq_lm") + " --landmarks=" + dir_->File("markers.txt")));
  EXPECT_EQ(sequence_landmarks.exit_code, 1) << sequence_landmarks.output;
  EXPECT_NE(sequence_landmarks.output.find("landmarks go with a sequence of point clouds"),
            std::string::npos) << sequence_landmarks.output;
  const testing::CommandResult no_model =
      RunCommand(AppPath("aqs_fit") + " --target=x.obj --output=o.obj");
  EXPECT_EQ(no_model.exit_code, 1);
  std::ofstream(dir_->File("bad_latent.txt")) << "latent 1 2\n";
  const testing::CommandResult bad_latent = RunCommand(
      AppPath("aqs_simulate") + " --model=" + dir_->File("model") + " --latent=" +
      dir_->File("bad_latent.txt") + " --output=" + dir_->File("o.obj"));
  EXPECT_EQ(bad_latent.exit_code, 1);
  EXPECT_NE(bad_latent.output.find("bad_latent.txt:1: expected 3 latent numbers"), std::string::npos)
      << bad_latent.output;
}

// Reads 'name value' lines (skipping '#' comments) of a contact report.
std::map<std::string, double> ReadReport(const std::string& path) {
  std::map<std::string, double> values;
  std::ifstream in(path);
  std::string name;
  double value = 0;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    if (fields >> name >> value) values[name] = value;
  }
  return values;
}

// A closed axis-aligned box as an OBJ surface (outward normals).
void WriteBoxObj(const std::string& path, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  std::ofstream out(path);
  for (int k = 0; k < 8; ++k) {
    out << "v " << ((k & 1) ? hi.x() : lo.x()) << " " << ((k & 2) ? hi.y() : lo.y()) << " "
        << ((k & 4) ? hi.z() : lo.z()) << "\n";
  }
  // Faces as quads (1-based), counter-clockwise seen from outside.
  out << "f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n";
}

TEST_F(AqsFitTest, CollidePushesTheSurfaceOutOfAnObstacle) {
  // A box reaching 0.08 into the upper side of the posed bar around the highest point
  // of its free half (the left end is fixed), much wider than that (penalty directions
  // come from the closest obstacle point: a point closer to a side face than to the
  // bottom is pushed sideways).
  const Eigen::Matrix3Xd& posed = data_->model.poses[0].surface;
  Eigen::Vector3d peak(0, -1e9, 0);
  for (Eigen::Index i = 0; i < posed.cols(); ++i) {
    if (posed(0, i) > 0.6 * posed.row(0).maxCoeff() && posed(1, i) > peak.y()) peak = posed.col(i);
  }
  WriteBoxObj(dir_->File("box.obj"),
              Eigen::Vector3d(peak.x() - 0.5, peak.y() - 0.08, posed.row(2).minCoeff() - 0.2),
              Eigen::Vector3d(peak.x() + 0.5, peak.y() + 0.4, posed.row(2).maxCoeff() + 0.2));
  const std::string collide = AppPath("aqs_collide") + " --model=" + dir_->File("model") +
                              " --pose=" + data_->model.poses[0].name + " --obstacles=" +
                              dir_->File("box.obj") + " --thickness=0.01 --search_radius=0.2";
  const testing::CommandResult run =
      RunCommand(collide + " --output=" + dir_->File("collided.obj") + " --output_before=" +
                 dir_->File("free.obj") + " --output_volume=" + dir_->File("collided.vtu") +
                 " --report=" + dir_->File("contact.txt") + " --output_intersections=" +
                 dir_->File("intersections.ply"));
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const std::map<std::string, double> report = ReadReport(dir_->File("contact.txt"));
  ASSERT_EQ(report.count("converged"), 1u) << run.output;
  EXPECT_EQ(report.at("converged"), 1);
  EXPECT_GT(report.at("penetrating_points_before"), 0) << run.output;
  EXPECT_GT(report.at("max_penetration_before"), 0.02) << run.output;
  EXPECT_EQ(report.at("penetrating_points_after"), 0) << run.output;
  EXPECT_GT(report.at("obstacle_intersections_before"), 0) << run.output;
  // Contact acts on surface points only: the box's lower edges still cut the bar's
  // triangles (0.2 wide) between their corners.
  EXPECT_LT(report.at("obstacle_intersections_after"), report.at("obstacle_intersections_before"))
      << run.output;
  EXPECT_EQ(report.at("new_self_intersections_after"), 0) << run.output;
  EXPECT_GT(report.at("obstacle_contacts"), 0) << run.output;
  // The surface moved down by about the penetration, no more.
  SurfaceMesh before, after;
  std::string error;
  ASSERT_TRUE(ReadObj(dir_->File("free.obj"), &before, &error)) << error;
  ASSERT_TRUE(ReadObj(dir_->File("collided.obj"), &after, &error)) << error;
  ASSERT_EQ(before.vertices.cols(), after.vertices.cols());
  const double moved = (after.vertices - before.vertices).colwise().norm().maxCoeff();
  EXPECT_GT(moved, 0.5 * report.at("max_penetration_before"));
  EXPECT_LT(moved, 3.0 * report.at("max_penetration_before") + 0.02);
  EXPECT_TRUE(std::filesystem::exists(dir_->File("collided.vtu")));
  // The intersections' PLY is the surface with contact (it was the one before contact
  // whenever --output_before was given, until 2026-12-05).
  Eigen::Matrix3Xd colored;
  ASSERT_TRUE(ReadPointCloud(dir_->File("intersections.ply"), &colored, &error)) << error;
  ASSERT_EQ(colored.cols(), after.vertices.cols());
  EXPECT_LT((colored - after.vertices).cwiseAbs().maxCoeff(), 1e-5);
  EXPECT_GT((colored - before.vertices).cwiseAbs().maxCoeff(), 1e-2);

  // Bad input: a clear message and exit status 1.
  std::ofstream(dir_->File("bad_box.obj")) << "v 0 0 0\nf 1 2 3\n";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"--obstacles=" + dir_->File("missing.obj"), "missing.obj"},
      {"--obstacles=" + dir_->File("bad_box.obj"), "bad_box.obj"},
      {"--obstacles='" + dir_->File("box.obj") + " bone=jaw'", "no bone 'jaw'"},
      {"--obstacles='" + dir_->File("box.obj") + " colour=red'", "colour=red"},
      {"--contact_vertices=0:99999", "outside the surface"},
      {"--contact_vertices=5:2", "5:2"},
      {"--thickness=0", "thickness"},
      {"--max_depth=-1", "--max_depth must be finite and > 0"},
      {"--contact_rounds=0", "--contact_rounds must be"},
      {"--path_steps=-1", "--path_steps must be in [0, 256]"},
  };
  const std::string base = AppPath("aqs_collide") + " --model=" + dir_->File("model") +
                           " --pose=" + data_->model.poses[0].name + " --output=" +
                           dir_->File("o.obj") + " ";
  for (const auto& [flags, message] : cases) {
    const testing::CommandResult bad = RunCommand(base + flags);
    EXPECT_EQ(bad.exit_code, 1) << flags << "\n" << bad.output;
    EXPECT_NE(bad.output.find(message), std::string::npos) << flags << "\n" << bad.output;
  }
  const testing::CommandResult both = RunCommand(base + "--latent=z.txt");
  EXPECT_EQ(both.exit_code, 1);
  EXPECT_NE(both.output.find("either --latent"), std::string::npos) << both.output;
  const testing::CommandResult unknown = RunCommand(
      AppPath("aqs_collide") + " --model=" + dir_->File("model") + " --pose=nope --output=o.obj");
  EXPECT_EQ(unknown.exit_code, 1);
  EXPECT_NE(unknown.output.find("no training pose 'nope'"), std::string::npos) << unknown.output;
}

}  // namespace
}  // namespace aqs
