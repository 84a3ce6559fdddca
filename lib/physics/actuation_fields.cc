#include "physics/actuation_fields.h"

#include <cmath>

#include <Eigen/Geometry>

namespace aqs {

ActuationMatrix SmoothFibreActuation(const TetMesh& mesh, double amplitude) {
  const Eigen::Vector3d lo = mesh.vertices.rowwise().minCoeff();
  const Eigen::Vector3d hi = mesh.vertices.rowwise().maxCoeff();
  const Eigen::Vector3d extent = (hi - lo).cwiseMax(1e-12);
  const Eigen::Vector3d axis = Eigen::Vector3d(0.2, 1.0, 0.3).normalized();
  ActuationMatrix a(6, mesh.num_tets());
  for (int e = 0; e < mesh.num_tets(); ++e) {
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (int k = 0; k < 4; ++k) c += 0.25 * mesh.vertices.col(mesh.tets(k, e));
    const Eigen::Vector3d u = (c - lo).cwiseQuotient(extent);
    const Eigen::Matrix3d q =
        Eigen::AngleAxisd(0.8 * u.x() + 0.5 * u.z(), axis).toRotationMatrix();
    const Eigen::Vector3d stretch(1.0 - amplitude * std::sin(M_PI * u.x()),
                                  1.0 + 0.5 * amplitude * std::cos(2 * M_PI * u.y()),
                                  1.0 + 0.3 * amplitude * u.z());
    a.col(e) = ActuationFromSymmetric(q * stretch.asDiagonal() * q.transpose());
  }
  return a;
}

}  // namespace aqs
