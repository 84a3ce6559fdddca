#include "mesh/tet_mesh.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <vector>

#include "mesh/tet_faces.h"

namespace aqs {
namespace {

// "source: element 17 (vertices 3 8 9 12) "
std::string ElementPrefix(const TetMesh& mesh, const std::string& source, int t) {
  std::ostringstream out;
  out << source << ": element " << t << " (vertices " << mesh.tets(0, t) << ' ' << mesh.tets(1, t)
      << ' ' << mesh.tets(2, t) << ' ' << mesh.tets(3, t) << ") ";
  return out.str();
}

// Numbers in messages: 6 significant digits are enough to read.
std::string Short(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

double LongestEdgeSquared(const Eigen::Vector3d x[4]) {
  double longest = 0;
  for (int i = 0; i < 4; ++i) {
    for (int j = i + 1; j < 4; ++j) longest = std::max(longest, (x[i] - x[j]).squaredNorm());
  }
  return longest;
}

}  // namespace

double SignedTetVolume(const Eigen::Vector3d& x0, const Eigen::Vector3d& x1,
                       const Eigen::Vector3d& x2, const Eigen::Vector3d& x3) {
  return (x1 - x0).dot((x2 - x0).cross(x3 - x0)) / 6.0;
}

double SignedTetVolume(const TetMesh& mesh, const Eigen::Matrix3Xd& positions, int t) {
  return SignedTetVolume(positions.col(mesh.tets(0, t)), positions.col(mesh.tets(1, t)),
                         positions.col(mesh.tets(2, t)), positions.col(mesh.tets(3, t)));
}

bool ValidateTetMesh(const TetMesh& mesh, const std::string& source, std::string* error,
                     const TetMeshValidationOptions& options) {
  const int num_vertices = mesh.num_vertices();
  const int num_tets = mesh.num_tets();
  if (num_tets == 0) {
    *error = source + ": the mesh has no elements (" + std::to_string(num_vertices) +
             " vertices, 0 tetrahedra)";
    return false;
  }
  for (int v = 0; v < num_vertices; ++v) {
    if (!mesh.vertices.col(v).allFinite()) {
      std::ostringstream out;
      out << source << ": vertex " << v << " has a non-finite coordinate (" << mesh.vertices(0, v)
          << ' ' << mesh.vertices(1, v) << ' ' << mesh.vertices(2, v) << ")";
      *error = out.str();
      return false;
    }
  }

  // Indices: in range and distinct.
  for (int t = 0; t < num_tets; ++t) {
    for (int i = 0; i < 4; ++i) {
      const int v = mesh.tets(i, t);
      if (v < 0 || v >= num_vertices) {
        *error = ElementPrefix(mesh, source, t) + "has vertex index " + std::to_string(v) +
                 " out of range: the mesh has " + std::to_string(num_vertices) +
                 " vertices (valid indices 0 to " + std::to_string(num_vertices - 1) + ")";
        return false;
      }
      for (int j = 0; j < i; ++j) {
        if (mesh.tets(j, t) == v) {
          *error = ElementPrefix(mesh, source, t) + "uses vertex " + std::to_string(v) +
                   " twice: the four vertices of an element must be distinct";
          return false;
        }
      }
    }
  }

  // Flat elements, then signs.
  std::vector<double> volumes(num_tets);
  int num_positive = 0;
  for (int t = 0; t < num_tets; ++t) {
    Eigen::Vector3d x[4];
    for (int i = 0; i < 4; ++i) x[i] = mesh.vertices.col(mesh.tets(i, t));
    const double volume = SignedTetVolume(x[0], x[1], x[2], x[3]);
    const double longest = std::sqrt(LongestEdgeSquared(x));
    const double bound = options.flat_tolerance * longest * longest * longest;
    if (!std::isfinite(volume) || !std::isfinite(bound)) {
      double largest = 0.0;
      for (int i = 0; i < 4; ++i) largest = std::max(largest, x[i].cwiseAbs().maxCoeff());
      *error = ElementPrefix(mesh, source, t) + "is too large to measure: its edge lengths or " +
               "volume overflow (a coordinate of " + Short(largest) + "; is the mesh damaged, " +
               "or in another unit?)";
      return false;
    }
    if (!(6.0 * std::abs(volume) > bound)) {
      *error = ElementPrefix(mesh, source, t) +
               "is flat (degenerate): 6 |volume| = " + Short(6.0 * std::abs(volume)) +
               " <= " + Short(options.flat_tolerance) + " * (longest edge " + Short(longest) +
               ")^3";
      return false;
    }
    volumes[t] = volume;
    if (volume > 0) ++num_positive;
  }
  const int num_negative = num_tets - num_positive;
  const bool majority_positive = num_positive >= num_negative;
  if (num_positive != num_tets && num_negative != num_tets) {
    for (int t = 0; t < num_tets; ++t) {
      if ((volumes[t] > 0) != majority_positive) {
        const int others = majority_positive ? num_positive : num_negative;
        *error = ElementPrefix(mesh, source, t) + "is inverted: signed volume " +
                 Short(volumes[t]) + " while " + std::to_string(others) +
                 (others == 1 ? " other element is " : " other elements are ") +
                 (majority_positive ? "positive" : "negative");
        return false;
      }
    }
  }

  // Triangles shared by more than two elements. Report the element that is the third
  // user of a triangle, the smallest such element.
  const mesh_internal::TetFaceTable table = mesh_internal::BuildTetFaceTable(mesh);
  int worst_tet = std::numeric_limits<int>::max();
  int worst_a = -1;
  size_t worst_run = 0;
  // Two elements on the same side of the triangle they share (a duplicate, a fold): their
  // outward orders of it agree, where neighbours' are opposite. The first such run.
  int folded_a = -1;
  size_t folded_run = 0;
  auto outward_parity = [&mesh](const mesh_internal::TetFace& f, int a) {
    int order[3];
    for (int k = 0; k < 3; ++k) {
      order[k] = mesh.tets(mesh_internal::kOutwardFace[f.local][k], f.tet);
    }
    // Rotate so that the smallest vertex, a, comes first: the order is then (a, b, c) or
    // (a, c, b).
    while (order[0] != a) std::rotate(order, order + 1, order + 3);
    return order[1] == f.b;
  };
  for (int a = 0; a < num_vertices; ++a) {
    const int end = table.offsets[a + 1];
    for (int begin = table.offsets[a]; begin < end;) {
      int stop = begin + 1;
      while (stop < end && table.faces[stop].b == table.faces[begin].b &&
             table.faces[stop].c == table.faces[begin].c) {
        ++stop;
      }
      if (stop - begin > 2 && table.faces[begin + 2].tet < worst_tet) {
        worst_tet = table.faces[begin + 2].tet;
        worst_a = a;
        worst_run = static_cast<size_t>(begin);
      }
      if (stop - begin == 2 && folded_a < 0 &&
          outward_parity(table.faces[begin], a) == outward_parity(table.faces[begin + 1], a)) {
        folded_a = a;
        folded_run = static_cast<size_t>(begin);
      }
      begin = stop;
    }
  }
  if (worst_a >= 0) {
    const mesh_internal::TetFace& first = table.faces[worst_run];
    std::ostringstream out;
    out << ElementPrefix(mesh, source, worst_tet) << "shares the triangle (" << worst_a << ' '
        << first.b << ' ' << first.c << ") with elements " << first.tet << " and "
        << table.faces[worst_run + 1].tet
        << ": a triangle can belong to at most two elements (duplicated or overlapping "
           "elements)";
    *error = out.str();
    return false;
  }
  if (folded_a >= 0) {
    const mesh_internal::TetFace& first = table.faces[folded_run];
    const mesh_internal::TetFace& second = table.faces[folded_run + 1];
    std::ostringstream out;
    out << ElementPrefix(mesh, source, second.tet) << "lies on the same side of the triangle ("
        << folded_a << ' ' << first.b << ' ' << first.c << ") as element " << first.tet
        << ", which shares it: the two overlap (a duplicated or folded element)";
    *error = out.str();
    return false;
  }
  return true;
}

}  // namespace aqs
