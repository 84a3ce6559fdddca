#include "model/model_io.h"

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <sstream>

#include "mesh/mesh_io.h"
#include "util/atomic_file.h"
#include "util/line_reader.h"
#include "util/matrix_io.h"
#include "util/number_format.h"

namespace aqs {
namespace {

namespace fs = std::filesystem;

constexpr int kFormatVersion = 1;

std::string PoseFile(const std::string& folder, int p) {
  char name[32];
  std::snprintf(name, sizeof(name), "%04d.bin", p);
  return folder + "/" + name;
}

bool MakeDirectory(const std::string& path, std::string* error) {
  std::error_code code;
  fs::create_directories(path, code);
  if (code) {
    *error = path + ": cannot create directory (" + code.message() + ")";
    return false;
  }
  return true;
}

bool WriteText(const std::string& path, const std::string& text, std::string* error) {
  return WriteFileAtomically(path, text, error);
}

bool WriteLearned(const std::string& dir, const ActiveModel& model, std::string* error) {
  if (model.decoder) {
    if (!SaveDecoder(dir + "/decoder.txt", model.decoder->spec(),
                     model.decoder->field().description(), model.decoder_params, error) ||
        !WriteMatrixFile(dir + "/latents.bin", model.latents, error)) {
      return false;
    }
  }
  if (!model.states.empty()) {
    if (!MakeDirectory(dir + "/states", error)) return false;
    for (int p = 0; p < model.num_poses(); ++p) {
      if (model.states[p].cols() == 0) continue;
      if (!WriteMatrixFile(PoseFile(dir + "/states", p), model.states[p], error)) return false;
    }
  }
  return true;
}

bool WriteAll(const std::string& dir, const ActiveModel& model, std::string* error) {
  std::ostringstream manifest;
  manifest << "# ActiveQS model (docs/model_format.md)\n"
           << "format " << kFormatVersion << "\n"
           << "vertices " << model.mesh.num_vertices() << "\n"
           << "elements " << model.mesh.num_tets() << "\n"
           << "surface_vertices " << model.num_surface_vertices() << "\n"
           << "poses " << model.num_poses() << "\n"
           << "bones " << model.bones.size() << "\n"
           << "trained " << (model.decoder ? 1 : 0) << "\n";
  if (!WriteText(dir + "/model.txt", manifest.str(), error) ||
      !WriteMeditMesh(dir + "/mesh.mesh", model.mesh, error) ||
      !WriteMatrixFile(dir + "/mu.bin", model.mu.transpose(), error) ||
      !WriteObj(dir + "/neutral.obj", model.neutral, error)) {
    return false;
  }
  std::string fixed = "# vertex bone (-1: static at rest)\n";
  for (int v : model.static_vertices) fixed += std::to_string(v) + " -1\n";
  for (size_t b = 0; b < model.bones.size(); ++b) {
    for (int v : model.bones[b].vertices) fixed += std::to_string(v) + " " + std::to_string(b) + "\n";
  }
  std::string bones = "# bone <b> <name>; then <b> <pose> rotation (row-major 9) translation (3)\n";
  for (size_t b = 0; b < model.bones.size(); ++b) {
    bones += "bone " + std::to_string(b) + " " + model.bones[b].name + "\n";
    for (int p = 0; p < model.num_poses(); ++p) {
      const RigidTransform& t = model.bones[b].pose_transforms[p];
      bones += std::to_string(b) + " " + std::to_string(p);
      for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) {
          bones += ' ';
          AppendDouble(t.rotation(r, c), &bones);
        }
      }
      for (int c = 0; c < 3; ++c) {
        bones += ' ';
        AppendDouble(t.translation[c], &bones);
      }
      bones += '\n';
    }
  }
  std::string embedding =
      "# element w0 w1 w2 w3 ox oy oz outside_distance, one line per surface vertex\n";
  for (int i = 0; i < model.embedding.num_points(); ++i) {
    embedding += std::to_string(model.embedding.element[i]);
    for (int k = 0; k < 4; ++k) {
      embedding += ' ';
      AppendDouble(model.embedding.weights(k, i), &embedding);
    }
    for (int k = 0; k < 3; ++k) {
      embedding += ' ';
      AppendDouble(model.embedding.offsets(k, i), &embedding);
    }
    embedding += ' ';
    AppendDouble(model.embedding.outside_distance[i], &embedding);
    embedding += '\n';
  }
  std::string poses = "# index name embedding_mean_error embedding_max_error\n";
  for (int p = 0; p < model.num_poses(); ++p) {
    poses += std::to_string(p) + " " + model.poses[p].name + " ";
    AppendDouble(model.poses[p].embedding_mean_error, &poses);
    poses += ' ';
    AppendDouble(model.poses[p].embedding_max_error, &poses);
    poses += '\n';
  }
  if (!WriteText(dir + "/fixed.txt", fixed, error) || !WriteText(dir + "/bones.txt", bones, error) ||
      !WriteText(dir + "/embedding.txt", embedding, error) ||
      !WriteText(dir + "/poses.txt", poses, error) || !MakeDirectory(dir + "/poses", error)) {
    return false;
  }
  bool any_target = false;
  for (const TrainingPose& pose : model.poses) any_target |= pose.target.cols() > 0;
  if (any_target && !MakeDirectory(dir + "/targets", error)) return false;
  for (int p = 0; p < model.num_poses(); ++p) {
    if (!WriteMatrixFile(PoseFile(dir + "/poses", p), model.poses[p].surface, error)) return false;
    if (model.poses[p].target.cols() > 0 &&
        !WriteMatrixFile(PoseFile(dir + "/targets", p), model.poses[p].target, error)) {
      return false;
    }
  }
  return WriteLearned(dir, model, error);
}

