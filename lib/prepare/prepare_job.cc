#include "prepare/prepare_job.h"

#include <filesystem>
#include <sstream>

#include "geometry/embedding.h"
#include "mesh/mesh_io.h"
#include "model/model_directory.h"
#include "model/model_io.h"
#include "prepare/pose_files.h"
#include "util/wall_timer.h"

namespace aqs {
namespace {

// Keeps the elements whose centroid is in one of `boxes`, then drops unused vertices.
TetMesh CropToBoxes(const TetMesh& mesh, const std::vector<Eigen::AlignedBox3d>& boxes) {
  std::vector<int> kept;
  for (int e = 0; e < mesh.num_tets(); ++e) {
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (int k = 0; k < 4; ++k) c += 0.25 * mesh.vertices.col(mesh.tets(k, e));
    for (const Eigen::AlignedBox3d& box : boxes) {
      if (box.contains(c)) {
        kept.push_back(e);
        break;
      }
    }
  }
  std::vector<int> renumber(mesh.num_vertices(), -1);
  int next = 0;
  TetMesh out;
  out.tets.resize(4, kept.size());
  for (size_t i = 0; i < kept.size(); ++i) {
    for (int k = 0; k < 4; ++k) {
      int& v = renumber[mesh.tets(k, kept[i])];
      if (v < 0) v = next++;
      out.tets(k, i) = v;
    }
  }
  out.vertices.resize(3, next);
  for (int v = 0; v < mesh.num_vertices(); ++v) {
    if (renumber[v] >= 0) out.vertices.col(renumber[v]) = mesh.vertices.col(v);
  }
  return out;
}

}  // namespace

bool RunPrepareJob(const PrepareJobOptions& options, std::ostream& log, std::string* error) {
  WallTimer total;
  if (options.neutral.empty()) {
    *error = "no neutral surface given (--neutral)";
    return false;
  }
  if (options.output.empty()) {
    *error = "no output model directory given (--output)";
    return false;
  }
  if (options.pose_paths.empty()) {
    *error = "the pose set is empty (--poses)";
    return false;
  }
  if (!(options.mu > 0)) {
    *error = "mu must be positive";
    return false;
  }
  // The output: locked, and checked before the work.
  std::string output = options.output;
  while (output.size() > 1 && output.back() == '/') output.pop_back();
  {
    const std::filesystem::path parent = std::filesystem::path(output).parent_path();
    std::error_code code;
    if (!parent.empty()) std::filesystem::create_directories(parent, code);
    if (code) {
      *error = parent.string() + ": cannot create directory (" + code.message() + ")";
      return false;
    }
  }
  PathLock lock;
  if (!LockModelForWriting(output, &log, &lock, error)) return false;
  if (!CheckModelDestination(output, options.overwrite, error)) {
    *error += " (--overwrite replaces it)";
    return false;
  }
  ActiveModel model;
  if (!ReadObj(options.neutral, &model.neutral, error)) return false;
  if (model.neutral.num_vertices() == 0 || model.neutral.num_triangles() == 0) {
    *error = options.neutral + ": the neutral surface needs vertices and faces";
    return false;
  }
  log << "neutral " << options.neutral << ": " << model.neutral.num_vertices() << " vertices, "
      << model.neutral.num_triangles() << " triangles\n";

  std::vector<std::string> names;
  std::vector<Eigen::Matrix3Xd> surfaces;
  if (!ReadPoseSurfaces(options.pose_paths, model.neutral.num_vertices(), options.num_threads,
                        &names, &surfaces, error)) {
    return false;
  }
  for (size_t p = 0; p < names.size(); ++p) {
    TrainingPose pose;
    pose.name = names[p];
    pose.surface = surfaces[p];
    model.poses.push_back(pose);
  }
  log << "poses: " << model.num_poses() << "\n";

  WallTimer timer;
  if (!options.tet_mesh.empty()) {
    if (!ReadTetMesh(options.tet_mesh, &model.mesh, error)) return false;
    log << "simulation mesh " << options.tet_mesh;
  } else {
    SurfaceTetMeshStats stats;
    if (!MeshSurfaceInterior(model.neutral.vertices, model.neutral.triangles, options.meshing,
                             &model.mesh, error, &stats)) {
      *error = options.neutral + ": " + *error;
      return false;
    }
    log << "simulation mesh: " << (options.meshing.type == LatticeType::kBcc ? "BCC" : "Kuhn")
        << " lattice, spacing " << options.meshing.spacing;
    if (options.meshing.shell_thickness > 0) log << ", shell " << options.meshing.shell_thickness;
  }
  if (!options.keep_boxes.empty()) {
    model.mesh = CropToBoxes(model.mesh, options.keep_boxes);
    if (model.mesh.num_tets() == 0) {
      *error = "no simulation element lies inside the --keep_box boxes";
      return false;
    }
  }
  CutMesh cut_mesh;
  if (!options.cuts.empty()) {
    cut_mesh = ApplyPlaneCuts(model.mesh, options.cuts);
    log << "; " << options.cuts.size() << " cut(s) duplicated "
        << cut_mesh.mesh.num_tets() - model.mesh.num_tets() << " elements";
    model.mesh = cut_mesh.mesh;
  }
  if (!ValidateTetMesh(model.mesh, "simulation mesh", error)) return false;
  log << ": " << model.mesh.num_vertices() << " vertices, " << model.mesh.num_tets()
      << " elements (" << timer.Seconds() << " s)\n";
  model.mu = Eigen::VectorXd::Constant(model.mesh.num_tets(), options.mu);

  timer.Reset();
  model.embedding = EmbedPoints(model.mesh, model.neutral.vertices, options.num_threads);
  if (!options.cuts.empty()) {
    const int moved = AssignEmbeddingSides(
        cut_mesh, options.cuts, model.neutral.vertices,
        VertexNormals(model.neutral.vertices, model.neutral.triangles), options.cut_margin,
        &model.embedding);
    log << "cuts: " << moved << " surface vertices moved to their side's element copy\n";
  }
  int outside = 0;
  double farthest = 0;
  for (double d : model.embedding.outside_distance) {
    outside += d > 0;
    farthest = std::max(farthest, d);
  }
  log << "embedding: " << model.neutral.num_vertices() << " surface vertices, " << outside
      << " outside the mesh (farthest " << farthest << ") (" << timer.Seconds() << " s)\n";

  std::string rules_log;
  std::vector<std::string> pose_names;
  for (const TrainingPose& pose : model.poses) pose_names.push_back(pose.name);
  BoundaryRuleOptions boundary = options.boundary;
  boundary.num_threads = options.num_threads;
  if (!ApplyBoundaryRules(boundary, model.mesh, model.neutral, pose_names, &model, &rules_log,
                          error)) {
    return false;
  }
  log << rules_log;

  timer.Reset();
  log << "volumetric targets by embedded simulation:\n";
  VolumetricTargetOptions targets = options.targets;
  targets.num_threads = options.num_threads;
  if (!MakeVolumetricTargets(targets, &model, log, error)) return false;
  double mean = 0, worst = 0;
  for (const TrainingPose& pose : model.poses) {
    mean += pose.embedding_mean_error / model.num_poses();
    worst = std::max(worst, pose.embedding_max_error);
  }
  log << "targets: mean surface error " << mean << ", max " << worst << " (" << timer.Seconds()
      << " s)\n";
  SaveModelOptions save;
  save.overwrite = options.overwrite;
  if (!SaveModel(output, model, save, error)) return false;
  log << "wrote model " << options.output << " (" << total.Seconds() << " s in all)\n";
  return true;
}

}  // namespace aqs
