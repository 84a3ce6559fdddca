#include "jobs/prepare_job.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>

#include <Eigen/Geometry>

#include "dist/model_broadcast.h"
#include "geometry/embedding.h"
#include "geometry/points_near_model.h"
#include "geometry/vertex_normals.h"
#include "jobs/shared_pose_work.h"
#include "mesh/element_subset.h"
#include "mesh/mesh_io.h"
#include "model/model_directory.h"
#include "model/model_fingerprint.h"
#include "model/model_io.h"
#include "prepare/free_pieces.h"
#include "prepare/pose_files.h"
#include "prepare/target_store.h"
#include "util/atomic_file.h"
#include "util/fault_injection.h"
#include "util/keyed_store.h"
#include "util/make_directory.h"
#include "util/number_format.h"
#include "util/option_checks.h"
#include "util/wall_timer.h"

namespace aqs {
namespace {

// Keeps the elements whose centroid is in one of `boxes`, then drops unused vertices
// (*kept_vertices: per vertex kept, its index in `mesh`).
TetMesh CropToBoxes(const TetMesh& mesh, const std::vector<Eigen::AlignedBox3d>& boxes,
                    std::vector<int>* kept_vertices) {
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
  return ElementSubset(mesh, kept, kept_vertices);
}

// Composes a vertex renumbering: origin[v] becomes origin[kept[v]] (kept: per new vertex,
// its index before).
void ComposeOrigins(const std::vector<int>& kept, std::vector<int>* origin) {
  std::vector<int> composed(kept.size());
  for (size_t v = 0; v < kept.size(); ++v) composed[v] = (*origin)[kept[v]];
  origin->swap(composed);
}

}  // namespace

bool PrepareJobOptions::Validate(std::string* error) const {
  std::string meshing_error, boundary_error, mirror_error, halfway_error, targets_error;
  const bool meshing_ok = !tet_mesh.empty() || meshing.Validate(&meshing_error);
  const bool boundary_ok = boundary.Validate(&boundary_error);
  const bool mirror_ok = mirror.Validate(&mirror_error);
  const bool halfway_ok = halfway.Validate(&halfway_error);
  const bool targets_ok = targets.Validate(&targets_error);
  OptionChecks checks;
  checks.Nested("meshing", meshing_ok, meshing_error)
      .NonNegative("cut_margin", cut_margin)
      .IntInRange("min_elements_per_vertex", min_elements_per_vertex, 0, 24)
      // Any unit of stiffness fits; beyond, the forces of a mesh of ordinary size
      // overflow (1e300 wrote a model of infinite forces).
      .InRange("mu", mu, 1e-12, 1e12)
      .Nested("boundary", boundary_ok, boundary_error)
      .Nested("mirror", mirror_ok, mirror_error)
      .Nested("halfway", halfway_ok, halfway_error)
      .Nested("targets", targets_ok, targets_error)
      .IntInRange("num_threads", num_threads, 1, 1024)
      .Positive("max_memory_bytes", max_memory_bytes);
  for (const PlaneCut& cut : cuts) {
    checks.Require(cut.normal.allFinite() && cut.normal.norm() > 0 && std::isfinite(cut.offset),
                   "cuts must have a finite, non-zero normal and a finite offset");
  }
  return checks.Done(error);
}

namespace {

// The neutral surface (vertices and faces) and the pose surfaces (its vertex order, near
// it) into model->neutral and model->poses.
bool ReadNeutralAndPoses(const PrepareJobOptions& options, ActiveModel* model,
                         std::ostream& log, std::string* error) {
  if (!ReadObj(options.neutral, &model->neutral, error)) return false;
  if (model->neutral.num_vertices() == 0 || model->neutral.num_triangles() == 0) {
    *error = options.neutral + ": the neutral surface needs vertices and faces";
    return false;
  }
  // Volumes go as the size cubed: a neutral at one point, or of a size whose cube doubles
  // cannot hold, gave messages about an open patch or a pose far from the model.
  const double size = ModelSize(model->neutral.vertices);
  if (!std::isnormal(size * size * size)) {
    *error = options.neutral + ": the neutral surface's bounding-box diagonal is " +
             FormatDouble(size) +
             (size == 0.0 ? " (every vertex at one point)"
                          : " (its cube, the scale of a volume, is beyond what doubles hold: "
                            "scale the surfaces to another unit)");
    return false;
  }
  log << "neutral " << options.neutral << ": " << model->neutral.num_vertices() << " vertices, "
      << model->neutral.num_triangles() << " triangles\n";

  std::vector<std::string> names;
  std::vector<Eigen::Matrix3Xd> surfaces;
  if (!ReadPoseSurfaces(options.pose_paths, model->neutral.num_vertices(), options.num_threads,
                        &names, &surfaces, error)) {
    return false;
  }
  bool all_neutral = true;
  for (size_t p = 0; p < names.size(); ++p) {
    if (!CheckPointsNearModel(options.pose_paths[p], model->neutral.vertices, surfaces[p],
                              error)) {
      return false;
    }
    // A surface given twice weighs twice in training (a copied file under two names).
    for (size_t q = 0; q < p; ++q) {
      if (surfaces[p] == surfaces[q]) {
        *error = options.pose_paths[p] + ": pose '" + names[p] + "' is the same surface as "
                 "pose '" + names[q] + "' (" + options.pose_paths[q] + ")";
        return false;
      }
    }
    all_neutral = all_neutral && surfaces[p] == model->neutral.vertices;
    TrainingPose pose;
    pose.name = names[p];
    pose.surface = surfaces[p];
    model->poses.push_back(pose);
  }
  if (all_neutral && !names.empty()) {
    *error = "every pose is the neutral surface " + options.neutral + ": nothing to learn";
    return false;
  }
  log << "poses: " << model->num_poses() << "\n";
  return true;
}

// The simulation mesh (read, or a lattice over the neutral within the memory limit),
// cropped to the keep boxes, without weakly held elements, cut by the planes (*cut_mesh:
// the cut's element copies) and validated, into model->mesh. *input_numbering: the
// read or made mesh's vertex count, and per vertex of the result its index there.
bool BuildSimulationMesh(const PrepareJobOptions& options, ActiveModel* model,
                         CutMesh* cut_mesh, ListNumbering* input_numbering, std::ostream& log,
                         std::string* error) {
  WallTimer timer;
  if (!options.tet_mesh.empty()) {
    if (!ReadTetMesh(options.tet_mesh, &model->mesh, error)) return false;
    // A mesh in another unit or frame than the surface: most of the surface would hang
    // on the mesh's nearest faces (a mesh in mm for a face in cm: 8423 of 13294 surface
    // vertices outside, the model written all the same).
    const Eigen::Matrix3Xd& neutral = model->neutral.vertices;
    const Eigen::AlignedBox3d mesh_box(model->mesh.vertices.rowwise().minCoeff(),
                                       model->mesh.vertices.rowwise().maxCoeff());
    const Eigen::AlignedBox3d surface_box(neutral.rowwise().minCoeff(),
                                          neutral.rowwise().maxCoeff());
    const double ratio = mesh_box.diagonal().norm() / surface_box.diagonal().norm();
    if (!(ratio >= 0.25 && ratio <= 4.0) || !mesh_box.contains(surface_box.center())) {
      std::ostringstream out;
      out << options.tet_mesh << ": the simulation mesh's box (diagonal "
          << mesh_box.diagonal().norm() << ", centre " << mesh_box.center().transpose()
          << ") does not match the neutral surface's (diagonal " << surface_box.diagonal().norm()
          << ", centre " << surface_box.center().transpose()
          << "): is it in another unit or frame?";
      *error = out.str();
      return false;
    }
    log << "simulation mesh " << options.tet_mesh;
  } else {
    // The lattice's memory, from the surface's bounding box, before it is built.
    double lattice_elements = 0.0;
    const Eigen::Matrix3Xd& neutral = model->neutral.vertices;
    const double lattice_bytes =
        SurfaceTetMeshMemoryBytes(neutral.rowwise().minCoeff(), neutral.rowwise().maxCoeff(),
                                  options.meshing, &lattice_elements);
    std::ostringstream details;
    details.precision(3);
    details << "a lattice of " << lattice_elements << " elements at spacing "
            << options.meshing.spacing << " over the neutral's bounding box";
    if (!CheckMemoryEstimate(lattice_bytes, options.max_memory_bytes, "meshing the neutral",
                             details.str(), error)) {
      return false;
    }
    SurfaceTetMeshStats stats;
    if (!MeshSurfaceInterior(model->neutral.vertices, model->neutral.triangles, options.meshing,
                             &model->mesh, error, &stats)) {
      *error = options.neutral + ": " + *error;
      return false;
    }
    log << "simulation mesh: " << (options.meshing.type == LatticeType::kBcc ? "BCC" : "Kuhn")
        << " lattice, spacing " << options.meshing.spacing;
    if (options.meshing.shell_thickness > 0) log << ", shell " << options.meshing.shell_thickness;
  }
  input_numbering->num_vertices = model->mesh.num_vertices();
  std::vector<int>* input_vertex = &input_numbering->origin;
  input_vertex->resize(model->mesh.num_vertices());
  for (int v = 0; v < model->mesh.num_vertices(); ++v) (*input_vertex)[v] = v;
  std::vector<int> kept;
  if (!options.keep_boxes.empty()) {
    model->mesh = CropToBoxes(model->mesh, options.keep_boxes, &kept);
    ComposeOrigins(kept, input_vertex);
    if (model->mesh.num_tets() == 0) {
      *error = "no simulation element lies inside the --keep_box boxes";
      return false;
    }
  }
  {
    // Vertices that one or two elements hold (outer corners of elements kept for a
    // surface vertex, the boxes' edges) make equilibria unstable.
    int pruned = 0;
    model->mesh =
        PruneWeaklyHeldElements(model->mesh, options.min_elements_per_vertex, &pruned, &kept);
    ComposeOrigins(kept, input_vertex);
    if (model->mesh.num_tets() == 0) {
      *error = "no simulation element is left after removing those at vertices held by fewer "
               "than " + std::to_string(options.min_elements_per_vertex) + " elements";
      return false;
    }
    if (pruned > 0) {
      log << "; " << pruned << " element(s) at vertices held by fewer than "
          << options.min_elements_per_vertex << " elements removed";
    }
  }
  if (!options.cuts.empty()) {
    *cut_mesh = ApplyPlaneCuts(model->mesh, options.cuts);
    log << "; " << options.cuts.size() << " cut(s) duplicated "
        << cut_mesh->mesh.num_tets() - model->mesh.num_tets() << " elements";
    model->mesh = cut_mesh->mesh;
    ComposeOrigins(cut_mesh->original_vertex, input_vertex);  // a ghost: its original's
  }
  if (!ValidateTetMesh(model->mesh, "simulation mesh", error)) return false;
  log << ": " << model->mesh.num_vertices() << " vertices, " << model->mesh.num_tets()
      << " elements (" << timer.Seconds() << " s)\n";
  return true;
}

// Whether the volumetric targets' embedded simulations (one solver per thread, and
// every pose's target) fit in options.max_memory_bytes; false with *error if not.
bool CheckTargetMemory(const PrepareJobOptions& options, const ActiveModel& model,
                       std::string* error) {
  const double elements = model.mesh.num_tets();
  const double solvers = std::max(1, std::min(options.num_threads, model.num_poses()));
  const double bytes = solvers * EquilibriumSolverMemoryBytes(elements) +
                       sizeof(double) * 6.0 * elements * model.num_poses();
  std::ostringstream details;
  details.precision(3);
  details << elements << " elements, " << solvers << " solver(s) in parallel, "
          << model.num_poses() << " poses";
  return CheckMemoryEstimate(bytes, options.max_memory_bytes,
                             "the volumetric targets' embedded simulation", details.str(), error);
}

// The neutral's vertices embedded in the simulation mesh (model->embedding), on their
// side of each cut.
void EmbedNeutral(const PrepareJobOptions& options, const CutMesh& cut_mesh, ActiveModel* model,
                  std::ostream& log) {
  WallTimer timer;
  model->embedding = EmbedPoints(model->mesh, model->neutral.vertices, options.num_threads);
  if (!options.cuts.empty()) {
    const int moved = AssignEmbeddingSides(
        cut_mesh, options.cuts, model->neutral.vertices,
        VertexNormals(model->neutral.vertices, model->neutral.triangles), options.cut_margin,
        &model->embedding);
    log << "cuts: " << moved << " surface vertices moved to their side's element copy\n";
  }
  int outside = 0;
  double farthest = 0;
  for (double d : model->embedding.outside_distance) {
    outside += d > 0;
    farthest = std::max(farthest, d);
  }
  log << "embedding: " << model->neutral.num_vertices() << " surface vertices, " << outside
      << " outside the mesh (farthest " << farthest << ") (" << timer.Seconds() << " s)\n";
}

// Every piece of the simulation mesh held (a lattice around two surfaces, a user's mesh
// of several bodies, a part joined by an edge only): a free piece the surface is embedded
// in would move it, and is refused; one it is not (a lone element copy that cuts leave:
// two in the full face at 232,635 elements) is removed (RemoveFreePieces).
bool CheckMeshPieces(ActiveModel* model, std::ostream& log, std::string* error) {
  FreePieceRemoval removal;
  if (!RemoveFreePieces(model, &removal, error)) return false;
  if (removal.pieces > 0) {
    log << "removed " << removal.pieces << " free piece(s) of the simulation mesh that no "
        << "fixed vertex holds and no surface vertex is embedded in: " << removal.elements
        << " element(s) (the first was element " << removal.first_element << ") and "
        << removal.vertices << " vertices; " << model->mesh.num_vertices() << " vertices, "
        << model->mesh.num_tets() << " elements left\n";
  }
  return true;
}

// What PrepareJobOptions::keep_same_model does with the model at `output`.
enum class ExistingModel {
  kReplace,  // none there, or another model (or an unreadable one) without a learned state
  kKeep,     // `model` as built (ModelFingerprint) with targets of `target_key`
  kRefuse,   // another model (or an unreadable one) with a learned state, which preparing
             // anew would discard
};

// Compares the model at `output` with `model` as built and the targets' key; the log
// says what is kept or why the model is prepared anew; *error says why it is refused.
ExistingModel CheckExistingModel(const std::string& output, const std::string& target_key,
                                 const ActiveModel& model, std::ostream& log, std::string* error) {
  std::error_code code;
  if (!std::filesystem::exists(output + "/model.txt", code)) return ExistingModel::kReplace;
  ActiveModel existing;
  std::string load_error;
  if (!LoadModel(output, &existing, &load_error)) {
    // A damaged file of a pre-trained model: its learned state may be mended or kept.
    for (const char* decoder : {"/learned/decoder.txt", "/decoder.txt"}) {
      if (!std::filesystem::exists(output + decoder, code)) continue;
      *error = "the model at " + output + " cannot be read (" + load_error +
               "), and preparing it anew would discard its learned state (" + output + decoder +
               ", ...): mend or move the file, --restart replaces the model, or prepare into "
               "another --model";
      return ExistingModel::kRefuse;
    }
    log << "prepare: the model at " << output << " is prepared anew: it cannot be read ("
        << load_error << ")\n";
    return ExistingModel::kReplace;
  }
  const std::string learned =
      existing.decoder ? std::to_string(existing.checkpoint.iterations) + " training iterations"
                       : std::string("not pre-trained");
  std::string why;
  if (ModelFingerprint(existing) != ModelFingerprint(model)) {
    why = "its mesh, material, fixed vertices, bones, embedding or poses differ from these "
          "inputs' and flags'";
  } else if (FacesFingerprint(existing.neutral) != FacesFingerprint(model.neutral)) {
    why = "its neutral's faces differ from these inputs'";
  } else if (existing.target_key.empty()) {
    why = "it records no key of its targets (some did not converge, or an older version "
          "wrote it)";
  } else if (existing.target_key != target_key) {
    why = "its targets were made with other options; models prepared before 2026-12-06 "
          "have --inverted_targets=mirror";
  } else {
    log << "prepare: the model at " << output << " is the model of these inputs and flags "
        << "(targets " << target_key << "): kept, with its learned state (" << learned << ")\n";
    return ExistingModel::kKeep;
  }
  if (existing.decoder) {
    *error = "the model at " + output + " is not the model of these inputs and flags (" + why +
             "), and preparing it anew would discard its learned state (pre-trained, " +
             learned + "): --restart replaces it, or prepare into another --model";
    return ExistingModel::kRefuse;
  }
  log << "prepare: the model at " << output << " is prepared anew: " << why << "\n";
  return ExistingModel::kReplace;
}

// Without keep_same_model (--restart): says in the log what preparing anew discards of
// the model at `output`, if there is one (its learned state, its training iterations).
void LogReplacedModel(const std::string& output, std::ostream& log) {
  std::error_code code;
  if (!std::filesystem::exists(output + "/model.txt", code)) return;
  ActiveModel existing;
  std::string load_error;
  if (!LoadModel(output, &existing, &load_error)) {
    log << "prepare: --restart: the model at " << output << " is replaced (it cannot be read: "
        << load_error << ")\n";
  } else if (existing.decoder) {
    log << "prepare: --restart: the model at " << output << " is replaced, with its learned "
        << "state (pre-trained, " << existing.checkpoint.iterations
        << " training iterations), once its targets are made\n";
  } else {
    log << "prepare: --restart: the model at " << output << " (not pre-trained) is replaced\n";
  }
}

// What rank 0 (or the one process) prepares before the volumetric targets.
struct PreparedModel {
  PathLock lock;  // the output's writers' lock, held until the model is saved
  std::string output;
  ActiveModel model;
  VolumetricTargetOptions targets;  // with the job's threads
  std::string target_key;           // VolumetricTargetFingerprint
  WallTimer total;
};

// How far BuildModel got.
enum class BuildResult { kFailed, kKept, kMakeTargets };

// Everything before the volumetric targets: checks, the output's lock, the surfaces, the
// simulation mesh, the embedding, the boundary rules and, with keep_same_model, the
// comparison with the model at the output.
BuildResult BuildModel(const PrepareJobOptions& options, PreparedModel* prepared,
                       std::ostream& log, std::string* error) {
  if (!options.Validate(error)) return BuildResult::kFailed;
  if (options.neutral.empty()) {
    *error = "no neutral surface given (--neutral)";
    return BuildResult::kFailed;
  }
  if (options.output.empty()) {
    *error = "no output model directory given (--output)";
    return BuildResult::kFailed;
  }
  if (options.pose_paths.empty()) {
    *error = "the pose set is empty (--poses)";
    return BuildResult::kFailed;
  }
  // The output: locked, and checked before the work.
  std::string& output = prepared->output;
  output = options.output;
  while (output.size() > 1 && output.back() == '/') output.pop_back();
  {
    const std::filesystem::path parent = std::filesystem::path(output).parent_path();
    std::error_code code;
    if (!parent.empty()) std::filesystem::create_directories(parent, code);
    if (code) {
      *error = parent.string() + ": cannot create directory (" + code.message() + ")";
      return BuildResult::kFailed;
    }
  }
  if (!LockModelForWriting(output, &log, &prepared->lock, error)) return BuildResult::kFailed;
  if (!CheckModelDestination(output, options.overwrite, error)) {
    *error += " (--overwrite replaces it)";
    return BuildResult::kFailed;
  }
  ActiveModel& model = prepared->model;
  if (!ReadNeutralAndPoses(options, &model, log, error)) return BuildResult::kFailed;
  // Mirror images: surfaces now (the memory estimates count them), bone motions after the
  // boundary rules have fitted the given poses'.
  const int given_poses = model.num_poses();
  std::vector<int> mirror_sources;
  if (options.mirror.enabled()) {
    log << "mirror images in the plane " << "xyz"[options.mirror.axis] << " = "
        << options.mirror.plane << ":\n";
    if (!AddMirrorPoses(options.mirror, &model, &mirror_sources, log, error)) {
      return BuildResult::kFailed;
    }
    log << "poses with their mirror images: " << model.num_poses() << "\n";
  }

  CutMesh cut_mesh;
  ListNumbering input_numbering;  // the vertices' numbering in --tet_mesh
  if (!BuildSimulationMesh(options, &model, &cut_mesh, &input_numbering, log, error)) {
    return BuildResult::kFailed;
  }
  model.mu = Eigen::VectorXd::Constant(model.mesh.num_tets(), options.mu);
  if (!CheckTargetMemory(options, model, error)) return BuildResult::kFailed;
  EmbedNeutral(options, cut_mesh, &model, log);

  std::string rules_log;
  std::vector<std::string> pose_names;
  for (const TrainingPose& pose : model.poses) pose_names.push_back(pose.name);
  BoundaryRuleOptions boundary = options.boundary;
  boundary.num_threads = options.num_threads;
  // --fixed_list indexes the vertices of --tet_mesh, which cropping, pruning and cuts
  // renumber; without --tet_mesh, those of the simulation mesh prepare makes.
  if (!ApplyBoundaryRules(boundary, model.mesh, model.neutral, pose_names,
                          options.tet_mesh.empty() ? nullptr : &input_numbering, &model,
                          &rules_log, error)) {
    return BuildResult::kFailed;
  }
  log << rules_log;
  if (!CheckMeshPieces(&model, log, error)) return BuildResult::kFailed;
  if (!mirror_sources.empty()) {
    MirrorBoneTransforms(options.mirror, mirror_sources, given_poses, &model);
    for (const Bone& bone : model.bones) {
      log << "bone '" << bone.name << "': in the " << mirror_sources.size()
          << " mirror images, the mirror image of its motion in their sources\n";
    }
  }
  if (options.halfway.enabled) {
    log << "halfway poses:\n";
    int added = 0;
    if (!AddHalfwayPoses(options.halfway, &model, &added, log, error)) {
      return BuildResult::kFailed;
    }
    log << "poses with their halfway poses: " << model.num_poses() << " (" << added
        << " added)\n";
    if (!CheckTargetMemory(options, model, error)) return BuildResult::kFailed;
  }

  prepared->targets = options.targets;
  prepared->targets.num_threads = options.num_threads;
  prepared->target_key = VolumetricTargetFingerprint(prepared->targets, model);
  if (options.keep_same_model) {
    const ExistingModel existing =
        CheckExistingModel(output, prepared->target_key, model, log, error);
    if (existing == ExistingModel::kRefuse) return BuildResult::kFailed;
    if (existing == ExistingModel::kKeep) {
      // A run stopped after it installed this model but before it removed its targets'
      // store left the store (under the model's lock here, so no run is using it). A
      // store of other options (a stopped run's that may resume) stays.
      const std::string store = TargetStorePath(output);
      std::error_code code;
      if (std::filesystem::exists(store, code) &&
          ReadWholeFile(store + "/key.txt") == TargetStoreKey(prepared->targets, model)) {
        std::string store_error;
        if (RemoveDirectory(store, &store_error)) {
          log << "cleanup: removed " << store << ", the targets' store of a run stopped after "
              << "it wrote the model\n";
        } else {
          log << "warning: " << store_error << " (the targets kept while preparing)\n";
        }
      }
      return BuildResult::kKept;
    }
  } else {
    LogReplacedModel(output, log);
  }
  return BuildResult::kMakeTargets;
}


// The volumetric targets (shared among the ranks of `comm` if not null: every rank
// calls MakeVolumetricTargetsOnRanks) and the model saved; on rank 0 or the one process.
bool FinishModel(const PrepareJobOptions& options, const Communicator* comm,
                 PreparedModel* prepared, std::ostream& log, std::string* error,
                 JobStatus* status) {
  ActiveModel& model = prepared->model;
  VolumetricTargetOptions& targets = prepared->targets;
  const std::string& output = prepared->output;
  WallTimer timer;
  log << "volumetric targets by embedded simulation:\n";
  // Each pose's target is kept beside the model as it is made, for a rerun after a stop.
  targets.store_directory = TargetStorePath(output);
  std::vector<std::string> unconverged;
  if (comm != nullptr) {
    if (!MakeVolumetricTargetsOnRanks(*comm, targets, &model, log, error, &unconverged)) {
      return false;
    }
  } else if (!MakeVolumetricTargets(targets, &model, log, error, &unconverged)) {
    return false;
  }
  // Over the poses that have a target (a pose whose embedded simulation ended in a state
  // that is not finite has none, and no error to count as 0).
  double sum = 0, worst = 0;
  int with_target = 0;
  for (const TrainingPose& pose : model.poses) {
    if (pose.target.cols() == 0) continue;
    sum += pose.embedding_mean_error;
    worst = std::max(worst, pose.embedding_max_error);
    ++with_target;
  }
  log << "targets: mean surface error " << (with_target > 0 ? sum / with_target : 0.0) << ", max "
      << worst;
  if (with_target < model.num_poses()) {
    log << " (over " << with_target << " poses; " << model.num_poses() - with_target
        << " without a target)";
  }
  log << " (" << timer.Seconds() << " s)\n";
  if (unconverged.empty()) model.target_key = prepared->target_key;
  SaveModelOptions save;
  save.overwrite = options.overwrite;
  if (!SaveModel(output, model, save, error)) return false;
  log << "wrote model " << options.output << " (" << prepared->total.Seconds() << " s in all)\n";
  FaultPoint("prepare:model_written");  // a kill here leaves the targets' store
  for (const std::string& store :
       {targets.store_directory, KeyedStore::PreviousPath(targets.store_directory)}) {
    std::string store_error;
    if (!RemoveDirectory(store, &store_error)) {
      log << "warning: " << store_error << " (the targets kept while preparing)\n";
    }
  }
  if (!unconverged.empty()) {
    *status = JobStatus::kNotConverged;
    *error = "the embedded simulation did not converge for " + std::to_string(unconverged.size()) +
             " of " + std::to_string(model.num_poses()) + " poses; the model was written with " +
             "their targets from the states the solves ended in, for inspection (first: " +
             unconverged.front() + ")";
    return false;
  }
  *status = JobStatus::kOk;
  return true;
}

// On a rank other than 0 of a distributed prepare: waits for rank 0's model, if it
// makes targets, and makes its share of them (options.targets and num_threads only).
bool ServePrepare(const PrepareJobOptions& options, const Communicator& comm,
                  std::string* error, JobStatus* status) {
  *status = JobStatus::kBadInput;
  int make_targets = 0;
  comm.Broadcast(&make_targets, 1, 0);
  if (make_targets) {
    ActiveModel model;
    if (!BroadcastModel(comm, &model, error)) return false;
    VolumetricTargetOptions targets = options.targets;
    targets.num_threads = options.num_threads;
    targets.store_directory.clear();
    std::ostringstream quiet;  // sent to rank 0
    if (!MakeVolumetricTargetsOnRanks(comm, targets, &model, quiet, error, nullptr)) {
      return false;
    }
  }
  *status = JobStatus::kOk;
  return true;
}

// The job on rank 0 or in one process (`comm` null).
bool RunPrepare(const PrepareJobOptions& options, const Communicator* comm, std::ostream& log,
                std::string* error, JobStatus* status) {
  *status = JobStatus::kBadInput;
  PreparedModel prepared;
  const BuildResult built = BuildModel(options, &prepared, log, error);
  if (comm != nullptr) {
    int make_targets = built == BuildResult::kMakeTargets ? 1 : 0;
    comm->Broadcast(&make_targets, 1, 0);
  }
  if (built == BuildResult::kFailed) return false;
  if (built == BuildResult::kKept) {
    *status = JobStatus::kOk;
    return true;
  }
  if (comm != nullptr) {
    // The other ranks take rank 0's model (no targets yet).
    if (!BroadcastModel(*comm, &prepared.model, error)) return false;
  }
  return FinishModel(options, comm, &prepared, log, error, status);
}

}  // namespace

bool RunPrepareJob(const PrepareJobOptions& options, std::ostream& log, std::string* error,
                   JobStatus* status) {
  JobStatus ignored;
  if (status == nullptr) status = &ignored;
  const Communicator* comm = options.communicator;
  if (comm == nullptr || comm->size() == 1) return RunPrepare(options, nullptr, log, error, status);
  if (comm->is_root()) return RunPrepare(options, comm, log, error, status);
  return ServePrepare(options, *comm, error, status);
}

}  // namespace aqs
