// ContactSolver::Resolve: the path from rest to the pose (a continuation in t) and, at
// every step, detection/solve rounds with augmented-Lagrangian updates.

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <sstream>

#include <glog/logging.h>

#include "contact/contact_solver.h"
#include "contact/far_displacement.h"
#include "geometry/embedding.h"
#include "geometry/rigid_transform.h"
#include "physics/actuation.h"

namespace aqs {
namespace {

// Barycentric margin of self-contact residuals within a round: unlimited, a pair acts
// on its triangle's plane until the next detection (a pair switching off as its point
// slides past a margin makes the energy discontinuous, and Levenberg-Marquardt stalls).
constexpr double kResidualMargin = std::numeric_limits<double>::infinity();
// Likewise a pair keeps pushing a point that went deeper than max_depth within a round
// (max_depth only selects candidates): switching off there made the energy jump.
constexpr double kResidualDepth = std::numeric_limits<double>::infinity();
// Largest augmented-Lagrangian offset of a self-contact point, in thicknesses.
constexpr double kMaxOffset = 10.0;

std::vector<const Obstacle*> Pointers(const std::vector<std::unique_ptr<Obstacle>>& obstacles) {
  std::vector<const Obstacle*> pointers;
  for (const auto& obstacle : obstacles) pointers.push_back(obstacle.get());
  return pointers;
}

std::vector<std::unique_ptr<Obstacle>> PlaceAll(const std::vector<MovingObstacle>& obstacles,
                                                const std::vector<RigidTransform>& bones) {
  std::vector<std::unique_ptr<Obstacle>> placed;
  for (const MovingObstacle& obstacle : obstacles) placed.push_back(obstacle.Place(bones));
  return placed;
}

// Diagnostics (--v=2): if the largest force of the one-pair term `single` on a simulation
// vertex at state x (3 x num_vertices) exceeds *largest, it becomes *largest and *text
// describes the pair (kind, surface vertex, distance, offset, how far outside its feature,
// its fade variable, stiffness).
void NoteLargestPairForce(const SelfContactTerm& single, const SelfContactPair& pair,
                          const Eigen::Matrix3Xd& x, double* largest, std::string* text) {
  Eigen::Matrix3Xd gradient = Eigen::Matrix3Xd::Zero(3, x.cols());
  single.AddEnergyAndGradient(x, &gradient);
  const double force = gradient.colwise().norm().maxCoeff();
  if (!(force > *largest)) return;
  const Eigen::Vector3d p[4] = {pair.point.Position(x), pair.corner[0].Position(x),
                                pair.corner[1].Position(x), pair.corner[2].Position(x)};
  double s = 0, outside = 0, fade = 0;
  SelfContactDistance(pair, p, &s, nullptr, &outside);
  SelfContactFadeVariable(pair, p, &fade, nullptr);
  const bool edge = pair.kind == SelfContactPair::Kind::kEdgeEdge;
  std::ostringstream out;
  out << (edge ? "edge-edge" : "point-triangle") << " surface vertex " << pair.surface_vertex
      << " s " << s << " offset " << pair.offset << " outside " << outside
      << (edge ? " sine " : " triangle quality ") << fade << " k " << pair.stiffness
      << " largest force " << force;
  *largest = force;
  *text = out.str();
}

}  // namespace

bool ContactSolver::SolveRounds(const ActuationMatrix& a, const std::vector<RigidTransform>& bones,
                                const std::vector<const Obstacle*>& obstacles, int allowed_self,
                                int allowed_obstacle, double relative_force_tolerance,
                                const Eigen::Matrix3Xd& reference, const std::string& label,
                                PathState* state, ContactReport* report,
                                std::string* error) const {
  const BoundaryConditions bc = ModelBoundaryConditions(model_, bones);
  QuasistaticSolverOptions solver_options = options_.solver;
  solver_options.relative_force_tolerance = relative_force_tolerance;
  solver_options.num_threads = options_.num_threads;
  Eigen::Matrix3Xd& x = state->x;
  ContactOffsetRule offset_rule;
  offset_rule.thickness = options_.thickness;
  offset_rule.max_depth = options_.max_depth;
  offset_rule.max_outside = kResidualMargin;
  offset_rule.max_offset = kMaxOffset * options_.thickness;
  for (int round = 0; round < options_.max_rounds; ++round) {
    const Eigen::Matrix3Xd surface = EmbeddedPositions(model_.embedding, model_.mesh.tets, x);
    const ObstacleCandidates near = DetectObstacleContacts(surface, obstacles);
    std::vector<SelfContactPair> pairs =
        options_.self_contact ? DetectSelfContacts(surface) : std::vector<SelfContactPair>();
    for (SelfContactPair& pair : pairs) pair.offset = state->offsets.Of(pair);
    int edge_pairs = 0;
    if (options_.self_contact && options_.edge_contact) {
      for (SelfContactPair& pair : DetectEdgeContacts(surface, reference)) {
        pair.offset = state->offsets.Of(pair);
        pairs.push_back(pair);
        ++edge_pairs;
      }
    }
    const ObstacleContactTerm obstacle_term(
        near.points, Eigen::Map<const Eigen::VectorXd>(near.stiffness.data(), near.stiffness.size()),
        options_.thickness, obstacles);
    // Within a round, a pair keeps its triangle's plane (kResidualMargin); re-detection
    // in the next round pairs points with their new triangles.
    const SelfContactTerm self_term(pairs, options_.thickness, kResidualDepth, kResidualMargin);
    QuasistaticSolver solver(*physics_, bc, solver_options);
    solver.actuation() = a;
    solver.SetPositions(x);
    if (!near.points.empty()) solver.AddEnergyTerm(&obstacle_term);
    if (!pairs.empty()) solver.AddEnergyTerm(&self_term);
    const QuasistaticSolveReport solve = solver.Solve();
    if (solve.refused || (!solve.converged && !std::isfinite(solve.final_energy))) {
      *error = "the equilibrium with contact failed" + label + ": " + solve.Summary();
      return false;
    }
    ++report->rounds;
    report->converged = solve.converged;
    report->round_summaries.push_back("round " + std::to_string(round + 1) + label + ": " +
                                      std::to_string(near.points.size()) + " points near obstacles, " +
                                      std::to_string(pairs.size()) + " self-contact pairs (" +
                                      std::to_string(edge_pairs) + " edge-edge); " +
                                      solve.Summary());
    x = solver.positions();
    // Active contacts at the new state.
    report->obstacle_contacts = 0;
    for (size_t k = 0; k < near.points.size(); ++k) {
      Eigen::Vector3d gradient;
      if (obstacle_term.Distance(near.points[k].Position(x), &gradient, options_.thickness) <
          options_.thickness) {
        ++report->obstacle_contacts;
        state->touched[near.surface_vertices[k]] = 1;
      }
    }
    report->self_contacts = 0;
    Eigen::Matrix3Xd g = Eigen::Matrix3Xd::Zero(3, x.cols());
    double largest_force = 0;
    std::string largest_pair;
    for (const SelfContactPair& pair : pairs) {
      const bool edge = pair.kind == SelfContactPair::Kind::kEdgeEdge;
      const SelfContactTerm single({pair}, options_.thickness, kResidualDepth, kResidualMargin);
      if (single.AddEnergyAndGradient(x, &g) > 0) {
        if (VLOG_IS_ON(2)) NoteLargestPairForce(single, pair, x, &largest_force, &largest_pair);
        ++report->self_contacts;
        if (edge) {  // both edges' vertices
          for (int e : {pair.edge, pair.second_edge}) {
            state->touched[edges_(0, e)] = state->touched[edges_(1, e)] = 1;
          }
        } else {
          state->touched[pair.surface_vertex] = 1;
        }
      }
      // Augmented Lagrangian: the multiplier k * offset grows by k (thickness - s).
      if (options_.augmented_lagrangian) state->offsets.Update(pair, x, offset_rule);
    }
    if (!largest_pair.empty()) VLOG(2) << "round " << round + 1 << label << ": " << largest_pair;
    const Eigen::Matrix3Xd moved = EmbeddedPositions(model_.embedding, model_.mesh.tets, x);
    double depth = 0;
    int inside = 0;
    MeasurePenetration(moved, obstacles, &depth, &inside);
    // Self intersections that contact can tell apart: new pairs whose triangles were
    // apart at rest (those touching at rest, such as the ICT lips' corners, have no
    // defined side) and that face each other across the exclusion rings (folds of one
    // sheet, such as a mouth corner pressed flat, are no pairs of self contact's);
    // steps and rounds do not decide on the others.
    state->self_intersections = 0;
    if (options_.self_contact) state->self_intersections = CountSelfIntersections(moved).facing;
    state->obstacle_intersections = CountObstacleIntersections(moved, obstacles);
    if (solve.iterations == 0) break;  // no progress left to make with these candidates
    // Stop when nothing penetrates any more.
    if (inside == 0 && state->self_intersections <= allowed_self &&
        state->obstacle_intersections <= allowed_obstacle) {
      break;
    }
  }
  return true;
}

bool ContactSolver::Resolve(const ActuationMatrix& a, const std::vector<RigidTransform>& bones,
                            const std::vector<MovingObstacle>& obstacles,
                            const Eigen::Matrix3Xd& start, Eigen::Matrix3Xd* state,
                            ContactReport* report, std::string* error) const {
  CHECK_EQ(bones.size(), model_.bones.size()) << "Resolve: one transform per model bone";
  CHECK(a.cols() == model_.mesh.num_tets())
      << "Resolve: the actuation has " << a.cols() << " columns, the model "
      << model_.mesh.num_tets() << " elements";
  CHECK(start.cols() == model_.mesh.num_vertices())
      << "Resolve: the start has " << start.cols() << " vertices, the model's mesh "
      << model_.mesh.num_vertices();
  *report = ContactReport();
  const std::vector<std::unique_ptr<Obstacle>> placed = PlaceAll(obstacles, bones);
  const std::vector<const Obstacle*> final_obstacles = Pointers(placed);
  const Eigen::Matrix3Xd before = EmbeddedPositions(model_.embedding, model_.mesh.tets, start);
  report->before = Measure(before, final_obstacles);
  report->self_intersections_rest = static_cast<int>(rest_intersections_.size());
  // Nothing in contact yet (the report's "far" displacement is measured away from the
  // surface vertices in contact in any round), no augmented-Lagrangian offsets.
  PathState current;
  current.touched.assign(rest_surface_.cols(), 0);
  current.offsets = ContactOffsets(static_cast<int>(rest_surface_.cols()));
  // The path needs a start without penetrations: obstacles placed around the pose may
  // already hold the rest surface.
  const std::vector<RigidTransform> rest_bones(bones.size());
  const std::vector<std::unique_ptr<Obstacle>> rest_placed = PlaceAll(obstacles, rest_bones);
  double rest_depth = 0;
  int rest_inside = 0;
  MeasurePenetration(rest_surface_, Pointers(rest_placed), &rest_depth, &rest_inside);
  if (options_.path_steps > 0 && rest_inside > 0) {
    report->round_summaries.push_back(
        "no path from rest: the rest surface has " + std::to_string(rest_inside) +
        " points inside the obstacles at their rest placement; rounds from the contact-free pose");
  }
  if (options_.path_steps <= 0 || rest_inside > 0) {
    current.x = start;
    if (!SolveRounds(a, bones, final_obstacles, 0, 0, options_.solver.relative_force_tolerance,
                     rest_surface_, "", &current, report, error)) {
      return false;
    }
  } else {
    // From rest, where the only intersections are those of the rest surface (not "new")
    // and whichever pairs the obstacles cross there.
    current.x = model_.mesh.vertices;
    current.obstacle_intersections =
        CountObstacleIntersections(rest_surface_, Pointers(rest_placed));
    current.self_intersections = 0;
    const double full_step = 1.0 / options_.path_steps;
    // The shortest step halving may try: an absolute floor (a floor per accepted step let
    // the steps shrink geometrically toward a crossing contact cannot prevent, without
    // end: 145 attempts for 8 steps on the demo, and t + step == t in a replica).
    const double min_step = std::ldexp(full_step, -options_.max_step_halvings);
    double t = 0.0, step = full_step;
    while (t < 1.0) {
      const double t_next = t + step > 1.0 - 1e-9 ? 1.0 : t + step;
      std::vector<RigidTransform> bones_t(bones.size());
      for (size_t b = 0; b < bones.size(); ++b) bones_t[b] = InterpolateRigidTransform(bones[b], t_next);
      const ActuationMatrix a_t =
          (1.0 - t_next) * IdentityActuations(static_cast<int>(a.cols())) + t_next * a;
      const std::vector<std::unique_ptr<Obstacle>> placed_t = PlaceAll(obstacles, bones_t);
      const std::vector<const Obstacle*> obstacles_t = Pointers(placed_t);
      std::ostringstream t_text;
      t_text.precision(4);
      t_text << t_next;
      const std::string label = " at t " + t_text.str();
      // The step's rounds start from the current state; a step that is halved leaves
      // it as it was (positions, contacts and offsets).
      PathState next = current;
      const Eigen::Matrix3Xd reference =
          EmbeddedPositions(model_.embedding, model_.mesh.tets, current.x);
      const double tolerance = t_next < 1.0 ? std::max(options_.path_relative_force_tolerance,
                                                       options_.solver.relative_force_tolerance)
                                            : options_.solver.relative_force_tolerance;
      if (!SolveRounds(a_t, bones_t, obstacles_t, current.self_intersections,
                       current.obstacle_intersections, tolerance, reference, label, &next, report,
                       error)) {
        return false;
      }
      if ((next.self_intersections > current.self_intersections ||
           next.obstacle_intersections > current.obstacle_intersections) &&
          0.5 * (t_next - t) >= min_step * (1.0 - 1e-9)) {
        step = 0.5 * (t_next - t);  // half the step taken (the last one may be short)
        ++report->path_halvings;
        report->round_summaries.push_back(
            "step to t " + t_text.str() + " adds intersecting pairs (self, facing, " +
            std::to_string(current.self_intersections) + " -> " +
            std::to_string(next.self_intersections) + ", obstacles " +
            std::to_string(current.obstacle_intersections) + " -> " +
            std::to_string(next.obstacle_intersections) + "): halved");
        continue;
      }
      current = std::move(next);
      t = t_next;
      ++report->path_steps;
      step = std::min(full_step, 2.0 * step);
    }
  }
  *state = current.x;
  const Eigen::Matrix3Xd after = EmbeddedPositions(model_.embedding, model_.mesh.tets, current.x);
  report->after = Measure(after, final_obstacles);
  const Eigen::VectorXd moved = (after - before).colwise().norm();
  report->mean_displacement = moved.mean();
  report->max_displacement = moved.maxCoeff();
  report->far_distance = 4.0 * options_.search_radius;
  report->max_far_displacement =
      MaxFarDisplacement(after, moved, current.touched, report->far_distance);
  return true;
}

}  // namespace aqs