// Reads "key value" lines of model.txt.
bool ReadManifest(const std::string& path, int* version, std::string* error) {
  LineReader reader(path);
  if (!reader.ok()) {
    *error = reader.error() + " (is this an ActiveQS model directory?)";
    return false;
  }
  std::vector<std::string> tokens;
  *version = -1;
  while (reader.NextTokens(&tokens)) {
    if (tokens.size() == 2 && tokens[0] == "format" && ParseInt(tokens[1], version)) break;
  }
  if (*version != kFormatVersion) {
    *error = path + ": expected 'format " + std::to_string(kFormatVersion) + "'";
    return false;
  }
  return true;
}

}  // namespace

bool SaveModel(const std::string& directory, const ActiveModel& model, std::string* error) {
  if (!ValidateModel(model, directory, error)) return false;
  const std::string temp = directory + ".tmp" + std::to_string(static_cast<long>(::getpid()));
  const std::string old = directory + ".old" + std::to_string(static_cast<long>(::getpid()));
  std::error_code code;
  fs::remove_all(temp, code);
  if (!MakeDirectory(temp, error) || !WriteAll(temp, model, error)) {
    fs::remove_all(temp, code);
    return false;
  }
  const bool existed = fs::exists(directory);
  if (existed) {
    fs::rename(directory, old, code);
    if (code) {
      *error = directory + ": cannot move the existing model aside (" + code.message() + ")";
      fs::remove_all(temp, code);
      return false;
    }
  }
  fs::rename(temp, directory, code);
  if (code) {
    *error = directory + ": cannot move the new model into place (" + code.message() + ")";
    if (existed) fs::rename(old, directory, code);
    return false;
  }
  if (existed) fs::remove_all(old, code);
  return true;
}

bool SaveLearnedState(const std::string& directory, const ActiveModel& model, std::string* error) {
  if (!ValidateModel(model, directory, error)) return false;
  return WriteLearned(directory, model, error);
}

