// The contact report (contact_report.h) and the measurements ContactSolver makes of it.

#include "contact/contact_report.h"

#include <algorithm>
#include <sstream>

#include <Eigen/Core>

#include "contact/contact_solver.h"
#include "geometry/distance/triangle_distance.h"
#include "geometry/triangle_intersections.h"

namespace aqs {

std::string ContactReport::Summary() const {
  const SelfIntersectionCounts& self_before = before.self_intersections;
  const SelfIntersectionCounts& self_after = after.self_intersections;
  std::ostringstream out;
  out.precision(4);
  out << "penetration into obstacles: max " << before.max_penetration << " -> "
      << after.max_penetration << ", points inside " << before.penetrating_points << " -> "
      << after.penetrating_points << "; intersecting triangle pairs: self "
      << self_before.all << " -> " << self_after.all << " ("
      << self_intersections_rest << " at rest; not intersecting at rest "
      << self_before.new_pairs << " -> " << self_after.new_pairs
      << ", of which apart at rest " << self_before.separated << " -> "
      << self_after.separated << " (facing each other " << self_before.facing << " -> "
      << self_after.facing << ", the rest folds of one sheet), between triangles clean at rest "
      << self_before.clean << " -> " << self_after.clean
      << "), with obstacles "
      << before.obstacle_intersections << " -> " << after.obstacle_intersections
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
  // A measurement before and after, as the lines NAME_before and NAME_after.
  const auto before_after = [&out](const std::string& name, auto value_before, auto value_after) {
    out << name << "_before " << value_before << "\n" << name << "_after " << value_after << "\n";
  };
  const SelfIntersectionCounts& self_before = before.self_intersections;
  const SelfIntersectionCounts& self_after = after.self_intersections;
  out << "# ActiveQS contact report: " << Summary() << "\n";
  for (const std::string& line : round_summaries) out << "# " << line << "\n";
  before_after("max_penetration", before.max_penetration, after.max_penetration);
  before_after("penetrating_points", before.penetrating_points, after.penetrating_points);
  out << "self_intersections_rest " << self_intersections_rest << "\n";
  before_after("self_intersections", self_before.all, self_after.all);
  before_after("new_self_intersections", self_before.new_pairs, self_after.new_pairs);
  before_after("separated_self_intersections", self_before.separated, self_after.separated);
  before_after("clean_self_intersections", self_before.clean, self_after.clean);
  before_after("facing_self_intersections", self_before.facing, self_after.facing);
  before_after("obstacle_intersections", before.obstacle_intersections,
               after.obstacle_intersections);
  out << "mean_displacement " << mean_displacement << "\n"
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

ContactMeasurement ContactSolver::Measure(const Eigen::Matrix3Xd& surface,
                                          const std::vector<const Obstacle*>& obstacles) const {
  ContactMeasurement measurement;
  MeasurePenetration(surface, obstacles, &measurement.max_penetration,
                     &measurement.penetrating_points);
  measurement.self_intersections = CountSelfIntersections(surface);
  measurement.obstacle_intersections = CountObstacleIntersections(surface, obstacles);
  return measurement;
}

void ContactSolver::MeasurePenetration(const Eigen::Matrix3Xd& surface,
                                       const std::vector<const Obstacle*>& obstacles,
                                       double* max_depth, int* points) const {
  *max_depth = 0.0;
  *points = 0;
  for (Eigen::Index i = 0; i < surface.cols(); ++i) {
    if (!in_contact_[i]) continue;
    // The deepest of the obstacles the point is in (counted once if it is in several).
    double deepest = 0.0;
    for (const Obstacle* obstacle : obstacles) {
      Eigen::Vector3d g;
      deepest = std::min(
          deepest, obstacle->SignedDistance(surface.col(i), &g, options_.search_radius));
    }
    if (deepest < 0) {
      ++*points;
      *max_depth = std::max(*max_depth, -deepest);
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
    if (!(DisjointTriangleDistance(a, b) > options_.rest_tolerance)) continue;
    ++counts.separated;
    if (FacingAtRest(pair.first, pair.second)) ++counts.facing;
  }
  return counts;
}

bool ContactSolver::FacingAtRest(int first, int second) const {
  const auto normal = [this](int t) -> Eigen::Vector3d {
    const Eigen::Vector3d a = rest_surface_.col(contact_triangles_(0, t));
    return (rest_surface_.col(contact_triangles_(1, t)) - a)
        .cross(rest_surface_.col(contact_triangles_(2, t)) - a)
        .normalized();
  };
  if (!(normal(first).dot(normal(second)) <= options_.max_normal_alignment)) return false;
  for (int j = 0; j < 3; ++j) {
    const std::vector<int>& ring = rings_[contact_triangles_(j, first)];
    for (int k = 0; k < 3; ++k) {
      if (std::binary_search(ring.begin(), ring.end(), contact_triangles_(k, second))) {
        return false;
      }
    }
  }
  return true;
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

}  // namespace aqs
