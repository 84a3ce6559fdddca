#ifndef AQS_GEOMETRY_SURFACE_FEATURES_H_
#define AQS_GEOMETRY_SURFACE_FEATURES_H_

#include <Eigen/Core>

namespace aqs {

// The edges and vertices of a triangle surface, with the inclusion-exclusion weights that
// make a sum over closed features count every point of the surface once:
//
//   sum_faces f(face) + sum_edges w_e f(edge) + sum_vertices w_v f(vertex),
//   w_e = 1 - (faces at the edge),  w_v = 1 + (faces at the vertex) - (edges at the vertex),
//
// equals f at a point that all its features share. With f the penalty of a distance
// (contact/obstacle_penalty.h), the sum is the penalty of the distance to the surface
// wherever the closest points of the features within reach coincide (a face, a convex
// edge or corner, a flat tessellation), and is C1 where they do not (a concave crease).
// Inside a closed manifold surface every edge has weight -1 and every vertex +1; on an
// open boundary edges and vertices get 0 (a boundary edge is covered by its one face).
struct SurfaceFeatures {
  // 2 x E: each edge's vertices (smaller index first), in ascending order of the pair.
  Eigen::Matrix2Xi edges;
  // 3 x M: the edges of triangle t, column t: (v0 v1), (v1 v2), (v2 v0) as edge indices.
  Eigen::Matrix3Xi triangle_edges;
  Eigen::VectorXd edge_weights;    // E
  Eigen::VectorXd vertex_weights;  // N (0 for vertices of no triangle)
};

// The features of the surface with `num_vertices` vertices and triangles (3 x M, every
// index in [0, num_vertices): CHECK). O(M log M).
SurfaceFeatures BuildSurfaceFeatures(const Eigen::Matrix3Xi& triangles, int num_vertices);

}  // namespace aqs

#endif  // AQS_GEOMETRY_SURFACE_FEATURES_H_
