#include "model/model_io.h"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>

#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "learn/decoder.h"
#include "learn/grid_actuation_field.h"
#include "model/model_directory.h"
#include "model/model_fingerprint.h"
#include "prepare/volumetric_targets.h"
#include "testing/fault_kill.h"
#include "testing/file_contents.h"
#include "testing/synthetic_muscles.h"
#include "testing/temp_dir.h"
#include "train/pretrain.h"
#include "util/fault_injection.h"
#include "util/matrix_io.h"
#include "util/staged_directory.h"

namespace aqs {
namespace {

// Puts the copy `pristine` of a model directory back at `path`.
void RestoreCopy(const std::string& pristine, const std::string& path) {
  std::filesystem::remove_all(path);
  std::filesystem::copy(pristine, path, std::filesystem::copy_options::recursive);
}

// Copies the model directory `path` to `pristine` and returns what puts it back.
std::function<void()> KeepPristineCopy(const std::string& path, const std::string& pristine) {
  std::filesystem::copy(path, pristine, std::filesystem::copy_options::recursive);
  return [path, pristine]() { RestoreCopy(pristine, path); };
}

ActiveModel TrainedSyntheticModel() {
  testing::SyntheticMuscles data = testing::MakeSyntheticMuscles(3, 0, 0.3, 5);
  ActiveModel& model = data.model;
  std::ostringstream log;
  std::string error;
  EXPECT_TRUE(MakeVolumetricTargets(VolumetricTargetOptions(), &model, log, &error)) << error;
  // A bone on the free end, with a transform per pose, to cover bones in the files.
  Bone bone;
  bone.name = "tip";
  bone.vertices = {model.mesh.num_vertices() - 1};
  for (int p = 0; p < model.num_poses(); ++p) {
    RigidTransform t;
    t.translation = Eigen::Vector3d(0.01 * p, 0, 0);
    bone.pose_transforms.push_back(t);
  }
  model.bones.push_back(bone);
  PretrainOptions pretrain;
  pretrain.spec.latent_dim = 2;
  pretrain.spec.hidden_dims = {6};
  pretrain.field.node_spacing = 0.5;
  pretrain.max_iterations = 5;
  pretrain.log_every = 0;
  PretrainReport report;
  EXPECT_TRUE(Pretrain(pretrain, &model, &report, log, &error)) << error;
  model.states.assign(model.num_poses(), Eigen::Matrix3Xd());
  model.states[1] = model.mesh.vertices * 1.01;
  return data.model;
}

TEST(ModelIoTest, RoundTripIsExact) {
  const ActiveModel model = TrainedSyntheticModel();
  testing::TempDir dir;
  std::string error;
  const std::string path = dir.File("m");
  ASSERT_TRUE(SaveModel(path, model, &error)) << error;
  ASSERT_TRUE(SaveModel(path, model, &error)) << error;  // replaces an existing model
  ActiveModel back;
  ASSERT_TRUE(LoadModel(path, &back, &error)) << error;
  EXPECT_EQ(back.mesh.vertices, model.mesh.vertices);
  EXPECT_EQ(back.mesh.tets, model.mesh.tets);
  EXPECT_EQ(back.mu, model.mu);
  EXPECT_EQ(back.static_vertices, model.static_vertices);
  ASSERT_EQ(back.bones.size(), 1u);
  EXPECT_EQ(back.bones[0].name, "tip");
  EXPECT_EQ(back.bones[0].vertices, model.bones[0].vertices);
  EXPECT_EQ(back.bones[0].pose_transforms[2].translation, model.bones[0].pose_transforms[2].translation);
  EXPECT_EQ(back.embedding.element, model.embedding.element);
  EXPECT_EQ(back.embedding.weights, model.embedding.weights);
  EXPECT_EQ(back.embedding.offsets, model.embedding.offsets);
  ASSERT_EQ(back.num_poses(), model.num_poses());
  for (int p = 0; p < model.num_poses(); ++p) {
    EXPECT_EQ(back.poses[p].name, model.poses[p].name);
    EXPECT_EQ(back.poses[p].surface, model.poses[p].surface);
    EXPECT_EQ(back.poses[p].target, model.poses[p].target);
    EXPECT_EQ(back.poses[p].embedding_max_error, model.poses[p].embedding_max_error);
  }
  ASSERT_TRUE(back.decoder != nullptr);
  EXPECT_EQ(back.decoder_params, model.decoder_params);
  EXPECT_EQ(back.latents, model.latents);
  EXPECT_EQ(back.states[1], model.states[1]);
  EXPECT_EQ(back.states[0].cols(), 0);
  // Decoding gives the same actuation.
  ActuationMatrix a, b;
  DecoderWorkspace w;
  model.decoder->Decode(model.decoder_params.data(), model.latents.col(0), &a, &w);
  back.decoder->Decode(back.decoder_params.data(), back.latents.col(0), &b, &w);
  EXPECT_EQ(a, b);
  // No temporary directories or lock files are left behind.
  int entries = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir.path())) {
    (void)entry;
    ++entries;
  }
  EXPECT_EQ(entries, 1);
  EXPECT_EQ(ModelFormatVersion(path), 2);
  EXPECT_TRUE(std::filesystem::exists(path + "/learned/decoder.txt"));
  EXPECT_EQ(back.checkpoint.iterations, 0);
}

