#include "jobs/collide_job.h"

#include <algorithm>
#include <filesystem>
#include <memory>
#include <sstream>

#include "contact/read_obstacles.h"
#include "fit/latent_fit.h"
#include "geometry/points_near_model.h"
#include "jobs/deformed_output.h"
#include "jobs/model_pose.h"
#include "mesh/mesh_io.h"
#include "mesh/ply_io.h"
#include "model/model_io.h"
#include "util/atomic_file.h"
#include "util/input_file.h"
#include "util/option_checks.h"
#include "util/wall_timer.h"

namespace aqs {
namespace {

CollideJobResult Fail(JobStatus status, const std::string& message) {
  CollideJobResult result;
  result.status = status;
  result.message = message;
  return result;
}


// The flags' outputs: a volume of a known kind, and every path writable, none inside
// the model, the latent or an obstacle file, and no two at one path (checked before any
// work).
bool CheckCollideOutputs(const CollideJobOptions& options, std::string* error) {
  if (!options.output_volume.empty() && !IsDeformedMeshOutputPath(options.output_volume)) {
    *error = options.output_volume + ": unknown output extension; known: .mesh, .vtu, .obj";
    return false;
  }
  std::vector<ObstacleSpec> obstacles;
  if (!ParseObstacleSpecs(options.obstacles, &obstacles, error)) return false;
  if (obstacles.empty() && !options.contact.self_contact) {
    *error = "no contact to resolve: give --obstacles, or leave --self_contact on (the "
             "result would be the pose without contact)";
    return false;
  }
  const std::vector<const std::string*> outputs = {
      &options.output, &options.output_before, &options.output_volume,
      &options.output_intersections, &options.report};
  for (const std::string* path : outputs) {
    const std::string& output = *path;
    if (output.empty()) continue;
    if (!CheckOutputFile(output, error) || !CheckOutputApart(output, options.model, error) ||
        !CheckOutputApart(output, options.latent, error)) {
      return false;
    }
    for (const ObstacleSpec& obstacle : obstacles) {
      if (!CheckOutputApart(output, obstacle.path, error)) return false;
    }
  }
  std::vector<std::string> paths;
  for (const std::string* output : outputs) paths.push_back(*output);
  return CheckOutputsDistinct(paths, error);
}

// The contact options against `model`: distances within kMaxDistanceInModelSizes of the
// model's size (beyond it they mean a unit mistake, and make the candidate search and
// the report's "far" distances meaningless), contact vertices on its surface.
bool CheckContactForModel(const ContactOptions& contact, const ActiveModel& model,
                          std::string* error) {
  const double size = (model.neutral.vertices.rowwise().maxCoeff() -
                       model.neutral.vertices.rowwise().minCoeff()).norm();
  const double limit = kMaxDistanceInModelSizes * size;
  for (const auto& [field, value] :
       {std::pair<const char*, double>{"contact.thickness", contact.thickness},
        {"contact.search_radius", contact.search_radius},
        {"contact.max_depth", contact.max_depth},
        {"contact.rest_tolerance", contact.rest_tolerance},
        {"contact.margin", contact.margin}}) {
    if (!(value <= limit)) {
      std::ostringstream out;
      out << field << " (" << value << ") is more than " << kMaxDistanceInModelSizes
          << " times the model's size (" << size << ")";
      *error = out.str();
      return false;
    }
  }
  for (int v : contact.surface_vertices) {
    if (v >= model.num_surface_vertices()) {
      *error = "contact vertex " + std::to_string(v) + " is outside the surface's " +
               std::to_string(model.num_surface_vertices()) + " vertices";
      return false;
    }
  }
  return true;
}

// The pose without contact: its equilibrium *start and surface *surface_before (a
// training pose from the equilibrium training left: the energy is not convex, and from
// rest the solve may take another branch or crawl). If it fails, its unconverged surface
// is still written to options.output_before, for inspection.
bool SimulateWithoutContact(const CollideJobOptions& options, const ActiveModel& model,
                            const ModelPose& pose, Eigen::Matrix3Xd* start,
                            Eigen::Matrix3Xd* surface_before, std::ostream& log,
                            std::string* error) {
  LatentFitOptions fit_options;
  fit_options.solver = options.contact.solver;
  fit_options.num_threads = options.contact.num_threads;
  LatentFitter fitter(model, fit_options);
  fitter.set_bone_transforms(pose.bones);
  if (pose.training_pose >= 0) fitter.StartFromTrainingPose(pose.training_pose);
  if (fitter.Simulate(pose.latent, start, surface_before, error)) return true;
  std::string write_error;
  if (!options.output_before.empty() && surface_before->allFinite() &&
      surface_before->cols() == model.num_surface_vertices()) {
    SurfaceMesh before = model.neutral;
    before.vertices = *surface_before;
    if (WriteObj(options.output_before, before, &write_error)) {
      log << "wrote " << options.output_before << " (NOT CONVERGED, for inspection)\n";
    }
  }
  *error = "the pose without contact: " + *error;
  return false;
}

// Writes the outputs of a resolved contact: the surface with contact, the one before
// it, the surface with contact coloured by its new self-intersections (PLY), the volume
// (with the displacement by contact and from rest) and the report.
bool WriteCollideOutputs(const CollideJobOptions& options, const ActiveModel& model,
                         const ContactSolver& solver, const Eigen::Matrix3Xd& start,
                         const Eigen::Matrix3Xd& surface_before, const Eigen::Matrix3Xd& state,
                         const ContactReport& report, std::ostream& log, std::string* error) {
  SurfaceMesh surface = model.neutral;
  surface.vertices = EmbeddedPositions(model.embedding, model.mesh.tets, state);
  if (!WriteObj(options.output, surface, error)) return false;
  log << "wrote " << options.output << "\n";
  if (!options.output_before.empty()) {
    SurfaceMesh before = model.neutral;
    before.vertices = surface_before;
    if (!WriteObj(options.output_before, before, error)) return false;
    log << "wrote " << options.output_before << "\n";
  }
  if (!options.output_intersections.empty()) {
    const std::vector<double> field = solver.NewIntersectionField(surface.vertices);
    const double most = *std::max_element(field.begin(), field.end());
    if (!WritePlyWithScalar(options.output_intersections, surface, field, std::max(1.0, most),
                            error)) {
      return false;
    }
    log << "wrote " << options.output_intersections << "\n";
  }
  if (!options.output_volume.empty()) {
    const std::vector<VtuField> point_fields = {
        MakeVtuField("contact_displacement", state - start),
        MakeVtuField("displacement", state - model.mesh.vertices)};
    if (!WriteDeformedMesh(options.output_volume, model.mesh, state, point_fields, {}, error)) {
      return false;
    }
    log << "wrote " << options.output_volume << "\n";
  }
  return options.report.empty() || WriteFileAtomically(options.report, report.ToText(), error);
}

}  // namespace

bool CollideJobOptions::Validate(std::string* error) const {
  std::string contact_error;
  const bool contact_ok = contact.Validate(&contact_error);
  return OptionChecks().Nested("contact", contact_ok, contact_error).Done(error);
}

CollideJobResult RunCollideJob(const CollideJobOptions& options, std::ostream& log) {
  WallTimer timer;
  std::string error;
  if (!options.Validate(&error)) return Fail(JobStatus::kBadInput, error);
  if (options.model.empty() || options.output.empty()) {
    return Fail(JobStatus::kBadInput, "--model and --output are required");
  }
  if (options.latent.empty() == options.pose.empty()) {
    return Fail(JobStatus::kBadInput, "give either --latent=Z.txt or --pose=NAME");
  }
  if (!CheckCollideOutputs(options, &error)) return Fail(JobStatus::kBadInput, error);
  ActiveModel model;
  if (!LoadModel(options.model, &model, &error)) return Fail(JobStatus::kBadInput, error);
  if (!model.decoder) {
    return Fail(JobStatus::kBadInput, options.model + ": the model is not trained");
  }
  ModelPose pose;
  std::vector<MovingObstacle> obstacles;
  if (!CheckContactForModel(options.contact, model, &error) ||
      !ResolveModelPose(model, options.latent, options.pose, &pose, &error) ||
      !ReadMovingObstacles(options.obstacles, model, &obstacles, log, &error)) {
    return Fail(JobStatus::kBadInput, error);
  }
  if (!pose.warning.empty()) log << "warning: " << pose.warning << "\n";
  Eigen::Matrix3Xd start, surface_before;
  if (!SimulateWithoutContact(options, model, pose, &start, &surface_before, log, &error)) {
    return Fail(JobStatus::kNotConverged, error);
  }
  ActuationMatrix a;
  DecoderWorkspace workspace;
  model.decoder->Decode(model.decoder_params.data(), pose.latent, &a, &workspace);
  ContactSolver solver(model, options.contact);
  CollideJobResult result;
  Eigen::Matrix3Xd state;
  if (!solver.Resolve(a, pose.bones, obstacles, start, &state, &result.report, &error)) {
    return Fail(JobStatus::kNotConverged, error);
  }
  for (const std::string& line : result.report.round_summaries) log << "  " << line << "\n";
  log << "contact: " << result.report.Summary() << "\n";
  if (!WriteCollideOutputs(options, model, solver, start, surface_before, state, result.report,
                           log, &error)) {
    return Fail(JobStatus::kBadInput, error);
  }
  if (!result.report.converged) {
    result.status = JobStatus::kNotConverged;
    result.message = "the equilibrium with contact was not reached to tolerance: " +
                     result.report.Summary();
  }
  log << "total " << timer.Seconds() << " s\n";
  return result;
}

}  // namespace aqs
