#include "model/model_io.h"

// Reading models (LoadModel): every file checked as it is read, the learned unit read as
// one (held open against a checkpoint replacing it meanwhile). Writing: model_save.cc.

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <map>
#include <sstream>
#include <utility>
#include <thread>

#include "geometry/embedding.h"
#include "geometry/points_near_model.h"
#include "io/actuation_io.h"
#include "mesh/mesh_io.h"
#include "model/model_directory.h"
#include "model/model_files.h"
#include "model/model_fingerprint.h"
#include "util/fault_injection.h"
#include "util/input_file.h"
#include "util/line_reader.h"
#include "util/matrix_io.h"
#include "util/name_rules.h"
#include "util/number_format.h"
#include "util/staged_directory.h"

namespace aqs {
namespace {

namespace fs = std::filesystem;

// ReadMatrixFile, and every entry must be finite: a NaN or an infinity in a model file
// is damage, reported naming the file and the entry.
bool ReadFiniteMatrix(const std::string& path, Eigen::Index rows, Eigen::Index cols,
                      Eigen::MatrixXd* matrix, std::string* error) {
  Eigen::MatrixXd read;
  if (!ReadMatrixFile(path, rows, cols, &read, error)) return false;
  for (Eigen::Index c = 0; c < read.cols(); ++c) {
    for (Eigen::Index r = 0; r < read.rows(); ++r) {
      if (!std::isfinite(read(r, c))) {
        *error = path + ": entry (" + std::to_string(r) + ", " + std::to_string(c) + ") of the " +
                 std::to_string(read.rows()) + " x " + std::to_string(read.cols()) +
                 " matrix is not finite (" + FormatDouble(read(r, c)) + "): the file is damaged";
        return false;
      }
    }
  }
  *matrix = std::move(read);
  return true;
}

// Whether `text` is a finite number >= 0.
bool FiniteNonNegative(const std::string& text) {
  double value = 0.0;
  return ParseDouble(text, &value) && std::isfinite(value) && value >= 0.0;
}

// Reads a checkpoint file ("iterations N", optional "loss L", "latent_refit_at N",
// "loss_weights latent L energy E decoder D" and "model F"; *fingerprint is F, or ""
// without that line). A missing file is no checkpoint (0 iterations); an empty or
// malformed one is an error naming it.

bool ReadCheckpoint(const std::string& path, TrainingCheckpoint* checkpoint,
                    std::string* fingerprint, std::string* error) {
  *checkpoint = TrainingCheckpoint();
  fingerprint->clear();
  std::error_code code;
  if (!fs::exists(path, code)) return true;
  LineReader reader(path);
  if (!reader.ok()) {
    *error = reader.error();
    return false;
  }
  std::vector<std::string> t;
  bool have_iterations = false;
  uint64_t value = 0;
  while (reader.NextTokens(&t)) {
    if (t.size() == 2 && t[0] == "iterations" && ParseInt(t[1], &checkpoint->iterations) &&
        checkpoint->iterations >= 0) {
      have_iterations = true;
    } else if (t.size() == 2 && t[0] == "model" && ParseFingerprint(t[1], &value)) {
      *fingerprint = FingerprintText(value);
    } else if (t.size() == 2 && t[0] == "latent_refit_at" &&
               ParseInt(t[1], &checkpoint->latent_refit_at) && checkpoint->latent_refit_at >= 0) {
    } else if (t.size() == 7 && t[0] == "loss_weights" && t[1] == "latent" &&
               t[3] == "energy" && t[5] == "decoder" && FiniteNonNegative(t[2]) &&
               FiniteNonNegative(t[4]) && FiniteNonNegative(t[6])) {
      checkpoint->loss_weights = t[1];
      for (size_t i = 2; i < t.size(); ++i) checkpoint->loss_weights += " " + t[i];
    } else if (!(t.size() == 2 && t[0] == "loss" && ParseDouble(t[1], &checkpoint->loss))) {
      *error = reader.Where(
          "expected 'iterations N' (N >= 0), 'loss L', 'latent_refit_at N' (N >= 0), "
          "'loss_weights latent L energy E decoder D' (finite, >= 0) or 'model F' (F: 16 "
          "hexadecimal digits)");
      return false;
    }
  }
  if (!reader.ok()) {
    *error = reader.error();
    return false;
  }
  if (!have_iterations) {
    *error = path +
             ": no 'iterations N' line (the file is empty or damaged; delete it to "
             "count training iterations from 0 again)";
    return false;
  }
  return true;
}

// The counts model.txt records (-1 where a line is absent).
struct ManifestCounts {
  int vertices = -1;
  int elements = -1;
  int surface_vertices = -1;
  int poses = -1;
  int bones = -1;
};

// Reads "key value" lines of model.txt: the format version, (may be null) the targets'
// key (ActiveModel::target_key; "" if absent or not a fingerprint) and (may be null) the
// counts.
bool ReadManifest(const std::string& path, int* version, std::string* error,
                  std::string* target_key = nullptr, ManifestCounts* counts = nullptr) {
  LineReader reader(path);
  if (!reader.ok()) {
    *error = reader.error() + " (is this an ActiveQS model directory?)";
    return false;
  }
  std::vector<std::string> tokens;
  *version = -1;
  uint64_t fingerprint = 0;
  while (reader.NextTokens(&tokens)) {
    if (tokens.size() == 2 && tokens[0] == "format") ParseInt(tokens[1], version);
    if (counts != nullptr && tokens.size() == 2) {
      const std::pair<const char*, int*> fields[] = {
          {"vertices", &counts->vertices}, {"elements", &counts->elements},
          {"surface_vertices", &counts->surface_vertices}, {"poses", &counts->poses},
          {"bones", &counts->bones}};
      for (const auto& [key, value] : fields) {
        if (tokens[0] == key && (!ParseInt(tokens[1], value) || *value < 0)) {
          *error = reader.Where("'" + tokens[0] + "' needs a count, not '" + tokens[1] + "'");
          return false;
        }
      }
    }
    if (target_key != nullptr && tokens.size() == 2 && tokens[0] == "targets" &&
        ParseFingerprint(tokens[1], &fingerprint)) {
      *target_key = FingerprintText(fingerprint);
    }
  }
  if (!reader.ok()) {
    *error = reader.error();
    return false;
  }
  if (*version != 1 && *version != internal::kModelFormatVersion) {
    *error = path + ": expected 'format 1' or 'format " +
             std::to_string(internal::kModelFormatVersion) +
             "' (a model of another ActiveQS version?)";
    return false;
  }
  return true;
}

// The counts model.txt records against what the files hold: a file that lost lines
// (poses.txt a pose, bones.txt a bone) is named, not loaded short.
bool CheckManifestCounts(const std::string& dir, const ManifestCounts& counts,
                         const ActiveModel& model, std::string* error) {
  const struct {
    const char* key;
    int recorded;
    int read;
    const char* file;
  } checks[] = {
      {"vertices", counts.vertices, model.mesh.num_vertices(), "mesh.mesh"},
      {"elements", counts.elements, model.mesh.num_tets(), "mesh.mesh"},
      {"surface_vertices", counts.surface_vertices, model.neutral.num_vertices(), "neutral.obj"},
      {"poses", counts.poses, model.num_poses(), "poses.txt"},
      {"bones", counts.bones, static_cast<int>(model.bones.size()), "bones.txt"},
  };
  for (const auto& check : checks) {
    if (check.recorded >= 0 && check.recorded != check.read) {
      *error = dir + "/model.txt says " + check.key + " " + std::to_string(check.recorded) +
               ", but " + dir + "/" + check.file + " has " + std::to_string(check.read) +
               " (a damaged or partly copied model directory)";
      return false;
    }
  }
  return true;
}

// A neutral surface without faces (scan fits, contact and the attachment springs read
// them) is refused naming neutral.obj.
bool CheckNeutralHasFaces(const std::string& dir, const ActiveModel& model, std::string* error) {
  if (model.neutral.triangles.cols() > 0) return true;
  *error = dir + "/neutral.obj has no faces: a model's neutral surface needs its triangles "
           "(scan fits, contact and the attachment springs read them)";
  return false;
}

// The smallest eigenvalue of a fit prior's covariance must be at least this fraction of its
// largest. A covariance that is nearly singular, with ordinary variances on its diagonal,
// pinned fits silently to a line of latents or the jaw to rest; learned ones are far
// inside (the latent's floor is 1% of the mean variance, the bones' floors 1% of a radian
// and 10% of the motions' spread).
constexpr double kMinPriorEigenvalueRatio = 1e-12;

// Whether the symmetric matrix `c` has eigenvalues in [kMinPriorEigenvalueRatio x its
// largest, its largest], the largest positive.
bool WellConditionedCovariance(const Eigen::MatrixXd& c) {
  if (c.size() == 0) return true;
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(c, Eigen::EigenvaluesOnly);
  const Eigen::VectorXd& lambda = eigen.eigenvalues();  // increasing
  return lambda[lambda.size() - 1] > 0.0 &&
         lambda[0] >= kMinPriorEigenvalueRatio * lambda[lambda.size() - 1];
}

// A fit prior's scales (`prior_source`: its file): finite but absurd priors (a bone's mean
// 1e300 away, a covariance of 1e-300) made every fit fail inside Ceres, naming nothing.
// Learned ones are far inside these bounds (the latent's mean variance above 1e-12, a
// bone's translation deviation above 1e-3 model sizes and its rotation's above 0.01 rad).
bool CheckFitPriorScales(const std::string& prior_source, const ActiveModel& model,
                         std::string* error) {
  const Eigen::Vector3d lo = model.mesh.vertices.rowwise().minCoeff();
  const Eigen::Vector3d hi = model.mesh.vertices.rowwise().maxCoeff();
  const double size = std::max((hi - lo).norm(), 1e-300);
  const std::string remedy = " (remove it to learn it again from the training latents)";
  const GaussianPrior& latent = model.fit_prior.latent;
  if (latent.size() > 0 && !(latent.covariance.diagonal().mean() >= 1e-14)) {
    *error = prior_source + ": the latent covariance's mean variance is " +
             FormatDouble(latent.covariance.diagonal().mean()) + ", below 1e-14" + remedy;
    return false;
  }
  if (!WellConditionedCovariance(latent.covariance)) {
    *error = prior_source + ": the latent covariance is nearly singular (its smallest " +
             "eigenvalue is below " + FormatDouble(kMinPriorEigenvalueRatio) +
             " of its largest), which pins fits to a subspace" + remedy;
    return false;
  }
  for (size_t b = 0; b < model.fit_prior.bones.size() && b < model.bones.size(); ++b) {
    const GaussianPrior& bone = model.fit_prior.bones[b];
    const std::string name = "bone '" + model.bones[b].name + "'";
    if (!(bone.mean.head<3>().norm() <= 2 * M_PI) ||
        !(bone.mean.tail<3>().norm() <= kMaxDistanceInModelSizes * size)) {
      *error = prior_source + ": the mean motion of " + name + " turns by more than 2 pi " +
               "or moves more than " + FormatDouble(kMaxDistanceInModelSizes) +
               " model sizes" + remedy;
      return false;
    }
    const Eigen::VectorXd variances = bone.covariance.diagonal();
    if (!(variances.head<3>().minCoeff() >= 1e-20) ||
        !(variances.tail<3>().minCoeff() >= 1e-18 * size * size)) {
      *error = prior_source + ": the covariance of " + name +
               " has a variance near 0, which pins every fit" + remedy;
      return false;
    }
    if (!WellConditionedCovariance(bone.covariance)) {
      *error = prior_source + ": the covariance of " + name + " is nearly singular (its " +
               "smallest eigenvalue is below " + FormatDouble(kMinPriorEigenvalueRatio) +
               " of its largest), which pins fits to a subspace" + remedy;
      return false;
    }
  }
  return true;
}

// The learned state must give actuations a simulation can use: the training latents
// and the fit prior's latent mean decode to entries of at most kMaxActuationStretch in
// magnitude (a damaged decoder, latent or prior file otherwise sends every solve after
// absurd targets). Errors name `source` (the decoder) or `prior_source`.
bool CheckLearnedActuations(const std::string& source, const std::string& prior_source,
                            const ActiveModel& model, std::string* error) {
  if (!model.decoder) return true;
  // Fits learn their priors from the training latents, and the evaluation and training
  // need the poses: a learned state without them is another model's or damaged.
  if (model.num_poses() == 0) {
    *error = source + ": a learned decoder in a model without training poses (poses.txt "
                      "lists none)";
    return false;
  }
  std::vector<ActuationMatrix> actuations;
  DecoderWorkspace workspace;
  model.decoder->DecodeBatch(model.decoder_params.data(), model.latents, &actuations, &workspace);
  for (int p = 0; p < model.num_poses(); ++p) {
    const double largest = actuations[p].cwiseAbs().maxCoeff();
    if (!(largest <= kMaxActuationStretch)) {
      *error = source + ": the decoder maps training pose '" + model.poses[p].name +
               "' to actuations with entries up to " + FormatDouble(largest) + " (more than " +
               FormatDouble(kMaxActuationStretch) + "): the decoder or the latents are damaged";
      return false;
    }
  }
  if (!model.fit_prior.empty() && !model.fit_prior.center.empty() &&
      model.PoseIndex(model.fit_prior.center) < 0) {
    *error = prior_source + ": the priors are centred on '" + model.fit_prior.center +
             "', which is not a training pose of this model";
    return false;
  }
  if (!model.fit_prior.empty() && !CheckFitPriorScales(prior_source, model, error)) {
    return false;
  }
  // Every fit starts from the prior's centre by default: it must decode as sanely.
  if (!model.fit_prior.empty() && model.fit_prior.latent.size() == model.latent_dim()) {
    ActuationMatrix a;
    model.decoder->Decode(model.decoder_params.data(), model.fit_prior.latent.mean, &a, &workspace);
    const double largest = a.cwiseAbs().maxCoeff();
    if (!(largest <= kMaxActuationStretch)) {
      *error = prior_source + ": the latent mean decodes to actuations with entries up to " +
               FormatDouble(largest) + " (more than " + FormatDouble(kMaxActuationStretch) +
               "): the prior is damaged (remove it to learn it again from the training latents)";
      return false;
    }
  }
  return true;
}

// Reads the learned unit at `dir` (format 2: learned/; format 1: the model's top,
// with the checkpoint in train/checkpoint.txt) into `model`.
// A checkpoint that names another model's fingerprint fails (the learned state was
// copied from another model).
bool ReadLearned(const std::string& dir, const std::string& checkpoint_path, ActiveModel* model,
                 std::string* error) {
  model->decoder.reset();
  model->decoder_params.resize(0);
  model->latents.resize(0, 0);
  model->states.clear();
  model->fit_prior = FitPrior();
  std::string fingerprint;
  if (!ReadCheckpoint(checkpoint_path, &model->checkpoint, &fingerprint, error)) return false;
  const std::string own = fingerprint.empty() ? "" : FingerprintText(ModelFingerprint(*model));
  if (fingerprint != own) {
    *error = checkpoint_path + ": the learned state belongs to another model (made for model " +
             fingerprint + "; this directory's mesh, poses and embedding are model " + own +
             "): copy whole model directories, not learned/ alone, or pre-train this model "
             "again (aqs_pretrain)";
    return false;
  }
  Eigen::MatrixXd matrix;
  if (!MayExist(dir + "/decoder.txt")) {
    // The decoder's latents, prior or equilibria without it: a damaged learned state
    // (it loaded as an untrained model, and the next fit or training aborted).
    for (const char* part : {"/latents.bin", "/prior.txt", "/states"}) {
      if (!MayExist(dir + part)) continue;
      *error = dir + "/decoder.txt: missing, but " + dir + part + " is there: the learned "
               "state is damaged (restore the file, or remove the learned state and "
               "pre-train the model again)";
      return false;
    }
  } else {
    DecoderSpec spec;
    GridFieldDescription description;
    Eigen::VectorXd params;
    if (!LoadDecoder(dir + "/decoder.txt", &spec, &description, &params, error)) return false;
    GridActuationField field;
    if (!GridActuationField::FromDescription(model->mesh, description, dir + "/decoder.txt", &field,
                                             error)) {
      return false;
    }
    model->decoder = std::make_shared<ActuationDecoder>(spec, std::move(field));
    model->decoder_params = params;
    FaultPoint("model_io:decoder_read");  // a checkpoint may replace the unit here
    if (!ReadFiniteMatrix(dir + "/latents.bin", spec.latent_dim, model->num_poses(), &matrix,
                          error)) {
      return false;
    }
    model->latents = matrix;
    // The fit prior, if the unit has one (else learned once the model is validated).
    if (MayExist(dir + "/prior.txt") &&
        !ReadFitPrior(dir + "/prior.txt", spec.latent_dim, internal::BoneNames(*model),
                      &model->fit_prior, error)) {
      return false;
    }
  }
  if (MayExist(dir + "/states")) {
    const int nv = model->mesh.num_vertices();
    model->states.resize(model->num_poses());
    for (int p = 0; p < model->num_poses(); ++p) {
      const std::string path = internal::PoseFile(dir + "/states", p);
      if (!MayExist(path)) continue;
      if (!ReadFiniteMatrix(path, 3, nv, &matrix, error)) return false;
      model->states[p] = matrix;
      if (!CheckPointsNearModel(path, model->neutral.vertices, model->states[p], error)) {
        return false;
      }
    }
  }
  return CheckLearnedActuations(dir + "/decoder.txt", dir + "/prior.txt", *model, error);
}

// Identity of the directory at `path` (device, inode); zeros if missing.
std::pair<dev_t, ino_t> DirectoryIdentity(const std::string& path) {
  struct stat st;
  if (::stat(path.c_str(), &st) != 0) return {0, 0};
  return {st.st_dev, st.st_ino};
}

// mu.bin (1 x num_elements, finite) into model->mu, with the checks every solve relies
// on: a stiffness contrast a double-precision solve resolves, and a finite, positive
// force scale 2 mean(mu V^(2/3)) (the solvers' tolerance).
bool ReadStiffness(const std::string& dir, ActiveModel* model, std::string* error) {
  ActiveModel& m = *model;
  const int ne = m.mesh.num_tets();
  Eigen::MatrixXd matrix;
  if (!ReadFiniteMatrix(dir + "/mu.bin", 1, ne, &matrix, error)) return false;
  m.mu = matrix.transpose();
  for (int e = 0; e < ne; ++e) {
    if (!(m.mu[e] > 0)) {
      *error = dir + "/mu.bin: the stiffness of element " + std::to_string(e) + " is " +
               FormatDouble(m.mu[e]) + ", not positive";
      return false;
    }
  }
  // The force scale 2 mean(mu V^(2/3)) must be a number: the solvers' tolerance.
  double scale = 0.0;
  for (int e = 0; e < ne; ++e) {
    const double volume = std::abs(SignedTetVolume(m.mesh, m.mesh.vertices, e));
    scale += m.mu[e] * std::cbrt(volume * volume);
  }
  scale *= 2.0 / std::max(1, ne);
  const double contrast = m.mu.maxCoeff() / m.mu.minCoeff();
  if (!(contrast <= kMaxStiffnessContrast)) {
    *error = dir + "/mu.bin: the stiffness ranges from " + FormatDouble(m.mu.minCoeff()) + " to " +
             FormatDouble(m.mu.maxCoeff()) + ", a contrast above " +
             FormatDouble(kMaxStiffnessContrast) + " that no solve resolves in double precision";
    return false;
  }
  if (!(std::isfinite(scale) && scale > 0.0)) {
    *error = dir + "/mu.bin: the force scale 2 mean(mu V^(2/3)) is " + FormatDouble(scale) +
             ": mu or the mesh's size is so large or small that the forces overflow";
    return false;
  }
  return true;
}

// poses.txt ('<index> <name> <mean error> <max error>' per pose, in order) and each
// pose's surface (poses/<p>.bin: 3 x num_surface_vertices, near the model) and, where
// present, its volumetric target (targets/<p>.bin: 6 x num_elements).
bool ReadPoses(const std::string& dir, ActiveModel* model, std::string* error) {
  ActiveModel& m = *model;
  LineReader reader(dir + "/poses.txt");
  if (!reader.ok()) {
    *error = reader.error();
    return false;
  }
  std::vector<std::string> t;
  std::map<std::string, int> lines;  // pose name -> its line
  while (reader.NextTokens(&t)) {
    TrainingPose pose;
    int index = 0;
    if (t.size() != 4 || !ParseInt(t[0], &index) || index != m.num_poses() ||
        !ParseDouble(t[2], &pose.embedding_mean_error) ||
        !ParseDouble(t[3], &pose.embedding_max_error)) {
      *error = reader.Where("expected '" + std::to_string(m.num_poses()) +
                            " <name> <mean error> <max error>'");
      return false;
    }
    pose.name = t[1];
    // The names go into CSV fields (evaluation.csv, frames.csv): a ',' split their rows.
    const std::string problem = NameProblem(pose.name);
    if (!problem.empty()) {
      *error = reader.Where("pose name '" + pose.name + "' " + problem);
      return false;
    }
    if (!(pose.embedding_mean_error >= 0 && pose.embedding_max_error >= 0 &&
          std::isfinite(pose.embedding_mean_error) && std::isfinite(pose.embedding_max_error))) {
      *error = reader.Where("the embedding errors must be finite distances >= 0");
      return false;
    }
    const auto [it, inserted] = lines.emplace(pose.name, reader.line_number());
    if (!inserted) {
      *error = reader.Where("pose '" + pose.name + "' again (first on line " +
                            std::to_string(it->second) + "): pose names must differ");
      return false;
    }
    m.poses.push_back(pose);
  }
  if (!reader.ok()) {
    *error = reader.error();
    return false;
  }
  const int ns = m.neutral.num_vertices();
  const int ne = m.mesh.num_tets();
  Eigen::MatrixXd matrix;
  for (int p = 0; p < m.num_poses(); ++p) {
    if (!ReadFiniteMatrix(internal::PoseFile(dir + "/poses", p), 3, ns, &matrix, error) ||
        !CheckPointsNearModel(internal::PoseFile(dir + "/poses", p), m.neutral.vertices, matrix,
                              error)) {
      return false;
    }
    m.poses[p].surface = matrix;
    const std::string target = internal::PoseFile(dir + "/targets", p);
    if (MayExist(target)) {
      if (!ReadFiniteMatrix(target, 6, ne, &matrix, error) ||
          !CheckStoredTargets(target, matrix, error)) {
        return false;
      }
      m.poses[p].target = matrix;
    }
  }
  return true;
}

// fixed.txt ('<vertex> <bone>' per fixed vertex: -1 static, else the bone that drives it)
// and bones.txt (each bone's name, then its rigid motion in every training pose):
// model->static_vertices and model->bones. At least one vertex must be fixed.
bool ReadFixedVerticesAndBones(const std::string& dir, ActiveModel* model, std::string* error) {
  ActiveModel& m = *model;
  const int nv = m.mesh.num_vertices();
  std::vector<std::pair<int, int>> fixed;
  {
    LineReader reader(dir + "/fixed.txt");
    if (!reader.ok()) {
      *error = reader.error();
      return false;
    }
    std::vector<std::string> t;
    std::vector<int> first_line(nv, 0);  // where each vertex is fixed (0: not yet)
    while (reader.NextTokens(&t)) {
      int v = 0, b = 0;
      if (t.size() != 2 || !ParseInt(t[0], &v) || !ParseInt(t[1], &b) || v < 0 || v >= nv ||
          b < -1) {
        *error = reader.Where("expected '<vertex in [0, " + std::to_string(nv) + ")> <bone>'");
        return false;
      }
      if (first_line[v] > 0) {
        *error = reader.Where("vertex " + std::to_string(v) + " is fixed again (first on line " +
                              std::to_string(first_line[v]) + ")");
        return false;
      }
      first_line[v] = reader.line_number();
      fixed.emplace_back(v, b);
    }
    if (!reader.ok()) {
      *error = reader.error();
      return false;
    }
    if (fixed.empty()) {
      *error = dir +
               "/fixed.txt: lists no fixed vertices; a model needs some (a free body "
               "has no unique equilibrium; aqs_prepare makes them from its --fixed_* "
               "rules)";
      return false;
    }
  }
  {
    LineReader reader(dir + "/bones.txt");
    if (!reader.ok()) {
      *error = reader.error();
      return false;
    }
    const double size = ModelSize(m.neutral.vertices);
    std::vector<std::string> t;
    while (reader.NextTokens(&t)) {
      int b = 0, p = 0;
      if (t.size() == 3 && t[0] == "bone") {
        if (!ParseInt(t[1], &b) || b != static_cast<int>(m.bones.size())) {
          *error = reader.Where("bones must be numbered 0, 1, ... in order");
          return false;
        }
        Bone bone;
        bone.name = t[2];
        const std::string problem = NameProblem(bone.name);
        if (!problem.empty()) {
          *error = reader.Where("bone name '" + bone.name + "' " + problem);
          return false;
        }
        m.bones.push_back(bone);
        continue;
      }
      RigidTransform transform;
      bool ok = t.size() == 14 && ParseInt(t[0], &b) && ParseInt(t[1], &p) && b >= 0 &&
                b == static_cast<int>(m.bones.size()) - 1 &&
                p == static_cast<int>(m.bones[b].pose_transforms.size());
      for (int i = 0; ok && i < 9; ++i) {
        ok = ParseDouble(t[2 + i], &transform.rotation(i / 3, i % 3));
      }
      for (int i = 0; ok && i < 3; ++i) ok = ParseDouble(t[11 + i], &transform.translation[i]);
      if (!ok) {
        *error = reader.Where(
            "expected '<bone> <pose> r00 .. r22 t0 t1 t2' for the next pose of "
            "the current bone");
        return false;
      }
      const Eigen::Matrix3d& r = transform.rotation;
      if (!((r.transpose() * r - Eigen::Matrix3d::Identity()).norm() <= 1e-6) ||
          !(std::abs(r.determinant() - 1.0) <= 1e-6) || !transform.translation.allFinite()) {
        *error = reader.Where("the motion of bone '" + m.bones[b].name + "' in pose " +
                              std::to_string(p) +
                              " is not a proper rotation and a finite "
                              "translation");
        return false;
      }
      // A motion that carries the neutral's centre more than kMaxDistanceInModelSizes
      // model sizes is another unit or frame, or a damaged file: simulating it ran on for
      // minutes to a face dragged off (1e6 in a translation).
      const double moved = CentreDisplacement(m.neutral.vertices, transform);
      if (!(moved <= kMaxDistanceInModelSizes * size)) {
        std::ostringstream out;
        out << "the motion of bone '" << m.bones[b].name << "' in pose " << p
            << " moves the neutral's centre by " << moved << ", more than "
            << kMaxDistanceInModelSizes << " times the model's size (" << size << ")";
        *error = reader.Where(out.str());
        return false;
      }
      m.bones[b].pose_transforms.push_back(transform);
    }
    if (!reader.ok()) {
      *error = reader.error();
      return false;
    }
  }
  for (const auto& [v, b] : fixed) {
    if (b == -1) {
      m.static_vertices.push_back(v);
    } else if (b < static_cast<int>(m.bones.size())) {
      m.bones[b].vertices.push_back(v);
    } else {
      *error = dir + "/fixed.txt: vertex " + std::to_string(v) + " refers to bone " +
               std::to_string(b) + ", but bones.txt defines " + std::to_string(m.bones.size());
      return false;
    }
  }
  return true;
}

// embedding.txt: per surface vertex its element, barycentric weights, offset and
// distance outside the mesh (model->embedding), checked to be barycentric and within
// the model.
bool ReadEmbedding(const std::string& dir, ActiveModel* model, std::string* error) {
  ActiveModel& m = *model;
  const int ns = m.neutral.num_vertices();
  const int ne = m.mesh.num_tets();
  LineReader reader(dir + "/embedding.txt");
  if (!reader.ok()) {
    *error = reader.error();
    return false;
  }
  m.embedding.weights.resize(4, ns);
  m.embedding.offsets.resize(3, ns);
  std::vector<std::string> t;
  std::vector<int> line_of(ns, 0);
  int i = 0;
  while (reader.NextTokens(&t)) {
    int e = 0;
    double outside = 0;
    bool ok = i < ns && t.size() == 9 && ParseInt(t[0], &e) && e >= 0 && e < ne &&
              ParseDouble(t[8], &outside);
    for (int k = 0; ok && k < 4; ++k) ok = ParseDouble(t[1 + k], &m.embedding.weights(k, i));
    for (int k = 0; ok && k < 3; ++k) ok = ParseDouble(t[5 + k], &m.embedding.offsets(k, i));
    if (!ok) {
      *error = reader.Where("expected '<element in [0, " + std::to_string(ne) +
                            ")> w0 w1 w2 w3 ox oy oz outside_distance' for surface vertex " +
                            std::to_string(i) + " of " + std::to_string(ns));
      return false;
    }
    m.embedding.element.push_back(e);
    m.embedding.outside_distance.push_back(outside);
    line_of[i] = reader.line_number();
    ++i;
  }
  if (!reader.ok()) {
    *error = reader.error();
    return false;
  }
  if (i != ns) {
    *error = dir + "/embedding.txt: " + std::to_string(i) + " lines for " + std::to_string(ns) +
             " surface vertices";
    return false;
  }
  // Barycentric weights (non-negative, summing to 1) and offsets within the m.
  const Eigen::Vector3d lower = m.neutral.vertices.rowwise().minCoeff();
  const Eigen::Vector3d upper = m.neutral.vertices.rowwise().maxCoeff();
  const double size = (upper - lower).norm();
  for (int k = 0; k < ns; ++k) {
    const auto w = m.embedding.weights.col(k);
    const double offset = m.embedding.offsets.col(k).norm();
    const double outside = m.embedding.outside_distance[k];
    if (!(w.minCoeff() >= -1e-6 && w.maxCoeff() <= 1.0 + 1e-6 && std::abs(w.sum() - 1.0) <= 1e-6) ||
        !(offset <= kMaxDistanceInModelSizes * size) ||
        !(outside >= 0.0 && outside <= kMaxDistanceInModelSizes * size)) {
      *error = dir + "/embedding.txt: surface vertex " + std::to_string(k) +
               ": the weights must be barycentric (in [0, 1], summing to 1) and the offset and "
               "outside distance within the model";
      return false;
    }
  }
  // At rest the embedding gives the neutral back (the writer's text keeps it to 1e-14 of
  // the model's size): a line changed by hand embeds its vertex elsewhere.
  const Eigen::Matrix3Xd rest = EmbeddedPositions(m.embedding, m.mesh.tets, m.mesh.vertices);
  for (int k = 0; k < ns; ++k) {
    const double off = (rest.col(k) - m.neutral.vertices.col(k)).norm();
    if (!(off <= 1e-6 * size)) {
      std::ostringstream message;
      message << dir << "/embedding.txt:" << line_of[k] << ": surface vertex " << k
              << " is embedded " << off << " from its place in neutral.obj (the model is "
              << size << " across): the file is damaged";
      *error = message.str();
      return false;
    }
  }
  return true;
}

// The learned part (decoder, latents, states, prior) of a model of format `version`,
// read as one unit: read again if a writer replaced learned/ meanwhile (its directory
// is then another one). A model not yet pre-trained has none.
bool ReadLearnedPart(const std::string& dir, int version, ActiveModel* model, std::string* error) {
  ActiveModel& m = *model;
  if (version == 1) {
    if (!ReadLearned(dir, dir + "/train/checkpoint.txt", &m, error)) return false;
  } else {
    const std::string learned = dir + "/" + internal::kLearnedFolder;
    for (int attempt = 0;; ++attempt) {
      // The unit's directory held open while it is read: its inode cannot be freed and
      // given to a later checkpoint's directory meanwhile, so the same identity after
      // the read means the same unit throughout (without it, a unit two checkpoints
      // later, which on ext4 gets the inode back, passed for the one being read).
      const int fd = ::open(learned.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
      struct stat held;
      if (fd < 0 || ::fstat(fd, &held) != 0) {
        const int code = errno;
        if (fd >= 0) ::close(fd);
        if (DirectoryIdentity(learned).second == 0) {
          // Not pre-trained, unless a writer without an atomic exchange (NFS) has moved
          // learned/ aside and not yet put the new one in its place, or was killed then.
          const std::string aside = MovedAsideOf(learned);
          if (aside.empty()) break;
          if (attempt == 20) {
            *error = learned + " is missing and " + aside + " is there: a writer was "
                     "interrupted replacing it; run aqs_train or aqs_pipeline on the model "
                     "once, which puts it back";
            return false;
          }
          std::this_thread::sleep_for(std::chrono::milliseconds(50));
          continue;
        }
        if (attempt == 5) {
          *error = learned + ": cannot open the folder (" + std::strerror(code) + ")";
          return false;
        }
        continue;  // replaced between the two looks: again
      }
      const std::pair<dev_t, ino_t> before = {held.st_dev, held.st_ino};
      const bool read = ReadLearned(learned, learned + "/checkpoint.txt", &m, error);
      const bool same = DirectoryIdentity(learned) == before;
      ::close(fd);
      if (same) {
        if (!read) return false;
        break;
      }
      if (attempt == 5) {
        *error = learned + ": replaced by a writer every time it was read; try again";
        return false;
      }
    }
  }
  return true;
}

}  // namespace

bool LoadModel(const std::string& directory, ActiveModel* model_out, std::string* error) {
  const std::string& dir = directory;
  int version = 0;
  ActiveModel model;
  ManifestCounts counts;
  if (!ReadManifest(dir + "/model.txt", &version, error, &model.target_key, &counts)) {
    return false;
  }
  if (!ReadTetMesh(dir + "/mesh.mesh", &model.mesh, error) || !ReadStiffness(dir, &model, error) ||
      !ReadObj(dir + "/neutral.obj", &model.neutral, error) ||
      !CheckNeutralHasFaces(dir, model, error) || !ReadPoses(dir, &model, error) ||
      !ReadFixedVerticesAndBones(dir, &model, error) ||
      !CheckManifestCounts(dir, counts, model, error) || !ReadEmbedding(dir, &model, error) ||
      !ReadLearnedPart(dir, version, &model, error) || !ValidateModel(model, dir, error)) {
    return false;
  }
  if (model.decoder && model.fit_prior.empty() &&
      !LearnFitPrior(model, FitPriorOptions(), &model.fit_prior, error)) {
    *error = dir + ": no learned/prior.txt, and " + *error;
    return false;
  }
  *model_out = std::move(model);
  return true;
}

}  // namespace aqs