TEST(ModelIoTest, DamagedModelsFailNamingTheFile) {
  const ActiveModel model = TrainedSyntheticModel();
  testing::TempDir dir;
  std::string error;
  ActiveModel back;
  EXPECT_FALSE(LoadModel(dir.File("nothing"), &back, &error));
  EXPECT_NE(error.find("model.txt"), std::string::npos) << error;
  const std::string path = dir.File("m");
  ASSERT_TRUE(SaveModel(path, model, &error)) << error;
  std::filesystem::remove(path + "/poses/0001.bin");
  EXPECT_FALSE(LoadModel(path, &back, &error));
  EXPECT_NE(error.find("poses/0001.bin"), std::string::npos) << error;
  ASSERT_TRUE(SaveModel(path, model, &error)) << error;
  {
    std::ofstream out(path + "/embedding.txt", std::ios::app);
    out << "3 0.25 0.25 0.25 0.25 0 0 0 0\n";  // one line too many
  }
  EXPECT_FALSE(LoadModel(path, &back, &error));
  EXPECT_NE(error.find("embedding.txt:"), std::string::npos) << error;
  ASSERT_TRUE(SaveModel(path, model, &error)) << error;
  {
    std::ofstream out(path + "/fixed.txt", std::ios::app);
    out << "0 7\n";  // vertex 0 is fixed already
  }
  EXPECT_FALSE(LoadModel(path, &back, &error));
  EXPECT_NE(error.find("fixed.txt:12: vertex 0 is fixed again (first on line 2)"),
            std::string::npos)
      << error;
  ASSERT_TRUE(SaveModel(path, model, &error)) << error;
  {
    std::ofstream out(path + "/fixed.txt", std::ios::app);
    out << "1000000 7\n";
  }
  EXPECT_FALSE(LoadModel(path, &back, &error));
  EXPECT_NE(error.find("fixed.txt:12: expected '<vertex in [0, "), std::string::npos) << error;
  ASSERT_TRUE(SaveModel(path, model, &error)) << error;
  {
    // A vertex not fixed yet, with a bone that does not exist.
    std::istringstream lines(testing::ReadAll(path + "/fixed.txt"));
    std::set<int> listed;
    for (std::string line; std::getline(lines, line);) {
      if (!line.empty() && line[0] != '#') listed.insert(std::stoi(line));
    }
    int free_vertex = 0;
    while (listed.count(free_vertex)) ++free_vertex;
    std::ofstream out(path + "/fixed.txt", std::ios::app);
    out << free_vertex << " 7\n";
  }
  EXPECT_FALSE(LoadModel(path, &back, &error));
  EXPECT_NE(error.find("refers to bone 7"), std::string::npos) << error;
  ASSERT_TRUE(SaveModel(path, model, &error)) << error;
  {
    std::fstream out(path + "/mu.bin", std::ios::in | std::ios::out | std::ios::binary);
    out.seekp(24 + 8 * 3);  // after the header: element 3
    const double negative = -1.0;
    out.write(reinterpret_cast<const char*>(&negative), sizeof(negative));
  }
  EXPECT_FALSE(LoadModel(path, &back, &error));
  EXPECT_NE(error.find("mu.bin: the stiffness of element 3 is -1, not positive"),
            std::string::npos)
      << error;
  // A pose name with a ',' (it split the evaluation's CSV rows) and a negative embedding
  // error (it went into the error budget's tables) are refused at their line.
  ASSERT_TRUE(SaveModel(path, model, &error)) << error;
  const std::string poses = testing::ReadAll(path + "/poses.txt");
  const size_t name = poses.find(" " + model.poses[1].name + " ");
  ASSERT_NE(name, std::string::npos) << poses;
  std::string damaged = poses;
  damaged.replace(name + 1, model.poses[1].name.size(), "bend,x");
  std::ofstream(path + "/poses.txt", std::ios::trunc) << damaged;
  EXPECT_FALSE(LoadModel(path, &back, &error));
  EXPECT_NE(error.find("poses.txt:"), std::string::npos) << error;
  EXPECT_NE(error.find("pose name 'bend,x' contains ','"), std::string::npos) << error;
  damaged = poses;
  damaged.replace(name + 1 + model.poses[1].name.size() + 1, 0, "-");
  std::ofstream(path + "/poses.txt", std::ios::trunc) << damaged;
  EXPECT_FALSE(LoadModel(path, &back, &error));
  EXPECT_NE(error.find("the embedding errors must be finite distances >= 0"), std::string::npos)
      << error;
}

// Decoder sizes that would exhaust memory are refused at load, naming decoder.txt: a
// latent above kMaxLatentDim (a d x d prior), and layers whose parameter count wrapped
// around in 64 bits (widths of 2^31 - 1 passed for 970 parameters, then Forward threw
// bad_alloc inside LoadModel).
TEST(ModelIoTest, DecoderSizesThatWouldExhaustMemoryAreRefused) {
  const ActiveModel model = TrainedSyntheticModel();
  testing::TempDir dir;
  std::string error;
  const std::string path = dir.File("m");
  ASSERT_TRUE(SaveModel(path, model, &error)) << error;
  const std::string decoder = path + "/learned/decoder.txt";
  const std::string text = testing::ReadAll(decoder);
  auto with_line = [&](const std::string& key, const std::string& line) {
    const size_t start = text.find("\n" + key + " ") + 1;
    const size_t end = text.find('\n', start);
    std::ofstream(decoder, std::ios::trunc) << text.substr(0, start) + line + text.substr(end);
  };
  ActiveModel back;
  with_line("latent_dim", "latent_dim 100000");
  EXPECT_FALSE(LoadModel(path, &back, &error));
  EXPECT_NE(error.find("decoder.txt: latent_dim must be in [1, 4096] (is 100000)"),
            std::string::npos)
      << error;
  with_line("hidden_dims", "hidden_dims 5 2147483647 2147483647 2147483647 2147483647 2");
  EXPECT_FALSE(LoadModel(path, &back, &error));
  EXPECT_NE(error.find("the layer sizes need more than 2147483647 parameters"),
            std::string::npos)
      << error;
  std::ofstream(decoder, std::ios::trunc) << text;
  ASSERT_TRUE(LoadModel(path, &back, &error)) << error;
}

// A learned decoder in a model without training poses is refused at load (the
// evaluation and the training benchmark aborted on it). SaveModel never writes one: the
// files of a saved model are edited, as a damaged or hand-made model would be, with the
// checkpoint of a version before it named its model.
TEST(ModelIoTest, ALearnedStateWithoutTrainingPosesIsRefused) {
  const ActiveModel model = TrainedSyntheticModel();
  testing::TempDir dir;
  std::string error;
  const std::string path = dir.File("m");
  ASSERT_TRUE(SaveModel(path, model, &error)) << error;
  auto edit = [&](const std::string& file, const std::function<bool(const std::string&)>& keep,
                  const std::string& replace_from = "", const std::string& replace_to = "") {
    std::istringstream lines(testing::ReadAll(path + "/" + file));
    std::string kept;
    for (std::string line; std::getline(lines, line);) {
      if (!replace_from.empty() && line.rfind(replace_from, 0) == 0) line = replace_to;
      if (keep(line)) kept += line + "\n";
    }
    std::ofstream(path + "/" + file, std::ios::trunc) << kept;
  };
  edit("model.txt", [](const std::string&) { return true; }, "poses ", "poses 0");
  edit("poses.txt", [](const std::string& line) { return line.empty() || line[0] == '#'; });
  edit("bones.txt", [](const std::string& line) {
    return line.empty() || line[0] == '#' || line.rfind("bone ", 0) == 0;
  });
  edit("learned/checkpoint.txt",
       [](const std::string& line) { return line.rfind("model ", 0) != 0; });
  std::filesystem::remove_all(path + "/poses");
  std::filesystem::remove_all(path + "/targets");
  std::filesystem::remove_all(path + "/learned/states");
  ASSERT_TRUE(WriteMatrixFile(path + "/learned/latents.bin",
                              Eigen::MatrixXd(model.latent_dim(), 0), &error))
      << error;
  ActiveModel back;
  EXPECT_FALSE(LoadModel(path, &back, &error));
  EXPECT_NE(error.find("a learned decoder in a model without training poses"),
            std::string::npos)
      << error;
}

