#include "jobs/deformed_output.h"

#include <algorithm>
#include <cctype>

#include "mesh/boundary_surface.h"

namespace aqs {
namespace {

std::string Extension(const std::string& path) {
  const size_t dot = path.find_last_of('.');
  const size_t slash = path.find_last_of('/');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
  std::string ext = path.substr(dot);
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}

}  // namespace

bool IsDeformedMeshOutputPath(const std::string& path) {
  const std::string ext = Extension(path);
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
  const std::string ext = Extension(path);
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
