#ifndef AQS_JOBS_DEFORMED_OUTPUT_H_
#define AQS_JOBS_DEFORMED_OUTPUT_H_

#include <string>
#include <vector>

#include <Eigen/Core>

#include "mesh/mesh_io.h"
#include "mesh/tet_mesh.h"

namespace aqs {

// Writes a deformed state of `rest` (positions: 3 x num_vertices) to `path`, the format
// chosen by extension:
//   .mesh  MEDIT tet mesh, same vertex and element order as `rest`;
//   .vtu   ParaView unstructured grid with the given per-vertex and per-element fields;
//   .obj   the boundary surface (outward triangles) at the deformed positions, with
//          only the boundary vertices (in increasing mesh-vertex order).
// Returns false with *error for unknown extensions or write failures.
bool WriteDeformedMesh(const std::string& path, const TetMesh& rest,
                       const Eigen::Matrix3Xd& positions,
                       const std::vector<VtuField>& point_fields,
                       const std::vector<VtuField>& cell_fields, std::string* error);

// True if WriteDeformedMesh knows the extension of `path`.
bool IsDeformedMeshOutputPath(const std::string& path);

// A VtuField from a column-major matrix (components x count).
VtuField MakeVtuField(const std::string& name, const Eigen::MatrixXd& values);

}  // namespace aqs

#endif  // AQS_JOBS_DEFORMED_OUTPUT_H_