// Damage the other checks let through (review of lib/model): a file that lost a line
// against model.txt's counts, a repeated pose name, an embedding line that no longer
// gives the neutral back at rest, a neutral without faces.
TEST(ModelIoTest, CountsNamesEmbeddingAndFacesAreChecked) {
  const ActiveModel model = TrainedSyntheticModel();
  ASSERT_GE(model.num_poses(), 2);
  testing::TempDir dir;
  std::string error;
  ActiveModel back;
  const std::string path = dir.File("m");
  auto rewrite = [&](const std::string& file, const std::function<std::string(std::string)>& edit) {
    const std::string text = testing::ReadAll(path + "/" + file);
    std::ofstream(path + "/" + file) << edit(text);
  };
  auto last_line_removed = [](std::string text) {
    text.pop_back();  // the final newline
    return text.substr(0, text.rfind('\n') + 1);
  };
  // poses.txt without its last pose.
  ASSERT_TRUE(SaveModel(path, model, &error)) << error;
  rewrite("poses.txt", last_line_removed);
  EXPECT_FALSE(LoadModel(path, &back, &error));
  EXPECT_NE(error.find("model.txt says poses " + std::to_string(model.num_poses()) +
                       ", but " + path + "/poses.txt has " +
                       std::to_string(model.num_poses() - 1)),
            std::string::npos)
      << error;
  // A count that is not one.
  ASSERT_TRUE(SaveModel(path, model, &error)) << error;
  rewrite("model.txt", [](std::string text) { return text + "elements many\n"; });
  EXPECT_FALSE(LoadModel(path, &back, &error));
  EXPECT_NE(error.find("'elements' needs a count, not 'many'"), std::string::npos) << error;
  // The second pose named as the first.
  ASSERT_TRUE(SaveModel(path, model, &error)) << error;
  rewrite("poses.txt", [&](std::string text) {
    const std::string second = " " + model.poses[1].name + " ";
    text.replace(text.find(second), second.size(), " " + model.poses[0].name + " ");
    return text;
  });
  EXPECT_FALSE(LoadModel(path, &back, &error));
  EXPECT_NE(error.find("pose '" + model.poses[0].name + "' again (first on line"),
            std::string::npos)
      << error;
  // The first embedding line moved to another element (its weights still barycentric).
  ASSERT_TRUE(SaveModel(path, model, &error)) << error;
  int first_line = 0;
  rewrite("embedding.txt", [&](std::string text) {
    size_t at = 0;
    for (int line = 1;; ++line) {
      if (text[at] != '#') {
        first_line = line;
        break;
      }
      at = text.find('\n', at) + 1;
    }
    const size_t space = text.find(' ', at);
    const int element = std::stoi(text.substr(at, space - at));
    const int other = (element + model.mesh.num_tets() / 2) % model.mesh.num_tets();
    return text.substr(0, at) + std::to_string(other) + text.substr(space);
  });
  EXPECT_FALSE(LoadModel(path, &back, &error));
  EXPECT_NE(error.find("embedding.txt:" + std::to_string(first_line) +
                       ": surface vertex 0 is embedded "),
            std::string::npos)
      << error;
  EXPECT_EQ(error.find("learned"), std::string::npos) << "not blamed on the learned state";
  // A neutral without faces.
  ASSERT_TRUE(SaveModel(path, model, &error)) << error;
  rewrite("neutral.obj", [](const std::string& text) {
    std::istringstream lines(text);
    std::string kept;
    for (std::string line; std::getline(lines, line);) {
      if (line.rfind("f ", 0) != 0) kept += line + "\n";
    }
    return kept;
  });
  EXPECT_FALSE(LoadModel(path, &back, &error));
  EXPECT_NE(error.find("neutral.obj has no faces"), std::string::npos) << error;
  // Intact, it loads.
  ASSERT_TRUE(SaveModel(path, model, &error)) << error;
  EXPECT_TRUE(LoadModel(path, &back, &error)) << error;
}

// A bones.txt whose first line is a motion (no bone yet) is refused naming its line (it
// indexed bone -1).
TEST(ModelIoTest, AMotionBeforeAnyBoneFailsNamingTheLine) {
  const ActiveModel model = TrainedSyntheticModel();
  testing::TempDir dir;
  const std::string path = dir.File("m");
  std::string error;
  ActiveModel back;
  ASSERT_TRUE(SaveModel(path, model, &error)) << error;
  {
    std::ofstream out(path + "/bones.txt", std::ios::trunc);
    out << "-1 0 1 0 0 0 1 0 0 0 1 0 0 0\n";
  }
  EXPECT_FALSE(LoadModel(path, &back, &error));
  EXPECT_NE(error.find("bones.txt:1: expected '<bone> <pose>"), std::string::npos) << error;
}

// A model whose fixed.txt is empty or a directory, or whose binary files hold a NaN, is
// refused at load, naming the file (it used to load as a free body, or to fail later
// without a file name).
TEST(ModelIoTest, EmptyFixedSetsAndNonFiniteNumbersFailNamingTheFile) {
  const ActiveModel model = TrainedSyntheticModel();
  testing::TempDir dir;
  std::string error;
  ActiveModel back;
  const std::string path = dir.File("m");
  ASSERT_TRUE(SaveModel(path, model, &error)) << error;
  const std::function<void()> restore = KeepPristineCopy(path, dir.File("pristine"));
  { std::ofstream(path + "/fixed.txt") << "# vertex bone\n"; }
  EXPECT_FALSE(LoadModel(path, &back, &error));
  EXPECT_NE(error.find(path + "/fixed.txt: lists no fixed vertices"), std::string::npos) << error;
  restore();
  std::filesystem::remove(path + "/fixed.txt");
  std::filesystem::create_directories(path + "/fixed.txt");
  EXPECT_FALSE(LoadModel(path, &back, &error));
  EXPECT_NE(error.find(path + "/fixed.txt: is a directory"), std::string::npos) << error;
  // A NaN written over an entry of each binary file.
  for (const std::string file : {"learned/latents.bin", "learned/states/0001.bin",
                                 "poses/0002.bin", "targets/0000.bin", "mu.bin"}) {
    restore();
    {
      std::fstream out(path + "/" + file, std::ios::in | std::ios::out | std::ios::binary);
      out.seekp(24 + 8);  // the second entry, after the 24-byte header
      const double nan = std::nan("");
      out.write(reinterpret_cast<const char*>(&nan), sizeof(nan));
    }
    EXPECT_FALSE(LoadModel(path, &back, &error)) << file;
    EXPECT_NE(error.find(path + "/" + file + ": entry"), std::string::npos) << error;
    EXPECT_NE(error.find("is not finite (nan)"), std::string::npos) << error;
  }
  restore();
  EXPECT_TRUE(LoadModel(path, &back, &error)) << error;
}

