#include "model/surface_springs.h"

#include <algorithm>

#include "mesh/mesh_measures.h"

namespace aqs {

Eigen::VectorXd SurfaceSpringStiffness(const ActiveModel& model, double relative_stiffness) {
  Eigen::VectorXd stiffness = VertexAreas(model.neutral.vertices, model.neutral.triangles);
  const double mean_area = stiffness.sum() / std::max<Eigen::Index>(1, stiffness.size());
  for (Eigen::Index i = 0; i < stiffness.size(); ++i) {
    if (!(stiffness[i] > 0)) stiffness[i] = mean_area;
  }
  return stiffness * (relative_stiffness * model.mu.mean() / MeanEdgeLength(model.mesh));
}

}  // namespace aqs
