#include "physics/boundary_conditions.h"

#include <sstream>

#include <glog/logging.h>

namespace aqs {

bool ValidateBoundaryConditions(const BoundaryConditions& bc, int num_vertices,
                                const std::string& source, std::string* error) {
  std::vector<int> seen(num_vertices, -1);
  for (size_t i = 0; i < bc.vertices.size(); ++i) {
    const int v = bc.vertices[i];
    if (v < 0 || v >= num_vertices) {
      std::ostringstream out;
      out << source << ": fixed vertex entry " << i << " is " << v
          << ", outside the mesh's vertex range [0, " << num_vertices << ")";
      *error = out.str();
      return false;
    }
    if (seen[v] >= 0) {
      std::ostringstream out;
      out << source << ": vertex " << v << " is listed twice (entries " << seen[v] << " and "
          << i << ")";
      *error = out.str();
      return false;
    }
    seen[v] = static_cast<int>(i);
  }
  if (bc.positions.cols() != 0) {
    if (bc.positions.cols() != static_cast<Eigen::Index>(bc.vertices.size())) {
      std::ostringstream out;
      out << source << ": " << bc.positions.cols() << " prescribed positions for "
          << bc.vertices.size() << " fixed vertices";
      *error = out.str();
      return false;
    }
    for (Eigen::Index i = 0; i < bc.positions.cols(); ++i) {
      if (!bc.positions.col(i).allFinite()) {
        std::ostringstream out;
        out << source << ": prescribed position of vertex " << bc.vertices[i]
            << " is not finite";
        *error = out.str();
        return false;
      }
    }
  }
  return true;
}

std::vector<bool> FixedVertexMask(const BoundaryConditions& bc, int num_vertices) {
  std::vector<bool> mask(num_vertices, false);
  for (int v : bc.vertices) {
    CHECK(v >= 0 && v < num_vertices) << "fixed vertex " << v;
    mask[v] = true;
  }
  return mask;
}

}  // namespace aqs