// Rewrites the lines of `path` that start with `prefix` (and a space) by `lines`, in
// place of the first of them.
void ReplaceLines(const std::string& path, const std::string& prefix,
                  const std::vector<std::string>& lines) {
  std::istringstream in(testing::ReadAll(path));
  std::string text, line;
  bool replaced = false;
  while (std::getline(in, line)) {
    if (line.rfind(prefix + " ", 0) != 0) {
      text += line + "\n";
    } else if (!replaced) {
      for (const std::string& l : lines) text += l + "\n";
      replaced = true;
    }
  }
  ASSERT_TRUE(replaced) << path << " has no line starting with " << prefix;
  std::ofstream(path, std::ios::trunc) << text;
}

// Values that are finite but absurd, which the loader took until 2026-12-08: a bone moved
// a million units (simulating it ran for minutes to a dragged face), targets of S = 0 or
// 1e300 (pre-training trained on them), a prior covariance that is nearly singular (fits
// pinned to a line). Each is refused naming the file; an inverted element's exact target
// (a negative eigenvalue) is not absurd and loads.
TEST(ModelIoTest, AbsurdButFiniteBonesTargetsAndPriorsAreRefusedNamingTheFile) {
  const ActiveModel model = TrainedSyntheticModel();
  testing::TempDir dir;
  std::string error;
  ActiveModel back;
  const std::string path = dir.File("m");
  ASSERT_TRUE(SaveModel(path, model, &error)) << error;
  const std::function<void()> restore = KeepPristineCopy(path, dir.File("pristine"));
  // Pose 2 of bone 0 ("tip", a translation of 0.02 along x) moved 1e6 along x, then
  // 0.003, which is no absurd motion.
  ReplaceLines(path + "/bones.txt", "0 2", {"0 2 1 0 0 0 1 0 0 0 1 1e6 0 0"});
  EXPECT_FALSE(LoadModel(path, &back, &error));
  EXPECT_NE(error.find(path + "/bones.txt:"), std::string::npos) << error;
  EXPECT_NE(error.find("the motion of bone 'tip' in pose 2 moves the neutral's centre by 1e+06"),
            std::string::npos)
      << error;
  restore();
  // (Bones are part of the model's fingerprint: the learned state is then another model's.)
  ReplaceLines(path + "/bones.txt", "0 2", {"0 2 1 0 0 0 1 0 0 0 1 0.003 0 0"});
  EXPECT_FALSE(LoadModel(path, &back, &error));
  EXPECT_EQ(error.find("moves the neutral's centre"), std::string::npos) << error;

  // A target file's numbers after its 24-byte header (6 x elements, column by column).
  const int elements = model.mesh.num_tets();
  auto write_target = [&](const std::vector<double>& first_columns, double rest) {
    std::vector<double> values(6 * elements, rest);
    std::copy(first_columns.begin(), first_columns.end(), values.begin());
    std::fstream out(path + "/targets/0001.bin", std::ios::in | std::ios::out | std::ios::binary);
    out.seekp(24);
    out.write(reinterpret_cast<const char*>(values.data()),
              static_cast<std::streamsize>(values.size() * sizeof(double)));
  };
  for (const double absurd : {0.0, 1e300}) {
    restore();
    write_target({}, absurd);
    EXPECT_FALSE(LoadModel(path, &back, &error)) << absurd;
    EXPECT_EQ(error.rfind(path + "/targets/0001.bin: " + std::to_string(elements) + " of " +
                              std::to_string(elements) + " targets have their largest",
                          0),
              0u)
        << error;
  }
  restore();
  write_target({1, 1, -0.5, 0, 0, 0}, 0.0);  // one element's, the rest S = 0
  EXPECT_FALSE(LoadModel(path, &back, &error));
  EXPECT_NE(error.find(std::to_string(elements - 1) + " of " + std::to_string(elements) +
                       " targets have their largest principal stretch (in magnitude) outside "
                       "[0.001, 1000]; the first, element 1,"),
            std::string::npos)
      << error;
  restore();
  write_target({1, 1, -0.5, 0, 0, 0, 1e-4, 0.5, 2, 0, 0, 0}, 1.0);  // inverted; one flat axis
  EXPECT_TRUE(LoadModel(path, &back, &error)) << error;

  // The latent prior (latent_dim 2) and the bone's: variances 1 and 0.01 on the diagonal,
  // but correlated to within 1e-15.
  const std::string prior = path + "/learned/prior.txt";
  restore();
  ReplaceLines(prior, "latent_covariance",
               {"latent_covariance 0 1 1", "latent_covariance 1 1 1.000000000000001"});
  EXPECT_FALSE(LoadModel(path, &back, &error));
  EXPECT_NE(error.find("prior.txt: the latent covariance is nearly singular"), std::string::npos)
      << error;
  restore();
  std::vector<std::string> bone_rows;
  for (int i = 0; i < 6; ++i) {
    std::string row = "bone tip covariance " + std::to_string(i);
    for (int j = 0; j < 6; ++j) row += i == j ? " 0.0100000000000001" : " 0.01";
    bone_rows.push_back(row);
  }
  ReplaceLines(prior, "bone tip covariance", bone_rows);
  EXPECT_FALSE(LoadModel(path, &back, &error));
  EXPECT_NE(error.find("prior.txt: the covariance of bone 'tip' is nearly singular"),
            std::string::npos)
      << error;
  restore();
  EXPECT_TRUE(LoadModel(path, &back, &error)) << error;
}

namespace fs = std::filesystem;

std::set<std::string> Entries(const std::string& dir) {
  std::set<std::string> names;
  for (const auto& entry : fs::directory_iterator(dir)) names.insert(entry.path().filename());
  return names;
}

using testing::ReadAll;

// Every file below `dir`, relative to it.
std::set<std::string> FilesBelow(const std::string& dir) {
  std::set<std::string> names;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    names.insert(fs::relative(entry.path(), dir).string());
  }
  return names;
}

