#include "jobs/collide_job.h"

#include <algorithm>
#include <filesystem>
#include <memory>
#include <sstream>

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
  if (!options.output_volume.empty() && !IsDeformedMeshOutputPath(options.output_volume)) {
    return Fail(JobStatus::kBadInput,
                options.output_volume + ": unknown output extension; known: .mesh, .vtu, .obj");
  }
  for (const std::string* output : {&options.output, &options.output_before, &options.output_volume,
                                    &options.output_intersections, &options.report}) {
    if (!output->empty() && !CheckOutputFile(*output, &error)) {
      return Fail(JobStatus::kBadInput, error);
    }
  }
  ActiveModel model;
  if (!LoadModel(options.model, &model, &error)) return Fail(JobStatus::kBadInput, error);
  if (!model.decoder) return Fail(JobStatus::kBadInput, options.model + ": the model is not trained");
  {
    // Contact distances beyond the model's scale mean a unit mistake, and make the
    // candidate search and the report's "far" distances meaningless.
    const double size = (model.neutral.vertices.rowwise().maxCoeff() -
                         model.neutral.vertices.rowwise().minCoeff()).norm();
    const double limit = kMaxDistanceInModelSizes * size;
    for (const auto& [field, value] :
         {std::pair<const char*, double>{"contact.thickness", options.contact.thickness},
          {"contact.search_radius", options.contact.search_radius},
          {"contact.max_depth", options.contact.max_depth},
          {"contact.rest_tolerance", options.contact.rest_tolerance},
          {"contact.margin", options.contact.margin}}) {
      if (!(value <= limit)) {
        std::ostringstream out;
        out << field << " (" << value << ") is more than " << kMaxDistanceInModelSizes
            << " times the model's size (" << size << ")";
        return Fail(JobStatus::kBadInput, out.str());
      }
    }
  }
  for (int v : options.contact.surface_vertices) {
    if (v >= model.num_surface_vertices()) {
      return Fail(JobStatus::kBadInput, "contact vertex " + std::to_string(v) +
                                            " is outside the surface's " +
                                            std::to_string(model.num_surface_vertices()) + " vertices");
    }
  }
  ModelPose pose;
  if (!ResolveModelPose(model, options.latent, options.pose, &pose, &error)) {
    return Fail(JobStatus::kBadInput, error);
  }
  const std::vector<RigidTransform>& bones = pose.bones;
  // Obstacles, placed with their bones.
  std::vector<ObstacleSpec> specs;
  if (!ParseObstacleSpecs(options.obstacles, &specs, &error)) return Fail(JobStatus::kBadInput, error);
  std::vector<Eigen::Matrix3Xd> obstacle_vertices;
  std::vector<Eigen::Matrix3Xi> obstacle_triangles;
  if (!ReadObstacleSurfaces(specs, &obstacle_vertices, &obstacle_triangles, &error)) {
    return Fail(JobStatus::kBadInput, error);
  }
  std::vector<MovingObstacle> obstacles;
  for (size_t i = 0; i < specs.size(); ++i) {
    MovingObstacle obstacle;
    obstacle.name = specs[i].path;
    obstacle.vertices = obstacle_vertices[i];
    obstacle.triangles = obstacle_triangles[i];
    if (!specs[i].bone.empty()) {
      for (size_t k = 0; k < model.bones.size(); ++k) {
        if (model.bones[k].name == specs[i].bone) obstacle.bone = static_cast<int>(k);
      }
      if (obstacle.bone < 0) return Fail(JobStatus::kBadInput, "obstacle " + specs[i].path + ": the model has no bone '" + specs[i].bone + "'");
    }
    obstacles.push_back(std::move(obstacle));
    log << "obstacle " << specs[i].path << ": " << obstacle_triangles[i].cols() << " triangles"
        << (specs[i].bone.empty() ? "" : ", moving with " + specs[i].bone) << "\n";
  }
  // The pose without contact.
  LatentFitOptions fit_options;
  fit_options.solver = options.contact.solver;
  fit_options.num_threads = options.contact.num_threads;
  LatentFitter fitter(model, fit_options);
  fitter.set_bone_transforms(bones);
  // A training pose starts from the equilibrium training left (the energy is not convex;
  // from rest the solve may take another branch or crawl).
  if (pose.training_pose >= 0) fitter.StartFromTrainingPose(pose.training_pose);
  Eigen::Matrix3Xd start, surface_before;
  if (!fitter.Simulate(pose.latent, &start, &surface_before, &error)) {
    // No contact without the pose; its unconverged surface, for inspection.
    std::string write_error;
    if (!options.output_before.empty() && surface_before.allFinite() &&
        surface_before.cols() == model.num_surface_vertices()) {
      SurfaceMesh before = model.neutral;
      before.vertices = surface_before;
      if (WriteObj(options.output_before, before, &write_error)) {
        log << "wrote " << options.output_before << " (NOT CONVERGED, for inspection)\n";
      }
    }
    return Fail(JobStatus::kNotConverged, "the pose without contact: " + error);
  }
  ActuationMatrix a;
  DecoderWorkspace workspace;
  model.decoder->Decode(model.decoder_params.data(), pose.latent, &a, &workspace);
  ContactSolver solver(model, options.contact);
  CollideJobResult result;
  Eigen::Matrix3Xd state;
  if (!solver.Resolve(a, bones, obstacles, start, &state, &result.report, &error)) {
    return Fail(JobStatus::kNotConverged, error);
  }
  for (const std::string& line : result.report.round_summaries) log << "  " << line << "\n";
  log << "contact: " << result.report.Summary() << "\n";
  SurfaceMesh surface = model.neutral;
  surface.vertices = EmbeddedPositions(model.embedding, model.mesh.tets, state);
  if (!WriteObj(options.output, surface, &error)) return Fail(JobStatus::kBadInput, error);
  log << "wrote " << options.output << "\n";
  if (!options.output_before.empty()) {
    surface.vertices = surface_before;
    if (!WriteObj(options.output_before, surface, &error)) return Fail(JobStatus::kBadInput, error);
    log << "wrote " << options.output_before << "\n";
  }
  if (!options.output_intersections.empty()) {
    const std::vector<double> field = solver.NewIntersectionField(surface.vertices);
    const double most = *std::max_element(field.begin(), field.end());
    if (!WritePlyWithScalar(options.output_intersections, surface, field, std::max(1.0, most),
                            &error)) {
      return Fail(JobStatus::kBadInput, error);
    }
    log << "wrote " << options.output_intersections << "\n";
  }
  if (!options.output_volume.empty()) {
    const std::vector<VtuField> point_fields = {MakeVtuField("contact_displacement", state - start),
                                                MakeVtuField("displacement", state - model.mesh.vertices)};
    if (!WriteDeformedMesh(options.output_volume, model.mesh, state, point_fields, {}, &error)) {
      return Fail(JobStatus::kBadInput, error);
    }
    log << "wrote " << options.output_volume << "\n";
  }
  if (!options.report.empty()) {
    if (!WriteFileAtomically(options.report, result.report.ToText(), &error)) {
      return Fail(JobStatus::kBadInput, error);
    }
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
