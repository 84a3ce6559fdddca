#ifndef AQS_CONTACT_CONTACT_SOLVER_H_
#define AQS_CONTACT_CONTACT_SOLVER_H_

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "contact/contact_offsets.h"
#include "contact/contact_report.h"
#include "contact/obstacle.h"
#include "contact/obstacle_contact_term.h"
#include "contact/self_contact_pair.h"
#include "contact/self_contact_term.h"
#include "equilibrium/quasistatic_solver.h"
#include "model/active_model.h"

namespace aqs {

// The equilibrium options of contact solves: the defaults, but Newton steps from a
// largest force of 0.1 force_scale on (newton_relative_force; 1e-2 by default). With the
// contact terms' exact Hessians, Newton converges in 2 to 3 steps from there on the ICT
// demo poses, where Levenberg-Marquardt took up to 200 iterations to reach 1e-2. Also
// steps along negative curvature (negative_curvature_steps), no factor reuse.
QuasistaticSolverOptions DefaultContactSolverOptions();

struct ContactOptions {
  // The surface vertices that take part in contact (empty: all): points, and triangles
  // with all three corners in the set (e.g. the skin without the mouth socket the teeth
  // are rooted in). Intersection counts use the same triangles.
  std::vector<int> surface_vertices;
  // Contact thickness (model units): surfaces are kept at least this far apart, and from
  // obstacles; contacts end between 0 and this distance.
  double thickness = 0.05;
  // Penalty stiffness per unit surface area, relative to the material: point i gets
  // k_i = relative_stiffness * mean(mu) * A_i / h (A_i its share of the neutral surface's
  // area, h the mean element edge), as the attachments of prepare.
  // (1000: 100 left the ICT lips of mouthClose 182 new intersecting pairs -> 181, 1000
  // -> 28; see README.)
  double relative_stiffness = 1000.0;
  bool obstacle_contact = true;
  bool self_contact = true;
  // Candidates: surface points closer than this to an obstacle, and point-triangle
  // pairs of the surface closer than this to each other.
  double search_radius = 0.5;
  // Self contact: triangles within this many edge rings of a point never pair with it
  // (its own neighbourhood). At most kMaxExclusionRings: every surface vertex keeps its
  // rings, whose size grows with their square (on the demo face, 13,294 surface vertices:
  // 52 MB at 3 rings, 258 MB at 30, 773 MB at 100).
  int exclusion_rings = 3;
  // Self contact: a pair forms only if the point was on the outer side of the
  // triangle at rest (signed distance > -rest_tolerance) and is less than max_depth
  // behind it when candidates are detected (within a round it keeps acting deeper, so
  // that the energy stays continuous).
  double rest_tolerance = 0.02;
  double max_depth = 1.0;
  // Self contact: a point pairs with a triangle it projects into (barycentric
  // coordinates >= -margin) when candidates are detected.
  double margin = 0.05;
  // Self contact: surfaces must face each other: the point's rest normal and the
  // triangle's rest normal must satisfy n_point . n_triangle <= this (-0.5: more than
  // 120 degrees apart), which rules out pairs within one smooth sheet.
  double max_normal_alignment = -0.5;
  // Self contact: also edge-edge pairs, for crossings in which no vertex passes through a
  // triangle (e.g. lips that touch at rest at the mouth corners). Each surface edge pairs
  // with the nearest edge that faces it (max_normal_alignment, with the mean rest normal
  // of each edge's ends), lies outside its exclusion rings and whose closest points lie
  // on both edges (within margin); the side it keeps is the one the surfaces' normals
  // give at the start of the path step (or at rest without a path): each edge on the
  // outer side of the other's surface.
  bool edge_contact = true;
  // Detection/solve rounds (candidates are re-detected as the surface moves), per path
  // step.
  int max_rounds = 6;
  // Self contact: after every round, each pair's target distance is raised by what it
  // misses of the thickness (an augmented-Lagrangian multiplier update, offset =
  // multiplier / k), so that strongly pressed surfaces still end near the thickness
  // rather than through each other.
  bool augmented_lagrangian = true;
  // The path: the contact equilibrium is followed from rest (identity actuation, bones
  // at rest) to the pose, through the actuations a(t) = I + t (a - I) and the bones'
  // screw motions (InterpolateRigidTransform) for t = 1/path_steps, 2/path_steps, ..., 1,
  // each step starting from the last one, so that contacts are caught as surfaces
  // approach each other, not after they passed through (a model's lips can cross by
  // more than their thickness). A step that adds intersecting triangle pairs is halved,
  // down to 1 / (path_steps 2^max_step_halvings) (a step that short is taken whatever
  // it adds). 0: no path; the rounds start from the contact-free
  // equilibrium (enough for shallow penetrations, e.g. teeth); also when the rest
  // surface has points inside the obstacles at their rest placement (no clean start).
  // (Steps and rounds count the new self-intersecting pairs whose triangles were apart
  // at rest and face each other across the exclusion rings, SelfIntersectionCounts::
  // facing: pairs touching at rest have no defined side, and folds of one sheet, such
  // as a mouth corner pressed flat, are no pairs of self contact's. On two of the demo's
  // mouthClose fits, counting folds too took 2x and 5.7x the time, and left 2 and 32 of
  // them, against 42 and 15; docs/contact.md.)
  int path_steps = 8;
  int max_step_halvings = 3;
  // The relative force tolerance of the path's intermediate steps (the last one uses
  // solver.relative_force_tolerance; the larger of the two applies). On the ICT demo's
  // mouthClose, 1e-5 everywhere took 3.3 minutes; a trial with 1e-3 (and extra rounds for
  // an unconverged last step) took over 10, so looser is not known to be faster.
  double path_relative_force_tolerance = 1e-5;
  // The equilibrium solves: Levenberg-Marquardt, then Newton steps on the stiffness with
  // the contact terms' Hessians (solver.newton_relative_force; 0: LM only).
  QuasistaticSolverOptions solver = DefaultContactSolverOptions();
  int num_threads = 2;