// `model` with every learned number changed, a checkpoint, and another stiffness.
ActiveModel Changed(const ActiveModel& model) {
  ActiveModel changed = model;
  changed.decoder_params.array() += 0.5;
  changed.latents *= 2.0;
  changed.states[1] *= 1.5;
  changed.states[2] = model.mesh.vertices;
  changed.checkpoint.iterations = 7;
  changed.checkpoint.loss = 0.25;
  changed.mu *= 2.0;
  return changed;
}

// Which of `a` and `b` the loaded model `m` is: "a", "b" or "mixed" (each part compared
// on its own).
std::string WhichOf(const ActiveModel& m, const ActiveModel& a, const ActiveModel& b,
                    bool static_part) {
  std::set<std::string> parts;
  const auto part = [&](bool is_a, bool is_b) { parts.insert(is_a ? "a" : is_b ? "b" : "neither"); };
  part(m.decoder_params == a.decoder_params, m.decoder_params == b.decoder_params);
  part(m.latents == a.latents, m.latents == b.latents);
  part(m.states.size() == a.states.size() && m.states[1] == a.states[1] && m.states[2].cols() == a.states[2].cols(),
       m.states.size() == b.states.size() && m.states[1] == b.states[1] && m.states[2] == b.states[2]);
  part(m.checkpoint.iterations == a.checkpoint.iterations,
       m.checkpoint.iterations == b.checkpoint.iterations &&
           m.checkpoint.loss == b.checkpoint.loss);
  if (static_part) part(m.mu == a.mu, m.mu == b.mu);
  return parts.size() == 1 ? *parts.begin() : "mixed";
}

// Replaces `path` by a copy of `pristine` (faster than saving: no fsync).
// Takes and releases the model's lock, which cleans up after killed writers.
void CleanUp(const std::string& path) {
  PathLock lock;
  std::string error;
  std::ostringstream log;
  ASSERT_TRUE(LockModelForWriting(path, &log, &lock, &error)) << error;
}

TEST(ModelIoTest, OnlyModelsEmptyDirectoriesAndMissingPathsAreReplaced) {
  const ActiveModel model = TrainedSyntheticModel();
  testing::TempDir dir;
  std::string error;
  // A folder that is not a model: refused, nothing deleted.
  const std::string folder = dir.File("folder");
  fs::create_directories(folder + "/sub");
  dir.Write("folder/notes.txt", "my notes");
  EXPECT_FALSE(SaveModel(folder, model, &error));
  EXPECT_NE(error.find(folder + " is a directory that is not an ActiveQS model"),
            std::string::npos) << error;
  EXPECT_EQ(Entries(folder), std::set<std::string>({"notes.txt", "sub"}));
  // A plain file: refused, unchanged.
  const std::string file = dir.Write("file", "data");
  EXPECT_FALSE(SaveModel(file, model, &error));
  EXPECT_NE(error.find(file + " exists and is not an ActiveQS model directory"),
            std::string::npos) << error;
  EXPECT_EQ(ReadAll(file), "data");
  // An empty folder and a missing path (with missing parents) are written.
  fs::create_directories(dir.File("empty"));
  ASSERT_TRUE(SaveModel(dir.File("empty"), model, &error)) << error;
  ASSERT_TRUE(SaveModel(dir.File("a/b/m"), model, &error)) << error;
  // With overwrite, anything is replaced.
  SaveModelOptions overwrite;
  overwrite.overwrite = true;
  ASSERT_TRUE(SaveModel(folder, model, overwrite, &error)) << error;
  ASSERT_TRUE(SaveModel(file, model, overwrite, &error)) << error;
  ActiveModel back;
  EXPECT_TRUE(LoadModel(folder, &back, &error)) << error;
  EXPECT_TRUE(LoadModel(file, &back, &error)) << error;
  EXPECT_EQ(Entries(dir.path()), std::set<std::string>({"a", "empty", "file", "folder"}));
  // A model with files of the user's in it: replacing it would delete them.
  dir.Write("folder/notes.txt", "my notes");
  EXPECT_FALSE(SaveModel(folder, model, &error));
  EXPECT_NE(error.find("holds files that are not part of an ActiveQS model (notes.txt)"),
            std::string::npos) << error;
  fs::remove(folder + "/notes.txt");
  dir.Write("folder/learned/plot.png", "png");
  EXPECT_FALSE(SaveLearnedState(folder, model, &error));
  EXPECT_NE(error.find("learned/plot.png"), std::string::npos) << error;
  EXPECT_FALSE(SaveModel(folder, model, &error));
  EXPECT_EQ(ReadAll(folder + "/learned/plot.png"), "png");
  ASSERT_TRUE(SaveModel(folder, model, overwrite, &error)) << error;
  EXPECT_FALSE(fs::exists(folder + "/learned/plot.png"));
  // Through a symbolic link, the link's target is replaced and the link stays.
  fs::create_directory_symlink(folder, dir.File("link"));
  ASSERT_TRUE(SaveModel(dir.File("link/"), model, &error)) << error;
  EXPECT_TRUE(fs::is_symlink(dir.File("link")));
  EXPECT_TRUE(LoadModel(dir.File("link"), &back, &error)) << error;
  EXPECT_EQ(Entries(dir.path()), std::set<std::string>({"a", "empty", "file", "folder", "link"}));
}

// kill -9 at every step of SaveModel over an existing model: the path always holds the
// old or the new model, complete; the next writer's cleanup leaves nothing else.
TEST(ModelIoTest, KillAtEveryStepOfSaveModelLeavesTheOldOrTheNewModel) {
  const ActiveModel a = TrainedSyntheticModel();
  const ActiveModel b = Changed(a);
  for (bool exchange : {true, false}) {
    testing::TempDir dir;
    const std::string path = dir.File("m");
    std::string error;
    ASSERT_TRUE(SaveModel(path, b, &error)) << error;
    const std::set<std::string> files_b = FilesBelow(path);
    ASSERT_TRUE(SaveModel(path, a, &error)) << error;
    ASSERT_TRUE(SaveModel(dir.File("pristine"), a, &error)) << error;
    const std::set<std::string> files_a = FilesBelow(path);
    const auto save = [&] {
      DisableExchangeForTesting(!exchange);
      std::string e;
      return SaveModel(path, b, &e);
    };
    const std::vector<std::string> points = testing::FaultPointsOf([&] { save(); });
    DisableExchangeForTesting(false);
    ASSERT_GT(points.size(), 30u);
    std::printf("SaveModel of the test model: %zu fault points\n", points.size());
    std::set<std::string> seen;
    for (int n = 0; n < static_cast<int>(points.size()); ++n) {
      // The steps of writing files into the staging directory (38 here) are alike, and
      // so are those of removing entries of the old model (11): every seventh of them
      // is enough; without exchange only putting the model in place differs.
      const bool file_step = points[n].rfind("atomic_file:", 0) == 0;
      if ((file_step || points[n] == "remove:entry") && (n % 7 != 0 || (file_step && !exchange))) {
        continue;
      }
      SCOPED_TRACE("exchange " + std::to_string(exchange) + ", killed at " + std::to_string(n) +
                   " " + points[n]);
      RestoreCopy(dir.File("pristine"), path);
      ASSERT_EQ(testing::RunInChildKilledAt(n, save), "killed");
      ActiveModel back;
      if (exchange) {  // no instant without a model
        ASSERT_TRUE(LoadModel(path, &back, &error)) << error;
        const std::string which = WhichOf(back, a, b, true);
        EXPECT_NE(which, "mixed");
      }
      CleanUp(path);
      ASSERT_TRUE(LoadModel(path, &back, &error)) << error;
      const std::string which = WhichOf(back, a, b, true);
      EXPECT_NE(which, "mixed");
      seen.insert(which);
      EXPECT_EQ(Entries(dir.path()), std::set<std::string>({"m", "pristine"}));
      EXPECT_EQ(FilesBelow(path), which == "a" ? files_a : files_b);
    }
    EXPECT_EQ(seen, std::set<std::string>({"a", "b"}));
  }
}

