#include "contact/contact_solver.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <sstream>
#include <unordered_map>

#include <glog/logging.h>

#include "geometry/embedding.h"
#include "geometry/plane_cuts.h"
#include "geometry/rigid_transform.h"
#include "geometry/triangle_distance.h"
#include "geometry/triangle_intersections.h"
#include "mesh/mesh_measures.h"
#include "physics/actuation.h"
#include "util/parallel_for.h"
#include "util/option_checks.h"

namespace aqs {
namespace {

// Barycentric margin of self-contact residuals within a round: unlimited, a pair acts
// on its triangle's plane until the next detection (a pair switching off as its point
// slides past a margin makes the energy discontinuous, and Levenberg-Marquardt stalls).
constexpr double kResidualMargin = std::numeric_limits<double>::infinity();
// Likewise a pair keeps pushing a point that went deeper than max_depth within a round
// (max_depth only selects candidates): switching off there made the energy jump.
constexpr double kResidualDepth = std::numeric_limits<double>::infinity();
// Edge-edge pairs per edge at most (those with the smallest signed distances).
constexpr size_t kEdgePartners = 2;
// Edge-edge pairs whose side the surface normals tell less clearly than this (cosine of
// the common normal with the difference of the edges' normals) are left out.
constexpr double kMinSideCosine = 0.3;
// Largest augmented-Lagrangian offset of a self-contact point, in thicknesses.
constexpr double kMaxOffset = 10.0;

// A uniform grid over the triangles' bounding boxes for radius queries.
class TriangleGrid {
 public:
  TriangleGrid(const Eigen::Matrix3Xd& vertices, const Eigen::Matrix3Xi& triangles, double cell)
      : cell_(cell), num_triangles_(static_cast<int>(triangles.cols())) {
    lo_ = vertices.rowwise().minCoeff().array() - cell;
    for (Eigen::Index t = 0; t < triangles.cols(); ++t) {
      Eigen::Vector3d a = vertices.col(triangles(0, t)), b = a;
      for (int k = 1; k < 3; ++k) {
        a = a.cwiseMin(vertices.col(triangles(k, t)));
        b = b.cwiseMax(vertices.col(triangles(k, t)));
      }
      const Eigen::Vector3i ca = Cell(a), cb = Cell(b);
      for (int i = ca.x(); i <= cb.x(); ++i) {
        for (int j = ca.y(); j <= cb.y(); ++j) {
          for (int k = ca.z(); k <= cb.z(); ++k) cells_[Key(i, j, k)].push_back(static_cast<int>(t));
        }
      }
    }
  }

  // Triangles whose box comes within one cell of p, each once (in the order the cells
  // list them). `marks` (one per triangle, per thread; any initial values below 0) are
  // set to `stamp` for the triangles returned: stamps must differ between calls that
  // share marks (e.g. the query's index).
  void Near(const Eigen::Vector3d& p, int stamp, std::vector<int>* marks,
            std::vector<int>* out) const {
    out->clear();
    marks->resize(num_triangles_, -1);
    const Eigen::Vector3i c = Cell(p);
    for (int i = c.x() - 1; i <= c.x() + 1; ++i) {
      for (int j = c.y() - 1; j <= c.y() + 1; ++j) {
        for (int k = c.z() - 1; k <= c.z() + 1; ++k) {
          auto it = cells_.find(Key(i, j, k));
          if (it == cells_.end()) continue;
          for (int t : it->second) {
            if ((*marks)[t] == stamp) continue;
            (*marks)[t] = stamp;
            out->push_back(t);
          }
        }
      }
    }
  }

