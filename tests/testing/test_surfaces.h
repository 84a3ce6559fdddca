#ifndef AQS_TESTING_TEST_SURFACES_H_
#define AQS_TESTING_TEST_SURFACES_H_

#include <vector>

#include <Eigen/Core>

#include "mesh/surface_mesh.h"

namespace aqs {
namespace testing {

// A triangulated sphere: the icosahedron with every triangle split into 4, `subdivisions`
// times, vertices projected onto the sphere of `radius` about `centre`. Outward
// (right-hand) orientation. 10 * 4^s + 2 vertices, 20 * 4^s triangles.
SurfaceMesh Icosphere(int subdivisions, double radius,
                     const Eigen::Vector3d& centre = Eigen::Vector3d::Zero());

// `triangles` without the columns listed in `removed`.
Eigen::Matrix3Xi RemoveTriangles(const Eigen::Matrix3Xi& triangles,
                                 const std::vector<int>& removed);

// The volume a closed, outward-oriented triangle surface encloses (divergence theorem).
double EnclosedVolume(const Eigen::Matrix3Xd& vertices, const Eigen::Matrix3Xi& triangles);

}  // namespace testing
}  // namespace aqs

#endif  // AQS_TESTING_TEST_SURFACES_H_