// kill -9 at every step of a training checkpoint: the learned state is the old or the
// new one as a whole (decoder, latents, states and checkpoint together).
TEST(ModelIoTest, KillAtEveryStepOfACheckpointLeavesOneWholeLearnedState) {
  const ActiveModel a = TrainedSyntheticModel();
  ActiveModel b = Changed(a);
  b.mu = a.mu;
  for (bool exchange : {true, false}) {
    testing::TempDir dir;
    const std::string path = dir.File("m");
    std::string error;
    ASSERT_TRUE(SaveModel(path, a, &error)) << error;
    ASSERT_TRUE(SaveModel(dir.File("pristine"), a, &error)) << error;
    const auto save = [&] {
      DisableExchangeForTesting(!exchange);
      std::string e;
      return SaveLearnedState(path, b, &e);
    };
    const std::vector<std::string> points = testing::FaultPointsOf([&] { save(); });
    DisableExchangeForTesting(false);
    ASSERT_GT(points.size(), 10u);
    std::set<std::string> seen;
    for (int n = 0; n < static_cast<int>(points.size()); ++n) {
      const bool file_step = points[n].rfind("atomic_file:", 0) == 0;
      if ((file_step || points[n] == "remove:entry") && (n % 3 != 0 || (file_step && !exchange))) {
        continue;
      }
      SCOPED_TRACE("exchange " + std::to_string(exchange) + ", killed at " + std::to_string(n) +
                   " " + points[n]);
      RestoreCopy(dir.File("pristine"), path);
      const std::set<std::string> files_a = FilesBelow(path);
      ASSERT_EQ(testing::RunInChildKilledAt(n, save), "killed");
      ActiveModel back;
      if (exchange) {
        ASSERT_TRUE(LoadModel(path, &back, &error)) << error;
        EXPECT_NE(WhichOf(back, a, b, false), "mixed");
      }
      CleanUp(path);
      ASSERT_TRUE(LoadModel(path, &back, &error)) << error;
      const std::string which = WhichOf(back, a, b, false);
      EXPECT_NE(which, "mixed");
      seen.insert(which);
      EXPECT_EQ(Entries(dir.path()), std::set<std::string>({"m", "pristine"}));
      if (which == "a") {
        EXPECT_EQ(FilesBelow(path), files_a);
      }
    }
    EXPECT_EQ(seen, std::set<std::string>({"a", "b"}));
  }
}

// Two checkpoints while a reader is between the unit's decoder and its latents: on ext4
// the second checkpoint's directory usually gets the first one's inode back, which the
// reader's identity check took for the unit it began with. It must read one unit whole.
struct SwapsDuringRead {
  std::string path;
  std::vector<const ActiveModel*> saves;
  bool done = false;
};
SwapsDuringRead g_swaps;

void SaveTwiceDuringRead(const char* point) {
  if (g_swaps.done || std::string(point) != "model_io:decoder_read") return;
  g_swaps.done = true;  // before saving: the saves' own fault points come here too
  for (const ActiveModel* model : g_swaps.saves) {
    std::string error;
    EXPECT_TRUE(SaveLearnedState(g_swaps.path, *model, &error)) << error;
  }
}

TEST(ModelIoTest, AReadSpanningTwoCheckpointsReadsOneUnitWhole) {
  const ActiveModel a = TrainedSyntheticModel();
  ActiveModel b = Changed(a), c = Changed(b);
  b.mu = c.mu = a.mu;
  c.checkpoint.iterations = 9;
  testing::TempDir dir;
  const std::string path = dir.File("m");
  std::string error;
  ASSERT_TRUE(SaveModel(path, a, &error)) << error;
  for (int round = 0; round < 3; ++round) {
    SCOPED_TRACE("round " + std::to_string(round));
    ASSERT_TRUE(SaveLearnedState(path, a, &error)) << error;
    g_swaps = {path, {&b, &c}, false};
    const FaultHook previous = SetFaultHookForTesting(&SaveTwiceDuringRead);
    ActiveModel back;
    const bool loaded = LoadModel(path, &back, &error);
    SetFaultHookForTesting(previous);
    ASSERT_TRUE(g_swaps.done);
    ASSERT_TRUE(loaded) << error;
    EXPECT_EQ(WhichOf(back, c, b, false), "a") << "the unit installed after the read began";
  }
}

TEST(ModelIoTest, DamagedCheckpointFailsNamingTheFile) {
  const ActiveModel model = TrainedSyntheticModel();
  testing::TempDir dir;
  const std::string path = dir.File("m");
  std::string error;
  ASSERT_TRUE(SaveModel(path, model, &error)) << error;
  ActiveModel back;
  for (const char* content : {"", "# nothing\n", "iterations\n", "iterations -3\n",
                              "iterations 4\nloss x\n", "iterations 4\nlatent_refit_at -1\n",
                              "iterations 4\nloss_weights latent 0.001 energy nan decoder 0\n",
                              "iterations 4\nloss_weights latent 0.001 energy 0\n",
                              "iterations 4\nloss_weights latent -1 energy 0 decoder 0\n"}) {
    std::ofstream(path + "/learned/checkpoint.txt") << content;
    EXPECT_FALSE(LoadModel(path, &back, &error)) << content;
    EXPECT_NE(error.find(path + "/learned/checkpoint.txt"), std::string::npos) << error;
  }
  std::ofstream(path + "/learned/checkpoint.txt") << "iterations 4\nloss 0.5\n";
  ASSERT_TRUE(LoadModel(path, &back, &error)) << error;
  EXPECT_EQ(back.checkpoint.iterations, 4);
  EXPECT_EQ(back.checkpoint.loss, 0.5);
  std::ofstream(path + "/learned/checkpoint.txt")
      << "iterations 4\nloss 0.5\nlatent_refit_at 2\nloss_weights latent 0.001 energy 0.1 "
         "decoder 0\n";
  ASSERT_TRUE(LoadModel(path, &back, &error)) << error;
  EXPECT_EQ(back.checkpoint.latent_refit_at, 2);
  EXPECT_EQ(back.checkpoint.loss_weights, "latent 0.001 energy 0.1 decoder 0");
}

