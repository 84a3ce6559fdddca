#ifndef AQS_CONTACT_SURFACE_STENCILS_H_
#define AQS_CONTACT_SURFACE_STENCILS_H_

#include <vector>

#include <Eigen/Core>

#include "geometry/embedding.h"

namespace aqs {

// An embedded surface point as a function of the simulation state x (3 x num_vertices):
// p(x) = sum_j weight[j] x.col(vertex[j]) + offset.
struct PointStencil {
  int vertex[4];
  double weight[4];
  Eigen::Vector3d offset;

  Eigen::Vector3d Position(const Eigen::Ref<const Eigen::Matrix3Xd>& x) const {
    Eigen::Vector3d p = offset;
    for (int j = 0; j < 4; ++j) p += weight[j] * x.col(vertex[j]);
    return p;
  }
};

// The stencils of all embedded points (tets: the mesh's 4 x num_elements).
std::vector<PointStencil> EmbeddingStencils(const Embedding& embedding, const Eigen::Matrix4Xi& tets);

}  // namespace aqs

#endif  // AQS_CONTACT_SURFACE_STENCILS_H_
