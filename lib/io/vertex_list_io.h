#ifndef AQS_IO_VERTEX_LIST_IO_H_
#define AQS_IO_VERTEX_LIST_IO_H_

#include <string>
#include <vector>

#include <Eigen/Core>

#include "physics/boundary_conditions.h"

namespace aqs {

// Text formats for vertex sets. '#' starts a comment (to the end of the line); blank
// lines are skipped. Indices are 0-based. Errors name "path:line" and what was wrong.

// A fixed-vertex file: one entry per line, either
//   i          vertex i fixed at its rest position, or
//   i x y z    vertex i fixed at position (x, y, z) (prescribed motion);
// both kinds may be mixed. rest_positions (3 x num_vertices) supplies the rest
// positions and the vertex count. Rejects out-of-range, repeated or non-integer
// indices, and lines with 2, 3 or more than 4 numbers.
bool ReadFixedVertices(const std::string& path, const Eigen::Matrix3Xd& rest_positions,
                       BoundaryConditions* bc, std::string* error);

// A plain vertex list: one index per line, each in [0, num_vertices), no repeats.
bool ReadVertexList(const std::string& path, int num_vertices, std::vector<int>* vertices,
                    std::string* error);

// Writes one index per line after a comment line `comment` (may be empty).
bool WriteVertexList(const std::string& path, const std::vector<int>& vertices,
                     const std::string& comment, std::string* error);

}  // namespace aqs

#endif  // AQS_IO_VERTEX_LIST_IO_H_