// The learned state's fingerprint and the targets' key survive saving and loading; the
// fingerprint changes with any learned number (not with the training counters), the
// model's own fingerprint does not.
TEST(ModelIoTest, LearnedStateFingerprintAndTargetKeyRoundTrip) {
  ActiveModel model = TrainedSyntheticModel();
  model.target_key = "0123456789abcdef";
  testing::TempDir dir;
  std::string error;
  ASSERT_TRUE(SaveModel(dir.File("a"), model, &error)) << error;
  EXPECT_NE(ReadAll(dir.File("a/model.txt")).find("\ntargets 0123456789abcdef\n"),
            std::string::npos);
  ActiveModel back;
  ASSERT_TRUE(LoadModel(dir.File("a"), &back, &error)) << error;
  EXPECT_EQ(back.target_key, model.target_key);
  // (The model in memory has no fit prior yet: saving learns it.)
  const uint64_t learned = LearnedStateFingerprint(back);
  EXPECT_NE(LearnedStateFingerprint(model), learned);
  model = back;
  ASSERT_TRUE(SaveModel(dir.File("b"), model, &error)) << error;
  ASSERT_TRUE(LoadModel(dir.File("b"), &back, &error)) << error;
  EXPECT_EQ(LearnedStateFingerprint(back), learned);
  back.checkpoint.iterations += 3;
  EXPECT_EQ(LearnedStateFingerprint(back), learned);
  ActiveModel other = model;
  other.decoder_params[0] += 1e-12;
  EXPECT_NE(LearnedStateFingerprint(other), learned);
  EXPECT_EQ(ModelFingerprint(other), ModelFingerprint(model));
  other = model;
  other.latents(0, 1) += 1e-12;
  EXPECT_NE(LearnedStateFingerprint(other), learned);
  other = model;
  other.fit_prior.latent.mean[0] += 1e-12;
  EXPECT_NE(LearnedStateFingerprint(other), learned);
  // The control grid's spacing, changed within what keeps its node set (the decoded
  // actuations change; the fingerprint did not).
  {
    GridFieldDescription grid = model.decoder->field().description();
    ASSERT_FALSE(grid.per_element);
    grid.spacing *= 1.0 + 1e-9;
    GridActuationField field;
    ASSERT_TRUE(GridActuationField::FromDescription(model.mesh, grid, "test", &field, &error))
        << error;
    other = model;
    other.decoder = std::make_shared<ActuationDecoder>(model.decoder->spec(), field);
    EXPECT_NE(DecoderArchitectureFingerprint(other), DecoderArchitectureFingerprint(model));
    EXPECT_NE(LearnedStateFingerprint(other), learned);
  }
  other = model;
  ASSERT_EQ(other.states.size(), 3u);
  ASSERT_EQ(other.states[1].cols(), model.mesh.num_vertices());  // the one stored state
  other.states[1](2, 0) += 1e-12;
  EXPECT_NE(LearnedStateFingerprint(other), learned);
  // Without a key (unconverged targets, or an older model): none is written or read.
  model.target_key.clear();
  ASSERT_TRUE(SaveModel(dir.File("a"), model, &error)) << error;
  EXPECT_EQ(ReadAll(dir.File("a/model.txt")).find("targets"), std::string::npos);
  ASSERT_TRUE(LoadModel(dir.File("a"), &back, &error)) << error;
  EXPECT_TRUE(back.target_key.empty());
}

// The checkpoint names the fingerprint of the model its learned state belongs to: the
// fingerprint survives saving and loading, a learned/ copied from another model (same
// mesh, other poses) is refused naming the file, and a checkpoint without the line (an
// older version's) is accepted.
TEST(ModelIoTest, LearnedStateOfAnotherModelIsRefused) {
  const ActiveModel model = TrainedSyntheticModel();
  testing::TempDir dir;
  std::string error;
  ASSERT_TRUE(SaveModel(dir.File("a"), model, &error)) << error;
  const std::string checkpoint = ReadAll(dir.File("a/learned/checkpoint.txt"));
  EXPECT_NE(checkpoint.find("model " + FingerprintText(ModelFingerprint(model)) + "\n"),
            std::string::npos) << checkpoint;
  ActiveModel back;
  ASSERT_TRUE(LoadModel(dir.File("a"), &back, &error)) << error;
  EXPECT_EQ(ModelFingerprint(back), ModelFingerprint(model));
  // Another model: the same bar and decoder, one pose moved by 1e-9.
  ActiveModel other = model;
  other.poses[2].surface(1, 7) += 1e-9;
  EXPECT_NE(ModelFingerprint(other), ModelFingerprint(model));
  ASSERT_TRUE(SaveModel(dir.File("b"), other, &error)) << error;
  fs::remove_all(dir.File("a/learned"));
  fs::copy(dir.File("b/learned"), dir.File("a/learned"), fs::copy_options::recursive);
  EXPECT_FALSE(LoadModel(dir.File("a"), &back, &error));
  EXPECT_NE(error.find(dir.File("a/learned/checkpoint.txt") +
                       ": the learned state belongs to another model (made for model " +
                       FingerprintText(ModelFingerprint(other)) + "; this directory's mesh, "
                       "poses and embedding are model " +
                       FingerprintText(ModelFingerprint(model)) + ")"),
            std::string::npos) << error;
  // Without the fingerprint line, as written before it existed: loaded.
  std::ofstream(dir.File("a/learned/checkpoint.txt")) << "iterations 2\nloss 0.5\n";
  ASSERT_TRUE(LoadModel(dir.File("a"), &back, &error)) << error;
  std::ofstream(dir.File("a/learned/checkpoint.txt")) << "iterations 2\nmodel xyz\n";
  EXPECT_FALSE(LoadModel(dir.File("a"), &back, &error));
  EXPECT_NE(error.find("'model F' (F: 16 hexadecimal digits)"), std::string::npos) << error;
}