bool LoadModel(const std::string& directory, ActiveModel* model_out, std::string* error) {
  const std::string& dir = directory;
  int version = 0;
  if (!ReadManifest(dir + "/model.txt", &version, error)) return false;
  ActiveModel model;
  if (!ReadTetMesh(dir + "/mesh.mesh", &model.mesh, error)) return false;
  const int nv = model.mesh.num_vertices();
  const int ne = model.mesh.num_tets();
  Eigen::MatrixXd matrix;
  if (!ReadMatrixFile(dir + "/mu.bin", 1, ne, &matrix, error)) return false;
  model.mu = matrix.transpose();
  if (!ReadObj(dir + "/neutral.obj", &model.neutral, error)) return false;

  // poses.txt
  {
    LineReader reader(dir + "/poses.txt");
    if (!reader.ok()) {
      *error = reader.error();
      return false;
    }
    std::vector<std::string> t;
    while (reader.NextTokens(&t)) {
      TrainingPose pose;
      int index = 0;
      if (t.size() != 4 || !ParseInt(t[0], &index) || index != model.num_poses() ||
          !ParseDouble(t[2], &pose.embedding_mean_error) ||
          !ParseDouble(t[3], &pose.embedding_max_error)) {
        *error = reader.Where("expected '" + std::to_string(model.num_poses()) +
                              " <name> <mean error> <max error>'");
        return false;
      }
      pose.name = t[1];
      model.poses.push_back(pose);
    }
  }
  const int ns = model.neutral.num_vertices();
  for (int p = 0; p < model.num_poses(); ++p) {
    if (!ReadMatrixFile(PoseFile(dir + "/poses", p), 3, ns, &matrix, error)) return false;
    model.poses[p].surface = matrix;
    const std::string target = PoseFile(dir + "/targets", p);
    if (fs::exists(target)) {
      if (!ReadMatrixFile(target, 6, ne, &matrix, error)) return false;
      model.poses[p].target = matrix;
    }
  }

  // fixed.txt and bones.txt
  std::vector<std::pair<int, int>> fixed;
  {
    LineReader reader(dir + "/fixed.txt");
    if (!reader.ok()) {
      *error = reader.error();
      return false;
    }
    std::vector<std::string> t;
    while (reader.NextTokens(&t)) {
      int v = 0, b = 0;
      if (t.size() != 2 || !ParseInt(t[0], &v) || !ParseInt(t[1], &b) || v < 0 || v >= nv ||
          b < -1) {
        *error = reader.Where("expected '<vertex in [0, " + std::to_string(nv) + ")> <bone>'");
        return false;
      }
      fixed.emplace_back(v, b);
    }
  }
  {
    LineReader reader(dir + "/bones.txt");
    if (!reader.ok()) {
      *error = reader.error();
      return false;
    }
    std::vector<std::string> t;
    while (reader.NextTokens(&t)) {
      int b = 0, p = 0;
      if (t.size() == 3 && t[0] == "bone") {
        if (!ParseInt(t[1], &b) || b != static_cast<int>(model.bones.size())) {
          *error = reader.Where("bones must be numbered 0, 1, ... in order");
          return false;
        }
        Bone bone;
        bone.name = t[2];
        model.bones.push_back(bone);
        continue;
      }
      RigidTransform transform;
      bool ok = t.size() == 14 && ParseInt(t[0], &b) && ParseInt(t[1], &p) &&
                b == static_cast<int>(model.bones.size()) - 1 &&
                p == static_cast<int>(model.bones[b].pose_transforms.size());
      for (int i = 0; ok && i < 9; ++i) ok = ParseDouble(t[2 + i], &transform.rotation(i / 3, i % 3));
      for (int i = 0; ok && i < 3; ++i) ok = ParseDouble(t[11 + i], &transform.translation[i]);
      if (!ok) {
        *error = reader.Where("expected '<bone> <pose> r00 .. r22 t0 t1 t2' for the next pose of "
                              "the current bone");
        return false;
      }
      model.bones[b].pose_transforms.push_back(transform);
    }
  }
  for (const auto& [v, b] : fixed) {
    if (b == -1) {
      model.static_vertices.push_back(v);
    } else if (b < static_cast<int>(model.bones.size())) {
      model.bones[b].vertices.push_back(v);
    } else {
      *error = dir + "/fixed.txt: vertex " + std::to_string(v) + " refers to bone " +
               std::to_string(b) + ", but bones.txt defines " + std::to_string(model.bones.size());
      return false;
    }
  }

  // embedding.txt
  {
    LineReader reader(dir + "/embedding.txt");
    if (!reader.ok()) {
      *error = reader.error();
      return false;
    }
    model.embedding.weights.resize(4, ns);
    model.embedding.offsets.resize(3, ns);
    std::vector<std::string> t;
    int i = 0;
    while (reader.NextTokens(&t)) {
      int e = 0;
      double outside = 0;
      bool ok = i < ns && t.size() == 9 && ParseInt(t[0], &e) && e >= 0 && e < ne &&
                ParseDouble(t[8], &outside);
      for (int k = 0; ok && k < 4; ++k) ok = ParseDouble(t[1 + k], &model.embedding.weights(k, i));
      for (int k = 0; ok && k < 3; ++k) ok = ParseDouble(t[5 + k], &model.embedding.offsets(k, i));
      if (!ok) {
        *error = reader.Where("expected '<element in [0, " + std::to_string(ne) +
                              ")> w0 w1 w2 w3 ox oy oz outside_distance' for surface vertex " +
                              std::to_string(i) + " of " + std::to_string(ns));
        return false;
      }
      model.embedding.element.push_back(e);
      model.embedding.outside_distance.push_back(outside);
      ++i;
    }
    if (i != ns) {
      *error = dir + "/embedding.txt: " + std::to_string(i) + " lines for " + std::to_string(ns) +
               " surface vertices";
      return false;
    }
  }

  // The learned part.
  if (fs::exists(dir + "/decoder.txt")) {
    DecoderSpec spec;
    GridFieldDescription description;
    Eigen::VectorXd params;
    if (!LoadDecoder(dir + "/decoder.txt", &spec, &description, &params, error)) return false;
    GridActuationField field;
    if (!GridActuationField::FromDescription(model.mesh, description, dir + "/decoder.txt", &field,
                                             error)) {
      return false;
    }
    model.decoder = std::make_shared<ActuationDecoder>(spec, std::move(field));
    model.decoder_params = params;
    if (!ReadMatrixFile(dir + "/latents.bin", spec.latent_dim, model.num_poses(), &matrix, error)) {
      return false;
    }
    model.latents = matrix;
  }
  if (fs::exists(dir + "/states")) {
    model.states.resize(model.num_poses());
    for (int p = 0; p < model.num_poses(); ++p) {
      const std::string path = PoseFile(dir + "/states", p);
      if (!fs::exists(path)) continue;
      if (!ReadMatrixFile(path, 3, nv, &matrix, error)) return false;
      model.states[p] = matrix;
    }
  }
  if (!ValidateModel(model, dir, error)) return false;
  *model_out = std::move(model);
  return true;
}

}  // namespace aqs
