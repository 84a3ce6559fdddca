#ifndef AQS_TESTING_TEST_MESHES_H_
#define AQS_TESTING_TEST_MESHES_H_

#include <random>

#include <Eigen/Core>

#include "mesh/tet_mesh.h"
#include "physics/actuation.h"
#include "physics/boundary_conditions.h"

namespace aqs {
namespace testing {

// A Kuhn lattice bar of nx x ny x nz cubes of edge `spacing`, minimum corner at 0.
TetMesh BarMesh(int nx, int ny, int nz, double spacing);

// The tetrahedron (0,0,0) (1,0,0) (0,1,0) (0,0,1), positive signed volume 1/6.
TetMesh UnitTet();

// `a` and then `b` as one mesh: b's vertices after a's, its elements after a's with their
// indices shifted, each turned (two vertices swapped) where its orientation differs from
// a's element 0.
TetMesh JoinMeshes(const TetMesh& a, const TetMesh& b);

// One skewed tetrahedron (vertices near the unit corners, positively oriented): the
// single-element meshes of the derivative tests.
TetMesh OneTetMesh();

// Three tets on 6 vertices: two sharing a face, a third sharing an edge with them (small
// enough for dense finite differences of every coordinate).
TetMesh ThreeTetMesh();

// The vertices with x <= tolerance (the bar's left face), fixed at rest.
BoundaryConditions LeftFaceFixed(const TetMesh& mesh, double tolerance = 1e-9);

// Appends one element apart from the mesh (4 new vertices, the last element): a corner
// `gap` above the mesh's largest x, y and z, and edges of length `size` along -x, -y and
// +z from it, oriented as element 0. Nothing holds it: a piece whose stiffness is
// singular, as meshers leave (prepare removes such pieces since 2026-12-07).
void AppendLoneElement(TetMesh* mesh, double gap, double size);

// SmoothFibreActuation(mesh, amplitude) (physics/actuation_fields.h).
ActuationMatrix SmoothActuation(const TetMesh& mesh, double amplitude);

// Contracts the bar's fibres (x) above its middle (in y) by `amount` and stretches them
// below by as much: the bar fixed at its left face curls up, far from its rest shape (a
// large pose from rest).
ActuationMatrix CurlActuation(const TetMesh& mesh, double amount);

// Identity plus uniform noise of the given amplitude on every number.
ActuationMatrix RandomActuation(int num_elements, double amplitude, std::mt19937* rng);

// The mesh's rest positions (3 x num_vertices) plus normal noise of standard deviation
// `sigma` on every coordinate.
Eigen::Matrix3Xd JitteredVertices(const TetMesh& mesh, double sigma, std::mt19937* rng);

}  // namespace testing
}  // namespace aqs

#endif  // AQS_TESTING_TEST_MESHES_H_
