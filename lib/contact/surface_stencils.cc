#include "contact/surface_stencils.h"

namespace aqs {

std::vector<PointStencil> EmbeddingStencils(const Embedding& embedding, const Eigen::Matrix4Xi& tets) {
  std::vector<PointStencil> stencils(embedding.num_points());
  for (int i = 0; i < embedding.num_points(); ++i) {
    PointStencil& s = stencils[i];
    for (int j = 0; j < 4; ++j) {
      s.vertex[j] = tets(j, embedding.element[i]);
      s.weight[j] = embedding.weights(j, i);
    }
    s.offset = embedding.offsets.col(i);
  }
  return stencils;
}

}  // namespace aqs