  // Checks every field; false with *error naming the first bad one. Bounds the work:
  // path_steps <= kMaxPathSteps, max_rounds <= kMaxContactRounds, max_step_halvings
  // <= 10.
  bool Validate(std::string* error) const;
};

// The most path steps and rounds per step a contact solve takes (ContactOptions::Validate):
// each round is an equilibrium solve, and every step taken is at least
// 1 / (path_steps 2^max_step_halvings) long and tried at most max_step_halvings + 1
// times, so these bound the work of one aqs_collide run to
// kMaxPathSteps x 2^max_step_halvings x (max_step_halvings + 1) x kMaxContactRounds solves.
constexpr int kMaxPathSteps = 256;
constexpr int kMaxContactRounds = 64;
// The largest ContactOptions::exclusion_rings.
constexpr int kMaxExclusionRings = 30;

// Obstacle-contact candidates (ContactSolver::DetectObstacleContacts): the surface
// points near obstacles, with their stencils, stiffness and surface vertices.
struct ObstacleCandidates {
  std::vector<PointStencil> points;
  std::vector<double> stiffness;
  std::vector<int> surface_vertices;
};

// Contact as post-processing: re-solves a model's equilibrium for a given actuation
// with penalty terms keeping its surface out of rigid obstacles (ObstacleContactTerm) and
// out of itself (SelfContactTerm), in rounds that re-detect candidates (obstacle trees;
// a grid over the surface's triangles) as the surface moves. Its sources: the rest
// data (contact_solver.cc), the candidates (contact_candidates.cc), the path from rest
// and its rounds (contact_path.cc), the report's measurements (contact_report.cc).
class ContactSolver {
 public:
  // The model must outlive the solver. `options` must be valid (CHECK:
  // ContactOptions::Validate) and its surface_vertices in [0, the model's surface vertex
  // count) (CHECK; RunCollideJob reports both as user errors first).
  ContactSolver(const ActiveModel& model, const ContactOptions& options);
  // It keeps a reference to the model: a temporary one does not compile.
  ContactSolver(ActiveModel&& model, const ContactOptions& options) = delete;
  ~ContactSolver();

  // The equilibrium with contact for actuation a (6 x num_elements) and bone transforms
  // `bones` (one per model bone), into *state (3 x num_vertices), with the obstacles
  // placed by the bones, and what changed, into *report. `start` (3 x num_vertices) is
  // the contact-free equilibrium for a and bones: the reference of the report, and the
  // start of the rounds when options.path_steps is 0 (otherwise the path starts at
  // rest). Returns false with *error if an equilibrium cannot be reached (also for a
  // non-finite actuation: the solves refuse it). Each call is independent of the others
  // (the augmented-Lagrangian offsets are its own). Obstacles from files, one per closed
  // shell: ReadMovingObstacles (contact/read_obstacles.h), as aqs_collide reads them.
  bool Resolve(const ActuationMatrix& a, const std::vector<RigidTransform>& bones,
               const std::vector<MovingObstacle>& obstacles, const Eigen::Matrix3Xd& start,
               Eigen::Matrix3Xd* state, ContactReport* report, std::string* error) const;

  // The report's measurements of a surface state (3 x num_surface_vertices) with placed
  // obstacles: MeasurePenetration, CountSelfIntersections, CountObstacleIntersections.
  ContactMeasurement Measure(const Eigen::Matrix3Xd& surface,
                             const std::vector<const Obstacle*>& obstacles) const;
  // The deepest penetration of the surface into the obstacles and the count of points
  // inside; the intersecting triangle pairs of the surface with itself and with the
  // obstacles (CountSelfIntersections classifies them as SelfIntersectionCounts says).
  void MeasurePenetration(const Eigen::Matrix3Xd& surface,
                          const std::vector<const Obstacle*>& obstacles, double* max_depth,
                          int* points) const;
  SelfIntersectionCounts CountSelfIntersections(const Eigen::Matrix3Xd& surface) const;
  // Whether contact triangles `first` and `second` (columns of the contact triangles)
  // are a pair self contact acts on: no corner of one within the exclusion rings of a
  // corner of the other, and rest normals with dot <= options.max_normal_alignment.
  bool FacingAtRest(int first, int second) const;
  int CountObstacleIntersections(const Eigen::Matrix3Xd& surface,
                                 const std::vector<const Obstacle*>& obstacles) const;