// Format 1 (learned files at the top, train/checkpoint.txt) is read, and the first
// checkpoint rewrites the model as format 2, keeping the training log and the
// pre-training record.
// Where learned/ is missing and a writer's moved-aside learned.aqs-old<pid> is there (a
// writer without an atomic exchange, killed between its two renames, or a read between
// them), the model is not read as one never pre-trained: the error says what happened.
TEST(ModelIoTest, ALearnedFolderMovedAsideIsNotANewModel) {
  const ActiveModel model = TrainedSyntheticModel();
  testing::TempDir dir;
  const std::string path = dir.File("m");
  std::string error;
  ASSERT_TRUE(SaveModel(path, model, &error)) << error;
  fs::rename(path + "/learned", path + "/learned.aqs-old12345");
  ActiveModel back;
  EXPECT_FALSE(LoadModel(path, &back, &error));
  EXPECT_NE(error.find(path + "/learned is missing and " + path +
                       "/learned.aqs-old12345 is there: a writer was interrupted"),
            std::string::npos)
      << error;
}

TEST(ModelIoTest, FormatOneIsReadAndUpgradedByACheckpoint) {
  const ActiveModel model = TrainedSyntheticModel();
  testing::TempDir dir;
  const std::string path = dir.File("m");
  std::string error;
  ASSERT_TRUE(SaveModel(path, model, &error)) << error;
  for (const char* name : {"decoder.txt", "latents.bin", "states"}) {
    fs::rename(path + "/learned/" + std::string(name), path + "/" + std::string(name));
  }
  fs::remove_all(path + "/learned");
  fs::create_directories(path + "/train");
  std::ofstream(path + "/train/checkpoint.txt") << "# end-to-end training checkpoint\n"
                                                   "iterations 3\nloss 0.0123457\n";
  std::ofstream(path + "/train/log.csv") << "iteration,loss\n0,1\n1,0.5\n";
  fs::create_directories(path + "/pretrain");
  std::ofstream(path + "/pretrain/surface_errors.txt") << "record\n";
  // The record that says the pre-training is whole: kept too (without it the pipeline
  // pre-trained the upgraded model again).
  std::ofstream(path + "/pretrain/key.txt") << "pretrain record\n";
  std::string manifest = ReadAll(path + "/model.txt");
  manifest.replace(manifest.find("format 2"), 8, "format 1");
  std::ofstream(path + "/model.txt") << manifest;
  ActiveModel back;
  ASSERT_TRUE(LoadModel(path, &back, &error)) << error;
  EXPECT_EQ(back.decoder_params, model.decoder_params);
  EXPECT_EQ(back.states[1], model.states[1]);
  EXPECT_EQ(back.checkpoint.iterations, 3);
  back.checkpoint.iterations = 4;
  ASSERT_TRUE(SaveLearnedState(path, back, &error)) << error;
  EXPECT_EQ(ModelFormatVersion(path), 2);
  EXPECT_EQ(ReadAll(path + "/train/log.csv"), "iteration,loss\n0,1\n1,0.5\n");
  EXPECT_EQ(ReadAll(path + "/pretrain/surface_errors.txt"), "record\n");
  EXPECT_EQ(ReadAll(path + "/pretrain/key.txt"), "pretrain record\n");
  EXPECT_FALSE(fs::exists(path + "/decoder.txt"));
  ActiveModel upgraded;
  ASSERT_TRUE(LoadModel(path, &upgraded, &error)) << error;
  EXPECT_EQ(upgraded.decoder_params, model.decoder_params);
  EXPECT_EQ(upgraded.checkpoint.iterations, 4);
}

// What earlier versions and killed writers left: a model moved aside is recovered,
// temporary files of model files are removed, everything else is kept.
TEST(ModelIoTest, CleanupRecoversAndRemovesOnlyActiveQsLeftovers) {
  const ActiveModel model = TrainedSyntheticModel();
  testing::TempDir dir;
  const std::string path = dir.File("m");
  const std::string dead = std::to_string(testing::DeadPid());
  std::string error;
  // Before format 2: the old model moved aside and the new one half written.
  ASSERT_TRUE(SaveModel(dir.File("m.old" + dead), model, &error)) << error;
  fs::create_directories(dir.File("m.tmp" + dead));
  dir.Write("m.tmp" + dead + "/model.txt", "format 1\n");
  CleanUp(path);
  ActiveModel back;
  ASSERT_TRUE(LoadModel(path, &back, &error)) << error;
  EXPECT_EQ(Entries(dir.path()), std::set<std::string>({"m", "m.tmp" + dead}));
  // Temporary files of model files (14 MB each for the face) are removed; a file that
  // is not a model file is kept even with such a name; so is one of a live process.
  const std::string live = std::to_string(static_cast<long>(getppid()));
  for (const std::string& name : {"learned/decoder.txt.tmp" + dead, "decoder.txt.tmp" + dead,
                                  "learned/states/0001.bin.tmp" + dead, "poses/0000.bin.tmp" + dead,
                                  "train/log.csv.tmp" + dead, "model.txt.tmp" + dead,
                                  "pretrain/surface_errors.bin.tmp" + dead,
                                  "notes.txt.tmp" + dead, "mu.bin.tmp" + live}) {
    fs::create_directories(fs::path(path + "/" + name).parent_path());
    dir.Write("m/" + name, "x");
  }
  CleanUp(path);
  EXPECT_FALSE(fs::exists(path + "/learned/decoder.txt.tmp" + dead));
  EXPECT_FALSE(fs::exists(path + "/learned/states/0001.bin.tmp" + dead));
  EXPECT_FALSE(fs::exists(path + "/poses/0000.bin.tmp" + dead));
  EXPECT_FALSE(fs::exists(path + "/train/log.csv.tmp" + dead));
  EXPECT_FALSE(fs::exists(path + "/decoder.txt.tmp" + dead));
  EXPECT_FALSE(fs::exists(path + "/model.txt.tmp" + dead));
  EXPECT_TRUE(fs::exists(path + "/notes.txt.tmp" + dead));
  EXPECT_TRUE(fs::exists(path + "/mu.bin.tmp" + live));
  EXPECT_FALSE(fs::exists(path + "/pretrain/surface_errors.bin.tmp" + dead));
  ASSERT_TRUE(LoadModel(path, &back, &error)) << error;
  // The model's own records do not stop a replacement; the user's files do.
  fs::remove(path + "/notes.txt.tmp" + dead);
  fs::remove(path + "/mu.bin.tmp" + live);
  dir.Write("m/pretrain/surface_errors.txt", "record");
  dir.Write("m/train/log.csv", "iteration\n");
  EXPECT_TRUE(SaveModel(path, model, &error)) << error;
}

}  // namespace
}  // namespace aqs