 private:
  Eigen::Vector3i Cell(const Eigen::Vector3d& p) const {
    return ((p - lo_) / cell_).array().floor().cast<int>();
  }
  static int64_t Key(int i, int j, int k) {
    return (static_cast<int64_t>(i) * 73856093) ^ (static_cast<int64_t>(j) * 19349663) ^
           (static_cast<int64_t>(k) * 83492791);
  }
  double cell_;
  int num_triangles_;
  Eigen::Vector3d lo_;
  std::unordered_map<int64_t, std::vector<int>> cells_;
};

}  // namespace

bool ContactOptions::Validate(std::string* error) const {
  std::string solver_error;
  const bool solver_ok = solver.Validate(&solver_error);
  return OptionChecks()
      .Positive("thickness", thickness)
      .Positive("relative_stiffness", relative_stiffness)
      .Positive("search_radius", search_radius)
      .IntInRange("exclusion_rings", exclusion_rings, 0, 100)
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
      .Done(error);
}

QuasistaticSolverOptions DefaultContactSolverOptions() {
  QuasistaticSolverOptions options;
  options.newton_relative_force = 0.1;
  // Every solve of a contact round has its own active pairs: a factor of another round is
  // a poor preconditioner, and inexact steps let crossed edges slip through (the
  // crossed-ridges test).
  options.factor_reuse.max_iterations = 0;
  return options;
}

std::string ContactReport::Summary() const {
  std::ostringstream out;
  out.precision(4);
  out << "penetration into obstacles: max " << max_penetration_before << " -> "
      << max_penetration_after << ", points inside " << penetrating_points_before << " -> "
      << penetrating_points_after << "; intersecting triangle pairs: self "
      << self_intersections_before << " -> " << self_intersections_after << " ("
      << self_intersections_rest << " at rest; not intersecting at rest "
      << new_self_intersections_before << " -> " << new_self_intersections_after
      << ", of which apart at rest " << separated_self_intersections_before << " -> "
      << separated_self_intersections_after << ", between triangles clean at rest "
      << clean_self_intersections_before << " -> " << clean_self_intersections_after
      << "), with obstacles "
      << obstacle_intersections_before << " -> " << obstacle_intersections_after
      << "; surface moved mean " << mean_displacement << " max " << max_displacement
      << " (max " << max_far_displacement << " farther than " << far_distance
      << " from the contacts); " << rounds << " rounds";
  if (path_steps > 0) {
    out << " over " << path_steps << " path steps from rest (" << path_halvings << " halved)";
  }
  out << ", " << obstacle_contacts
      << " obstacle and " << self_contacts << " self contacts active"
      << (converged ? "" : "; NOT CONVERGED");
  return out.str();
}

std::string ContactReport::ToText() const {
  std::ostringstream out;
  out.precision(10);
  out << "# ActiveQS contact report: " << Summary() << "\n";
  for (const std::string& line : round_summaries) out << "# " << line << "\n";
  out << "max_penetration_before " << max_penetration_before << "\n"
      << "max_penetration_after " << max_penetration_after << "\n"
      << "penetrating_points_before " << penetrating_points_before << "\n"
      << "penetrating_points_after " << penetrating_points_after << "\n"
      << "self_intersections_rest " << self_intersections_rest << "\n"
      << "self_intersections_before " << self_intersections_before << "\n"
      << "self_intersections_after " << self_intersections_after << "\n"
      << "new_self_intersections_before " << new_self_intersections_before << "\n"
      << "new_self_intersections_after " << new_self_intersections_after << "\n"
      << "separated_self_intersections_before " << separated_self_intersections_before << "\n"
      << "separated_self_intersections_after " << separated_self_intersections_after << "\n"
      << "clean_self_intersections_before " << clean_self_intersections_before << "\n"
      << "clean_self_intersections_after " << clean_self_intersections_after << "\n"
      << "obstacle_intersections_before " << obstacle_intersections_before << "\n"
      << "obstacle_intersections_after " << obstacle_intersections_after << "\n"
      << "mean_displacement " << mean_displacement << "\n"
      << "max_displacement " << max_displacement << "\n"
      << "far_distance " << far_distance << "\n"
      << "max_far_displacement " << max_far_displacement << "\n"
      << "rounds " << rounds << "\n"
      << "path_steps " << path_steps << "\n"
      << "path_halvings " << path_halvings << "\n"
      << "obstacle_contacts " << obstacle_contacts << "\n"
      << "self_contacts " << self_contacts << "\n"
      << "converged " << (converged ? 1 : 0) << "\n";
  return out.str();
}

ContactSolver::ContactSolver(const ActiveModel& model, const ContactOptions& options)
    : model_(model), options_(options) {
  CHECK_GE(options.max_rounds, 1);
  CHECK_GE(options.path_steps, 0);
  CHECK_GE(options.max_step_halvings, 0);
  physics_ = std::make_unique<ShapeTargetModel>(model.mesh, model.mu);
  stencils_ = EmbeddingStencils(model.embedding, model.mesh.tets);
  stiffness_ = VertexAreas(model.neutral.vertices, model.neutral.triangles);
  const double mean_area = stiffness_.sum() / std::max<Eigen::Index>(1, stiffness_.size());
  for (Eigen::Index i = 0; i < stiffness_.size(); ++i) {
    if (!(stiffness_[i] > 0)) stiffness_[i] = mean_area;
  }
  stiffness_ *= options.relative_stiffness * model.mu.mean() / MeanEdgeLength(model.mesh);
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
  rings_.resize(ns);
  ParallelFor(options.num_threads, 0, ns, [&](int, int v) {
    std::vector<int> ring = {v}, frontier = {v};
    for (int r = 0; r < options.exclusion_rings; ++r) {
      std::vector<int> next;
      for (int u : frontier) {
        for (int w : neighbours[u]) next.push_back(w);
      }
      std::sort(next.begin(), next.end());
      next.erase(std::unique(next.begin(), next.end()), next.end());
      frontier.clear();
      for (int w : next) {
        if (!std::binary_search(ring.begin(), ring.end(), w)) frontier.push_back(w);
      }
      ring.insert(ring.end(), frontier.begin(), frontier.end());
      std::sort(ring.begin(), ring.end());
    }
    rings_[v] = ring;
  });
}

ContactSolver::~ContactSolver() = default;

void ContactSolver::MeasurePenetration(const Eigen::Matrix3Xd& surface,
                                       const std::vector<const Obstacle*>& obstacles,
                                       double* max_depth, int* points) const {
  *max_depth = 0.0;
  *points = 0;
  for (const Obstacle* obstacle : obstacles) {
    for (Eigen::Index i = 0; i < surface.cols(); ++i) {
      if (!in_contact_[i]) continue;
      Eigen::Vector3d g;
      const double d = obstacle->SignedDistance(surface.col(i), &g, options_.search_radius);
      if (d < 0) {
        ++*points;
        *max_depth = std::max(*max_depth, -d);
      }
    }
  }
}

SelfIntersectionCounts ContactSolver::CountSelfIntersections(const Eigen::Matrix3Xd& surface) const {
  TriangleIntersectionOptions options;
  options.num_threads = options_.num_threads;
  std::vector<std::pair<int, int>> pairs;
  SelfIntersectionCounts counts;
  counts.all = FindIntersectingTrianglePairs(surface, contact_triangles_, options, &pairs);
  for (const auto& pair : pairs) {
    if (std::binary_search(rest_intersections_.begin(), rest_intersections_.end(), pair)) continue;
    ++counts.new_pairs;
    if (!intersects_at_rest_[pair.first] && !intersects_at_rest_[pair.second]) ++counts.clean;
    Eigen::Matrix3d a, b;
    for (int k = 0; k < 3; ++k) {
      a.col(k) = rest_surface_.col(contact_triangles_(k, pair.first));
      b.col(k) = rest_surface_.col(contact_triangles_(k, pair.second));
    }
    if (DisjointTriangleDistance(a, b) > options_.rest_tolerance) ++counts.separated;
  }
  return counts;
}

int ContactSolver::CountObstacleIntersections(const Eigen::Matrix3Xd& surface,
                                              const std::vector<const Obstacle*>& obstacles) const {
  int count = 0;
  for (const Obstacle* obstacle : obstacles) {
    count += FindIntersectingTrianglePairs(surface, contact_triangles_, obstacle->vertices(),
                                           obstacle->triangles(), options_.num_threads, nullptr);
  }
  return count;
}

std::vector<double> ContactSolver::NewIntersectionField(const Eigen::Matrix3Xd& surface) const {
  TriangleIntersectionOptions options;
  options.num_threads = options_.num_threads;
  std::vector<std::pair<int, int>> pairs;
  FindIntersectingTrianglePairs(surface, contact_triangles_, options, &pairs);
  std::vector<double> field(surface.cols(), 0.0);
  for (const auto& pair : pairs) {
    if (std::binary_search(rest_intersections_.begin(), rest_intersections_.end(), pair)) continue;
    for (int t : {pair.first, pair.second}) {
      for (int k = 0; k < 3; ++k) field[contact_triangles_(k, t)] += 1.0;
    }
  }
  return field;
}

std::vector<SelfContactPair> ContactSolver::DetectSelfContacts(const Eigen::Matrix3Xd& surface) const {
  const Eigen::Matrix3Xi& tris = contact_triangles_;
  // Reach: search_radius in front of a triangle and max_depth behind it.
  const double reach = std::max({options_.search_radius, options_.max_depth, 1e-9});
  const TriangleGrid grid(surface, tris, reach);
  const int ns = static_cast<int>(surface.cols());
  std::vector<int> best(ns, -1);
  const int threads = ParallelForThreadCount(options_.num_threads, ns, 64);
  std::vector<std::vector<int>> marks(threads), candidate_lists(threads);
  ParallelFor(options_.num_threads, 0, ns, [&](int thread, int i) {
    if (!in_contact_[i]) return;
    std::vector<int>& candidates = candidate_lists[thread];
    grid.Near(surface.col(i), i, &marks[thread], &candidates);
    double best_distance = reach;
    const std::vector<int>& ring = rings_[i];
    for (int t : candidates) {
      bool excluded = false;
      for (int k = 0; k < 3 && !excluded; ++k) {
        excluded = std::binary_search(ring.begin(), ring.end(), tris(k, t));
      }
      if (excluded) continue;
      double s = 0, s_rest = 0;
      Eigen::Vector3d beta, beta_rest;
      if (!PlaneDistance(surface.col(i), surface.col(tris(0, t)), surface.col(tris(1, t)),
                         surface.col(tris(2, t)), &s, nullptr, &beta) ||
          beta.minCoeff() < -options_.margin || !(s > -options_.max_depth) ||
          !(s < options_.thickness + options_.search_radius)) {
        continue;
      }
      // The point must have been on the triangle's outer side at rest, facing it.
      if (!PlaneDistance(rest_surface_.col(i), rest_surface_.col(tris(0, t)),
                         rest_surface_.col(tris(1, t)), rest_surface_.col(tris(2, t)), &s_rest,
                         nullptr, &beta_rest) ||
          s_rest < -options_.rest_tolerance) {
        continue;
      }
      const Eigen::Vector3d a = rest_surface_.col(tris(0, t));
      const Eigen::Vector3d n_t =
          (rest_surface_.col(tris(1, t)) - a).cross(rest_surface_.col(tris(2, t)) - a).normalized();
      if (rest_normals_.col(i).dot(n_t) > options_.max_normal_alignment) continue;
      if (std::abs(s) < best_distance) {
        best_distance = std::abs(s);
        best[i] = t;
      }
    }
  }, 64);
  std::vector<SelfContactPair> pairs;
  for (int i = 0; i < ns; ++i) {
    if (best[i] < 0) continue;
    SelfContactPair pair;
    pair.point = stencils_[i];
    for (int k = 0; k < 3; ++k) pair.corner[k] = stencils_[tris(k, best[i])];
    pair.stiffness = stiffness_[i];
    pair.surface_vertex = i;
    pairs.push_back(pair);
  }
  return pairs;
}

std::vector<SelfContactPair> ContactSolver::DetectEdgeContacts(
    const Eigen::Matrix3Xd& surface, const Eigen::Matrix3Xd& reference) const {
  const int num_edges = static_cast<int>(edges_.cols());
  if (num_edges == 0) return {};
  const double reach = std::max({options_.search_radius, options_.max_depth, 1e-9});
  // Edges as degenerate triangles (a, b, b) in a grid whose cells also hold the longest
  // edge, so that a query at an edge's midpoint finds every edge within reach of it.
  Eigen::Matrix3Xi segments(3, num_edges);
  double longest = 0.0;
  for (int e = 0; e < num_edges; ++e) {
    segments.col(e) << edges_(0, e), edges_(1, e), edges_(1, e);
    longest = std::max(longest, (surface.col(edges_(0, e)) - surface.col(edges_(1, e))).norm());
  }
  const TriangleGrid grid(surface, segments, reach + longest);
  // Pairs keep -max_depth < s < thickness + search_radius.
  const double distance_limit =
      std::max(options_.max_depth, options_.thickness + options_.search_radius);
  // Edge normals at the reference: the mean of the ends' vertex normals.
  const Eigen::Matrix3Xd vertex_normals = VertexNormals(reference, model_.neutral.triangles);
  Eigen::Matrix3Xd reference_normals(3, num_edges);
  for (int e = 0; e < num_edges; ++e) {
    reference_normals.col(e) = (vertex_normals.col(edges_(0, e)) + vertex_normals.col(edges_(1, e))).normalized();
  }
  // Per edge, its partners with the smallest signed distances (crossed ones first: the
  // nearest line is often a neighbour of the edge actually crossed).
  struct Partner {
    double s;
    int edge;
    double sign;
  };
  std::vector<std::vector<Partner>> partners(num_edges);
  const int threads = ParallelForThreadCount(options_.num_threads, num_edges, 64);
  std::vector<std::vector<int>> marks(threads), candidate_lists(threads);
  ParallelFor(options_.num_threads, 0, num_edges, [&](int thread, int e) {
    const int a = edges_(0, e), b = edges_(1, e);
    std::vector<int>& candidates = candidate_lists[thread];
    grid.Near(0.5 * (surface.col(a) + surface.col(b)), e, &marks[thread], &candidates);
    std::vector<Partner>& found = partners[e];
    const Eigen::Vector3d middle = 0.5 * (surface.col(a) + surface.col(b));
    const double length = (surface.col(b) - surface.col(a)).norm();
    for (int f : candidates) {
      if (edge_normals_.col(e).dot(edge_normals_.col(f)) > options_.max_normal_alignment) continue;
      const int c = edges_(0, f), d = edges_(1, f);
      // Closest points within margin on both edges and |s| < distance_limit put the
      // middles at most distance_limit + (1/2 + margin) (both lengths) apart.
      const double other_length = (surface.col(d) - surface.col(c)).norm();
      if ((0.5 * (surface.col(c) + surface.col(d)) - middle).norm() >
          distance_limit + (0.5 + options_.margin) * (length + other_length)) {
        continue;
      }
      bool excluded = false;
      for (int v : {a, b}) {
        const std::vector<int>& ring = rings_[v];
        excluded = excluded || std::binary_search(ring.begin(), ring.end(), c) ||
                   std::binary_search(ring.begin(), ring.end(), d);
      }
      if (excluded) continue;
      double s = 0, u = 0, w = 0;
      if (!EdgeDistance(surface.col(a), surface.col(b), surface.col(c), surface.col(d),
                        kMinEdgeSine, &s, nullptr, &u, &w) ||
          std::max({-u, u - 1.0, -w, w - 1.0}) > options_.margin) {
        continue;
      }
      // The side: the first edge on the outer side of the second's surface,
      // n . (normal_f - normal_e) > 0 for the common normal n at this state (s > 0 along
      // n) and the surfaces' normals at the reference, where these tell it clearly. (The
      // sign of the lines' distance at the reference would not do: it flips without a
      // crossing wherever the closest points leave the edges, and n flips wherever the
      // edges turn through parallel.)
      const Eigen::Vector3d cross = (surface.col(b) - surface.col(a))
                                        .cross(surface.col(d) - surface.col(c));
      const Eigen::Vector3d facing = reference_normals.col(f) - reference_normals.col(e);
      const double side = cross.dot(facing);
      if (!(std::abs(side) > kMinSideCosine * cross.norm() * facing.norm())) continue;
      const double sign = side > 0 ? 1.0 : -1.0;
      // And the lines' distance at the reference must agree (in this state's orientation
      // of n), so that pairs already crossed there are left alone.
      double s_reference = 0;
      if (!EdgeDistance(reference.col(a), reference.col(b), reference.col(c), reference.col(d),
                        0.0, &s_reference, nullptr, nullptr, nullptr)) {
        continue;
      }
      const Eigen::Vector3d cross_reference = (reference.col(b) - reference.col(a))
                                                  .cross(reference.col(d) - reference.col(c));
      if (s_reference * cross_reference.dot(cross) * sign <= 0.0) continue;
      s *= sign;
      if (!(s > -options_.max_depth) || !(s < options_.thickness + options_.search_radius)) continue;
      found.push_back({s, f, sign});
    }
    const size_t keep = std::min<size_t>(found.size(), kEdgePartners);
    std::partial_sort(found.begin(), found.begin() + keep, found.end(),
                      [](const Partner& x, const Partner& y) { return x.s < y.s; });
    found.resize(keep);
  }, 64);
  // Each unordered pair once, its lower-numbered edge first (the pair's distance and
  // side do not depend on the order; the augmented-Lagrangian offset is that edge's).
  std::set<std::pair<int, int>> taken;
  std::vector<SelfContactPair> pairs;
  for (int e = 0; e < num_edges; ++e) {
    for (const Partner& partner : partners[e]) {
      const int first = std::min(e, partner.edge), second = std::max(e, partner.edge);
      if (!taken.insert({first, second}).second) continue;
      SelfContactPair pair;
      pair.kind = SelfContactPair::Kind::kEdgeEdge;
      pair.point = stencils_[edges_(0, first)];
      pair.corner[0] = stencils_[edges_(1, first)];
      pair.corner[1] = stencils_[edges_(0, second)];
      pair.corner[2] = stencils_[edges_(1, second)];
      pair.sign = partner.sign;
      pair.stiffness = 0.25 * (stiffness_[edges_(0, first)] + stiffness_[edges_(1, first)] +
                               stiffness_[edges_(0, second)] + stiffness_[edges_(1, second)]);
      pair.edge = first;
      pairs.push_back(pair);
    }
  }
  return pairs;
}

bool ContactSolver::SolveRounds(const ActuationMatrix& a, const std::vector<RigidTransform>& bones,
                                const std::vector<const Obstacle*>& obstacles, int allowed_self,
                                int allowed_obstacle, double relative_force_tolerance,
                                const Eigen::Matrix3Xd& reference, const std::string& label,
                                Eigen::Matrix3Xd* x,
                                std::vector<char>* touched, int* self_intersections,
                                int* obstacle_intersections, ContactReport* report,
                                std::string* error) {
  const BoundaryConditions bc = ModelBoundaryConditions(model_, bones);
  QuasistaticSolverOptions solver_options = options_.solver;
  solver_options.relative_force_tolerance = relative_force_tolerance;
  solver_options.num_threads = options_.num_threads;
  for (int round = 0; round < options_.max_rounds; ++round) {
    const Eigen::Matrix3Xd surface = EmbeddedPositions(model_.embedding, model_.mesh.tets, *x);
    // Candidates near obstacles.
    std::vector<PointStencil> near_points;
    std::vector<double> near_stiffness;
    std::vector<int> near_vertices;
    if (options_.obstacle_contact && !obstacles.empty()) {
      const ObstacleContactTerm probe({}, Eigen::VectorXd(), options_.thickness, obstacles);
      for (Eigen::Index i = 0; i < surface.cols(); ++i) {
        if (!in_contact_[i]) continue;
        Eigen::Vector3d g;
        if (probe.Distance(surface.col(i), &g) < options_.thickness + options_.search_radius) {
          near_points.push_back(stencils_[i]);
          near_stiffness.push_back(stiffness_[i]);
          near_vertices.push_back(static_cast<int>(i));
        }
      }
    }
    std::vector<SelfContactPair> pairs =
        options_.self_contact ? DetectSelfContacts(surface) : std::vector<SelfContactPair>();
    for (SelfContactPair& pair : pairs) pair.offset = self_offsets_[pair.surface_vertex];
    int edge_pairs = 0;
    if (options_.self_contact && options_.edge_contact) {
      for (SelfContactPair& pair : DetectEdgeContacts(surface, reference)) {
        pair.offset = edge_offsets_[pair.edge];
        pairs.push_back(pair);
        ++edge_pairs;
      }
    }
    const ObstacleContactTerm obstacle_term(
        near_points, Eigen::Map<const Eigen::VectorXd>(near_stiffness.data(), near_stiffness.size()),
        options_.thickness, obstacles);
    // Within a round, a pair keeps its triangle's plane (kResidualMargin); re-detection
    // in the next round pairs points with their new triangles.
    const SelfContactTerm self_term(pairs, options_.thickness, kResidualDepth, kResidualMargin);
    QuasistaticSolver solver(*physics_, bc, solver_options);
    solver.actuation() = a;
    solver.SetPositions(*x);
    if (!near_points.empty()) solver.AddEnergyTerm(&obstacle_term);
    if (!pairs.empty()) solver.AddEnergyTerm(&self_term);
    const QuasistaticSolveReport solve = solver.Solve();
    if (!solve.converged && !std::isfinite(solve.final_energy)) {
      *error = "the equilibrium with contact failed" + label + ": " + solve.Summary();
      return false;
    }
    ++report->rounds;
    report->converged = solve.converged;
    report->round_summaries.push_back("round " + std::to_string(round + 1) + label + ": " +
                                      std::to_string(near_points.size()) + " points near obstacles, " +
                                      std::to_string(pairs.size()) + " self-contact pairs (" +
                                      std::to_string(edge_pairs) + " edge-edge); " +
                                      solve.Summary());
    *x = solver.positions();
    // Active contacts at the new state.
    report->obstacle_contacts = 0;
    for (size_t k = 0; k < near_points.size(); ++k) {
      Eigen::Vector3d gradient;
      if (obstacle_term.Distance(near_points[k].Position(*x), &gradient) < options_.thickness) {
        ++report->obstacle_contacts;
        (*touched)[near_vertices[k]] = 1;
      }
    }
    report->self_contacts = 0;
    Eigen::Matrix3Xd g = Eigen::Matrix3Xd::Zero(3, x->cols());
    for (const SelfContactPair& pair : pairs) {
      const bool edge = pair.kind == SelfContactPair::Kind::kEdgeEdge;
      const SelfContactTerm single({pair}, options_.thickness, kResidualDepth, kResidualMargin);
      if (single.AddEnergyAndGradient(*x, &g) > 0) {
        ++report->self_contacts;
        if (edge) {
          (*touched)[edges_(0, pair.edge)] = (*touched)[edges_(1, pair.edge)] = 1;
        } else {
          (*touched)[pair.surface_vertex] = 1;
        }
      }
      // Augmented Lagrangian: the multiplier k * offset grows by k (thickness - s).
      const Eigen::Vector3d points[4] = {pair.point.Position(*x), pair.corner[0].Position(*x),
                                         pair.corner[1].Position(*x), pair.corner[2].Position(*x)};
      double s = 0, outside = 0;
      if (options_.augmented_lagrangian &&
          SelfContactDistance(pair, points, &s, nullptr, &outside) && outside <= kResidualMargin &&
          s > -options_.max_depth) {
        double& offset = edge ? edge_offsets_[pair.edge] : self_offsets_[pair.surface_vertex];
        offset = std::clamp(offset + options_.thickness - s, 0.0, kMaxOffset * options_.thickness);
      }
    }
    const Eigen::Matrix3Xd moved = EmbeddedPositions(model_.embedding, model_.mesh.tets, *x);
    double depth = 0;
    int inside = 0;
    MeasurePenetration(moved, obstacles, &depth, &inside);
    // Self intersections that contact can tell apart: new pairs whose triangles were
    // apart at rest (those touching at rest, such as the ICT lips' corners, have no
    // defined side; steps and rounds cannot decide on them).
    *self_intersections = 0;
    if (options_.self_contact) *self_intersections = CountSelfIntersections(moved).separated;
    *obstacle_intersections = CountObstacleIntersections(moved, obstacles);
    if (solve.iterations == 0) break;  // no progress left to make with these candidates
    // Stop when nothing penetrates any more.
    if (inside == 0 && *self_intersections <= allowed_self &&
        *obstacle_intersections <= allowed_obstacle) {
      break;
    }
  }
  return true;
}

namespace {

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

}  // namespace

bool ContactSolver::Resolve(const ActuationMatrix& a, const std::vector<RigidTransform>& bones,
                            const std::vector<MovingObstacle>& obstacles,
                            const Eigen::Matrix3Xd& start, Eigen::Matrix3Xd* state,
                            ContactReport* report, std::string* error) {
  CHECK_EQ(bones.size(), model_.bones.size());
  *report = ContactReport();
  const std::vector<std::unique_ptr<Obstacle>> placed = PlaceAll(obstacles, bones);
  const std::vector<const Obstacle*> final_obstacles = Pointers(placed);
  const Eigen::Matrix3Xd before = EmbeddedPositions(model_.embedding, model_.mesh.tets, start);
  MeasurePenetration(before, final_obstacles, &report->max_penetration_before,
                     &report->penetrating_points_before);
  const SelfIntersectionCounts counts_before = CountSelfIntersections(before);
  report->self_intersections_before = counts_before.all;
  report->new_self_intersections_before = counts_before.new_pairs;
  report->separated_self_intersections_before = counts_before.separated;
  report->clean_self_intersections_before = counts_before.clean;
  report->self_intersections_rest = static_cast<int>(rest_intersections_.size());
  report->obstacle_intersections_before = CountObstacleIntersections(before, final_obstacles);
  // Surface vertices in contact in any round (the report's "far" displacement is
  // measured away from them).
  std::vector<char> touched(rest_surface_.cols(), 0);
  self_offsets_.assign(rest_surface_.cols(), 0.0);
  edge_offsets_.assign(edges_.cols(), 0.0);
  Eigen::Matrix3Xd x;
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
    x = start;
    int self_intersections = 0, obstacle_intersections = 0;
    if (!SolveRounds(a, bones, final_obstacles, 0, 0, options_.solver.relative_force_tolerance,
                     rest_surface_, "", &x, &touched, &self_intersections, &obstacle_intersections,
                     report, error)) {
      return false;
    }
  } else {
    // From rest, where the only intersections are those of the rest surface (not "new")
    // and whichever pairs the obstacles cross there.
    x = model_.mesh.vertices;
    int current_obstacle = CountObstacleIntersections(rest_surface_, Pointers(rest_placed));
    int current_self = 0;
    const double full_step = 1.0 / options_.path_steps;
    double t = 0.0, step = full_step;
    int halvings = 0;
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
      Eigen::Matrix3Xd x_next = x;
      std::vector<char> touched_next = touched;
      const std::vector<double> offsets = self_offsets_, edge_offsets = edge_offsets_;
      const Eigen::Matrix3Xd reference = EmbeddedPositions(model_.embedding, model_.mesh.tets, x);
      const double tolerance = t_next < 1.0 ? std::max(options_.path_relative_force_tolerance,
                                                       options_.solver.relative_force_tolerance)
                                            : options_.solver.relative_force_tolerance;
      int self_next = 0, obstacle_next = 0;
      if (!SolveRounds(a_t, bones_t, obstacles_t, current_self, current_obstacle, tolerance,
                       reference, label, &x_next, &touched_next, &self_next, &obstacle_next, report, error)) {
        return false;
      }
      if ((self_next > current_self || obstacle_next > current_obstacle) &&
          halvings < options_.max_step_halvings) {
        self_offsets_ = offsets;
        edge_offsets_ = edge_offsets;
        step = 0.5 * (t_next - t);  // half the step taken (the last one may be short)
        ++halvings;
        ++report->path_halvings;
        report->round_summaries.push_back(
            "step to t " + t_text.str() + " adds intersecting pairs (self, apart at rest, " +
            std::to_string(current_self) + " -> " + std::to_string(self_next) + ", obstacles " +
            std::to_string(current_obstacle) + " -> " + std::to_string(obstacle_next) +
            "): halved");
        continue;
      }
      x = x_next;
      touched = touched_next;
      t = t_next;
      current_self = self_next;
      current_obstacle = obstacle_next;
      ++report->path_steps;
      halvings = 0;
      step = std::min(full_step, 2.0 * step);
    }
  }
  *state = x;
  const Eigen::Matrix3Xd after = EmbeddedPositions(model_.embedding, model_.mesh.tets, x);
  MeasurePenetration(after, final_obstacles, &report->max_penetration_after,
                     &report->penetrating_points_after);
  const SelfIntersectionCounts counts_after = CountSelfIntersections(after);
  report->self_intersections_after = counts_after.all;
  report->new_self_intersections_after = counts_after.new_pairs;
  report->separated_self_intersections_after = counts_after.separated;
  report->clean_self_intersections_after = counts_after.clean;
  report->obstacle_intersections_after = CountObstacleIntersections(after, final_obstacles);
  const Eigen::VectorXd moved = (after - before).colwise().norm();
  report->mean_displacement = moved.mean();
  report->max_displacement = moved.maxCoeff();
  report->far_distance = 4.0 * options_.search_radius;
  std::vector<int> contact_vertices;
  for (Eigen::Index i = 0; i < after.cols(); ++i) {
    if (touched[i]) contact_vertices.push_back(static_cast<int>(i));
  }
  for (Eigen::Index i = 0; i < after.cols(); ++i) {
    double nearest = std::numeric_limits<double>::infinity();
    for (int c : contact_vertices) nearest = std::min(nearest, (after.col(i) - after.col(c)).norm());
    if (nearest > report->far_distance) {
      report->max_far_displacement = std::max(report->max_far_displacement, moved[i]);
    }
  }
  return true;
}

}  // namespace aqs
