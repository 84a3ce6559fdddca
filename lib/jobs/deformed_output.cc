#include "jobs/deformed_output.h"

#include "mesh/boundary_surface.h"
#include "util/file_extension.h"

namespace aqs {

bool IsDeformedMeshOutputPath(const std::string& path) {
  const std::string ext = LowercaseExtension(path);
  return ext == ".mesh" || ext == ".vtu" || ext == ".obj";
}

VtuField MakeVtuField(const std::string& name, const Eigen::MatrixXd& values) {
  VtuField field;
  field.name = name;
  field.components = static_cast<int>(values.rows());
  field.values.assign(values.data(), values.data() + values.size());
  return field;
}

bool WriteDeformedMesh(const std::string& path, const TetMesh& rest,
                       const Eigen::Matrix3Xd& positions,
                       const std::vector<VtuField>& point_fields,
                       const std::vector<VtuField>& cell_fields, std::string* error) {
  TetMesh deformed;
  deformed.vertices = positions;
  deformed.tets = rest.tets;
  const std::string ext = LowercaseExtension(path);
  if (ext == ".mesh") return WriteMeditMesh(path, deformed, error);
  if (ext == ".vtu") return WriteVtu(path, deformed, point_fields, cell_fields, error);
  if (ext == ".obj") {
    const BoundarySurface boundary = ExtractBoundarySurface(rest);
    return WriteObj(path, BoundaryToSurface(boundary, positions), error);
  }
  *error = path + ": unknown output extension '" + ext + "'; known: .mesh, .vtu, .obj";
  return false;
}

}  // namespace aqs