  // Per surface vertex (surface: 3 x num_surface_vertices): the number of
  // self-intersecting triangle pairs that do not intersect at rest and that one of its
  // triangles takes part in (0 where the surface is clean), for viewing.
  std::vector<double> NewIntersectionField(const Eigen::Matrix3Xd& surface) const;

  // Candidates at a surface state (3 x num_surface_vertices). Obstacle contact: the
  // contact points closer than thickness + search_radius to an obstacle (none without
  // options.obstacle_contact).
  ObstacleCandidates DetectObstacleContacts(const Eigen::Matrix3Xd& surface,
                                            const std::vector<const Obstacle*>& obstacles) const;
  // Self contact: point-triangle pairs, each point with its nearest eligible triangle
  // (ContactOptions says which).
  std::vector<SelfContactPair> DetectSelfContacts(const Eigen::Matrix3Xd& surface) const;
  // Edge-edge candidates at a surface state, each keeping the side the surface normals
  // give at `reference` (a surface state without the crossings to prevent; both
  // 3 x num_surface_vertices).
  // pair.edge indexes edges().
  std::vector<SelfContactPair> DetectEdgeContacts(const Eigen::Matrix3Xd& surface,
                                                  const Eigen::Matrix3Xd& reference) const;
  // The edges of the contact triangles (2 x num_edges, surface vertices, first < second).
  const Eigen::Matrix2Xi& edges() const { return edges_; }
  // The surface vertices within exclusion_rings edge rings of surface vertex v (0 <= v <
  // num_surface_vertices: CHECK), v among them, ascending: those whose triangles v never
  // pairs with.
  const std::vector<int>& ExclusionRing(int v) const;

 private:
  // What one path step of a Resolve hands to the next: the positions x
  // (3 x num_vertices); per surface vertex, whether it was in contact in any round;
  // the augmented-Lagrangian offsets (SelfContactPair::offset) of point-triangle pairs,
  // per surface vertex, and of edge-edge pairs, per edge; the new self-intersecting
  // pairs that face each other (SelfIntersectionCounts::facing) and the pairs crossing
  // obstacles at x.
  struct PathState {
    Eigen::Matrix3Xd x;
    std::vector<char> touched;
    ContactOffsets offsets;
    int self_intersections = 0;
    int obstacle_intersections = 0;
  };

  // Detection/solve rounds for one actuation and placement from state->x, with
  // edge-edge pairs keeping their sides at the surface state `reference`, until the
  // surface has no more new self-intersecting pairs facing each other than
  // allowed_self, no more pairs crossing obstacles than allowed_obstacle and no point
  // inside an obstacle, or max_rounds, each solved to relative_force_tolerance. Updates
  // *state (positions, contacts, offsets, intersections at the result); the rounds'
  // lines are appended to report->round_summaries (with `label`), and report->rounds,
  // converged, obstacle_contacts and self_contacts are updated.
  bool SolveRounds(const ActuationMatrix& a, const std::vector<RigidTransform>& bones,
                   const std::vector<const Obstacle*>& obstacles, int allowed_self,
                   int allowed_obstacle, double relative_force_tolerance,
                   const Eigen::Matrix3Xd& reference, const std::string& label,
                   PathState* state, ContactReport* report, std::string* error) const;

  const ActiveModel& model_;
  ContactOptions options_;
  std::unique_ptr<ShapeTargetModel> physics_;
  std::vector<PointStencil> stencils_;
  Eigen::VectorXd stiffness_;     // per surface point
  Eigen::Matrix3Xd rest_surface_;
  Eigen::Matrix3Xd rest_normals_;  // per surface vertex
  // For each surface vertex, the vertices within exclusion_rings rings (sorted).
  std::vector<std::vector<int>> rings_;
  std::vector<char> in_contact_;           // per surface vertex: takes part in contact
  Eigen::Matrix3Xi contact_triangles_;     // triangles with all corners taking part
  Eigen::Matrix2Xi edges_;          // edges of contact_triangles_
  Eigen::Matrix3Xd edge_normals_;   // per edge: the mean rest normal of its ends
  std::vector<std::pair<int, int>> rest_intersections_;  // sorted pairs of contact_triangles_
  std::vector<char> intersects_at_rest_;  // per contact triangle: in rest_intersections_
};

}  // namespace aqs

#endif  // AQS_CONTACT_CONTACT_SOLVER_H_
