// ContactSolver's candidates: surface points near obstacles, point-triangle and
// edge-edge pairs of the surface.

#include <algorithm>
#include <cmath>
#include <set>

#include <Eigen/Geometry>

#include "contact/contact_solver.h"
#include "geometry/distance/edge_distance.h"
#include "geometry/distance/plane_distance.h"
#include "geometry/triangle_grid.h"
#include "geometry/vertex_normals.h"
#include "mesh/mesh_measures.h"
#include "util/parallel_for.h"

namespace aqs {
namespace {

// Edge-edge pairs per edge at most (those with the smallest signed distances).
constexpr size_t kEdgePartners = 2;
// Edge-edge pairs whose side the surface normals tell less clearly than this (cosine of
// the common normal with the difference of the edges' normals) are left out.
constexpr double kMinSideCosine = 0.3;

}  // namespace

ObstacleCandidates ContactSolver::DetectObstacleContacts(
    const Eigen::Matrix3Xd& surface, const std::vector<const Obstacle*>& obstacles) const {
  ObstacleCandidates candidates;
  if (!options_.obstacle_contact || obstacles.empty()) return candidates;
  const ObstacleContactTerm probe({}, Eigen::VectorXd(), options_.thickness, obstacles);
  for (Eigen::Index i = 0; i < surface.cols(); ++i) {
    if (!in_contact_[i]) continue;
    Eigen::Vector3d g;
    const double reach = options_.thickness + options_.search_radius;
    if (probe.Distance(surface.col(i), &g, reach) < reach) {
      candidates.points.push_back(stencils_[i]);
      candidates.stiffness.push_back(stiffness_[i]);
      candidates.surface_vertices.push_back(static_cast<int>(i));
    }
  }
  return candidates;
}

std::vector<SelfContactPair> ContactSolver::DetectSelfContacts(const Eigen::Matrix3Xd& surface) const {
  const Eigen::Matrix3Xi& tris = contact_triangles_;
  // Reach: search_radius in front of a triangle and max_depth behind it.
  const double reach = std::max({options_.search_radius, options_.max_depth, 1e-9});
  const TriangleGrid grid(surface, tris, reach);
  const int ns = static_cast<int>(surface.cols());
  // Per triangle, once: its rest normal (the cheapest test, which rejects most candidates:
  // those of the point's own sheet) and whether its plane is well conditioned now.
  const int nt = static_cast<int>(tris.cols());
  Eigen::Matrix3Xd rest_normals(3, nt);
  std::vector<char> pairable(nt);
  for (int t = 0; t < nt; ++t) {
    const Eigen::Vector3d a = rest_surface_.col(tris(0, t));
    rest_normals.col(t) =
        (rest_surface_.col(tris(1, t)) - a).cross(rest_surface_.col(tris(2, t)) - a).normalized();
    pairable[t] = PairableTriangle(surface.col(tris(0, t)), surface.col(tris(1, t)),
                                   surface.col(tris(2, t)));
  }
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
      // The point must face the triangle at rest (normals more than the alignment apart).
      if (rest_normals_.col(i).dot(rest_normals.col(t)) > options_.max_normal_alignment) continue;
      bool excluded = false;
      for (int k = 0; k < 3 && !excluded; ++k) {
        excluded = std::binary_search(ring.begin(), ring.end(), tris(k, t));
      }
      if (excluded) continue;
      double s = 0, s_rest = 0;
      Eigen::Vector3d beta, beta_rest;
      // A squashed triangle's plane is ill-conditioned (SelfContactFadeVariable): skipped.
      if (!pairable[t] ||
          !PlaneDistance(surface.col(i), surface.col(tris(0, t)), surface.col(tris(1, t)),
                         surface.col(tris(2, t)), &s, nullptr, &beta) ||
          !(beta.minCoeff() >= -options_.margin) || !(s > -options_.max_depth) ||
          !(s < options_.thickness + options_.search_radius)) {
        continue;
      }
      // The point must have been on the triangle's outer side at rest.
      if (!PlaneDistance(rest_surface_.col(i), rest_surface_.col(tris(0, t)),
                         rest_surface_.col(tris(1, t)), rest_surface_.col(tris(2, t)), &s_rest,
                         nullptr, &beta_rest) ||
          s_rest < -options_.rest_tolerance) {
        continue;
      }
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
  // Pairs keep -max_depth < s < thickness + search_radius.
  const double distance_limit =
      std::max(options_.max_depth, options_.thickness + options_.search_radius);
  // Each edge extended by the margin at both ends (where its closest point may lie), as a
  // degenerate triangle (a', b', b') in a grid of cells of that distance. The closest
  // points of a pair that passes the tests below lie on the two extended edges, at most
  // distance_limit apart, so the box of one extended edge grown by distance_limit meets
  // a cell that lists the other (a query about the middle of an edge with cells as large
  // as the longest edge found 22% of the demo face's edges for each: 1.4 s a round).
  Eigen::Matrix3Xd ends(3, 2 * num_edges);
  Eigen::Matrix3Xi segments(3, num_edges);
  for (int e = 0; e < num_edges; ++e) {
    const Eigen::Vector3d a = surface.col(edges_(0, e)), b = surface.col(edges_(1, e));
    ends.col(2 * e) = a - options_.margin * (b - a);
    ends.col(2 * e + 1) = b + options_.margin * (b - a);
    segments.col(e) << 2 * e, 2 * e + 1, 2 * e + 1;
  }
  const TriangleGrid grid(ends, segments, std::max(distance_limit, 1e-9));
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
    const Eigen::Vector3d grow = Eigen::Vector3d::Constant(distance_limit);
    grid.InBox(ends.col(2 * e).cwiseMin(ends.col(2 * e + 1)) - grow,
               ends.col(2 * e).cwiseMax(ends.col(2 * e + 1)) + grow, e, &marks[thread],
               &candidates);
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
  // side do not depend on the order; the augmented-Lagrangian offset is the pair's).
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
      pair.second_edge = second;
      pairs.push_back(pair);
    }
  }
  return pairs;
}

}  // namespace aqs
