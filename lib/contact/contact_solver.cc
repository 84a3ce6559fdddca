// ContactSolver: its options and the rest data it builds once (contact_solver.h lists
// the other sources).

#include "contact/contact_solver.h"

#include <algorithm>
#include <utility>

#include <glog/logging.h>

#include "geometry/embedding.h"
#include "geometry/triangle_intersections.h"
#include "geometry/vertex_normals.h"
#include "model/surface_springs.h"
#include "util/option_checks.h"
#include "util/parallel_for.h"

namespace aqs {

bool ContactOptions::Validate(std::string* error) const {
  std::string solver_error;
  const bool solver_ok = solver.Validate(&solver_error);
  return OptionChecks()
      .Positive("thickness", thickness)
      .Positive("relative_stiffness", relative_stiffness)
      .Positive("search_radius", search_radius)
      .IntInRange("exclusion_rings", exclusion_rings, 0, kMaxExclusionRings)
      .NonNegative("rest_tolerance", rest_tolerance)
      .Positive("max_depth", max_depth)
      .NonNegative("margin", margin)
      .InRange("max_normal_alignment", max_normal_alignment, -1.0, 1.0)
      .IntInRange("max_rounds", max_rounds, 1, kMaxContactRounds)
      .IntInRange("path_steps", path_steps, 0, kMaxPathSteps)
      .IntInRange("max_step_halvings", max_step_halvings, 0, 10)
      .Positive("path_relative_force_tolerance", path_relative_force_tolerance)
      .ReachableTolerance("path_relative_force_tolerance", path_relative_force_tolerance)
      .Nested("solver", solver_ok, solver_error)
      .ReachableTolerance("solver.relative_force_tolerance", solver.relative_force_tolerance)
      .IntInRange("num_threads", num_threads, 1, 1024)
      .Require(std::all_of(surface_vertices.begin(), surface_vertices.end(),
                           [](int v) { return v >= 0; }),
               "surface_vertices: every vertex index must be >= 0")
      .Done(error);
}

QuasistaticSolverOptions DefaultContactSolverOptions() {
  QuasistaticSolverOptions options;
  options.newton_relative_force = 0.1;
  // Every solve of a contact round has its own active pairs: a factor of another round is
  // a poor preconditioner, and inexact steps let crossed edges slip through (the
  // crossed-ridges test).
  options.factor_reuse.max_iterations = 0;
  // Penalty pairs make saddles common (the demo's mouthClose fit: one round took 37
  // projected Newton steps out of one, 53 factorizations; along negative curvature 20, and
  // 126 -> 93 factorizations for the whole path, the same result).
  options.negative_curvature_steps = true;
  return options;
}

ContactSolver::ContactSolver(const ActiveModel& model, const ContactOptions& options)
    : model_(model), options_(options) {
  std::string error;
  CHECK(options.Validate(&error)) << "ContactOptions: " << error;
  physics_ = std::make_unique<ShapeTargetModel>(model.mesh, model.mu);
  stencils_ = EmbeddingStencils(model.embedding, model.mesh.tets);
  stiffness_ = SurfaceSpringStiffness(model, options.relative_stiffness);
  rest_surface_ = EmbeddedPositions(model.embedding, model.mesh.tets, model.mesh.vertices);
  rest_normals_ = VertexNormals(rest_surface_, model.neutral.triangles);
  const int num_surface = model.num_surface_vertices();
  in_contact_.assign(num_surface, options.surface_vertices.empty() ? 1 : 0);
  for (int v : options.surface_vertices) {
    CHECK(v >= 0 && v < num_surface) << "contact surface vertex " << v;
    in_contact_[v] = 1;
  }
  std::vector<int> kept;
  for (Eigen::Index t = 0; t < model.neutral.triangles.cols(); ++t) {
    bool in = true;
    for (int k = 0; k < 3; ++k) in = in && in_contact_[model.neutral.triangles(k, t)];
    if (in) kept.push_back(static_cast<int>(t));
  }
  contact_triangles_.resize(3, kept.size());
  for (size_t i = 0; i < kept.size(); ++i) contact_triangles_.col(i) = model.neutral.triangles.col(kept[i]);
  TriangleIntersectionOptions intersection_options;
  intersection_options.num_threads = options.num_threads;
  FindIntersectingTrianglePairs(rest_surface_, contact_triangles_, intersection_options,
                                &rest_intersections_);
  intersects_at_rest_.assign(contact_triangles_.cols(), 0);
  for (const auto& pair : rest_intersections_) {
    intersects_at_rest_[pair.first] = intersects_at_rest_[pair.second] = 1;
  }
  // The contact triangles' edges.
  std::vector<std::pair<int, int>> edge_list;
  for (Eigen::Index t = 0; t < contact_triangles_.cols(); ++t) {
    for (int k = 0; k < 3; ++k) {
      const int a = contact_triangles_(k, t), b = contact_triangles_((k + 1) % 3, t);
      edge_list.emplace_back(std::min(a, b), std::max(a, b));
    }
  }
  std::sort(edge_list.begin(), edge_list.end());
  edge_list.erase(std::unique(edge_list.begin(), edge_list.end()), edge_list.end());
  edges_.resize(2, edge_list.size());
  edge_normals_.resize(3, edge_list.size());
  for (size_t e = 0; e < edge_list.size(); ++e) {
    edges_(0, e) = edge_list[e].first;
    edges_(1, e) = edge_list[e].second;
    edge_normals_.col(e) =
        (rest_normals_.col(edge_list[e].first) + rest_normals_.col(edge_list[e].second)).normalized();
  }
  // Edge rings of every surface vertex.
  const int ns = model.num_surface_vertices();
  std::vector<std::vector<int>> neighbours(ns);
  const Eigen::Matrix3Xi& tris = model.neutral.triangles;
  for (Eigen::Index t = 0; t < tris.cols(); ++t) {
    for (int a = 0; a < 3; ++a) {
      for (int b = 0; b < 3; ++b) {
        if (a != b) neighbours[tris(a, t)].push_back(tris(b, t));
      }
    }
  }
  for (auto& list : neighbours) {
    std::sort(list.begin(), list.end());
    list.erase(std::unique(list.begin(), list.end()), list.end());
  }
  // Breadth first, ring after ring, marking the vertices met with the start's index (a
  // re-sort of the whole ring at every step took 23 s at 30 rings on the demo face).
  rings_.resize(ns);
  const int threads = ParallelForThreadCount(options.num_threads, ns, 64);
  std::vector<std::vector<int>> seen(threads, std::vector<int>(ns, -1));
  ParallelFor(options.num_threads, 0, ns, [&](int thread, int v) {
    std::vector<int>& met = seen[thread];
    std::vector<int> ring = {v};
    met[v] = v;
    size_t begin = 0;
    for (int r = 0; r < options.exclusion_rings && begin < ring.size(); ++r) {
      const size_t end = ring.size();
      for (size_t i = begin; i < end; ++i) {
        for (int w : neighbours[ring[i]]) {
          if (met[w] == v) continue;
          met[w] = v;
          ring.push_back(w);
        }
      }
      begin = end;
    }
    std::sort(ring.begin(), ring.end());
    rings_[v] = std::move(ring);
  }, 64);
}

const std::vector<int>& ContactSolver::ExclusionRing(int v) const {
  CHECK(v >= 0 && v < static_cast<int>(rings_.size())) << "surface vertex " << v;
  return rings_[v];
}

ContactSolver::~ContactSolver() = default;

}  // namespace aqs
