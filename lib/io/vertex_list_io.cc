#include "io/vertex_list_io.h"

#include <sstream>

#include "geometry/points_near_model.h"
#include "util/atomic_file.h"
#include "util/line_reader.h"

namespace aqs {
namespace {

// Parses a vertex index token on the reader's current line; checks range and repeats.
bool ParseVertexIndex(const LineReader& reader, const std::string& token, int num_vertices,
                      std::vector<int>* first_line, int* index, std::string* error) {
  if (!ParseInt(token, index)) {
    *error = reader.Where("expected a vertex index (a non-negative integer), got " + Quoted(token));
    return false;
  }
  if (*index < 0 || *index >= num_vertices) {
    std::ostringstream out;
    out << "vertex index " << *index << " is outside the mesh's range [0, " << num_vertices
        << ")";
    *error = reader.Where(out.str());
    return false;
  }
  if ((*first_line)[*index] > 0) {
    std::ostringstream out;
    out << "vertex " << *index << " is listed again (first on line " << (*first_line)[*index]
        << ")";
    *error = reader.Where(out.str());
    return false;
  }
  (*first_line)[*index] = reader.line_number();
  return true;
}

}  // namespace

bool ReadFixedVertices(const std::string& path, const Eigen::Matrix3Xd& rest_positions,
                       BoundaryConditions* bc, std::string* error) {
  LineReader reader(path);
  if (!reader.ok()) {
    *error = reader.error();
    return false;
  }
  const int num_vertices = static_cast<int>(rest_positions.cols());
  std::vector<int> first_line(num_vertices, 0);
  std::vector<int> vertices;
  std::vector<Eigen::Vector3d> positions;
  std::vector<std::string> tokens;
  while (reader.NextTokens(&tokens)) {
    if (tokens.size() != 1 && tokens.size() != 4) {
      *error = reader.Where("expected 'index' or 'index x y z', got " +
                            std::to_string(tokens.size()) + " fields");
      return false;
    }
    int v = 0;
    if (!ParseVertexIndex(reader, tokens[0], num_vertices, &first_line, &v, error)) return false;
    Eigen::Vector3d p = rest_positions.col(v);
    if (tokens.size() == 4) {
      for (int c = 0; c < 3; ++c) {
        if (!ParseDouble(tokens[1 + c], &p[c])) {
          *error = reader.Where("expected a finite coordinate, got " + Quoted(tokens[1 + c]));
          return false;
        }
      }
      // As every target is checked against the model (a position 1e200 away overflowed
      // the solve, and the message named an output field).
      if (!CheckPointsNearModel(reader.Where("the position of vertex " + tokens[0]),
                                rest_positions, p, error)) {
        return false;
      }
    }
    vertices.push_back(v);
    positions.push_back(p);
  }
  if (!reader.ok()) {
    *error = reader.error();
    return false;
  }
  bc->vertices = vertices;
  bc->positions.resize(3, vertices.size());
  for (size_t i = 0; i < positions.size(); ++i) bc->positions.col(i) = positions[i];
  return true;
}

bool ReadVertexList(const std::string& path, int num_vertices, std::vector<int>* vertices,
                    std::string* error) {
  LineReader reader(path);
  if (!reader.ok()) {
    *error = reader.error();
    return false;
  }
  std::vector<int> first_line(num_vertices, 0);
  std::vector<int> out;
  std::vector<std::string> tokens;
  while (reader.NextTokens(&tokens)) {
    if (tokens.size() != 1) {
      *error = reader.Where("expected one vertex index per line, got " +
                            std::to_string(tokens.size()) + " fields");
      return false;
    }
    int v = 0;
    if (!ParseVertexIndex(reader, tokens[0], num_vertices, &first_line, &v, error)) return false;
    out.push_back(v);
  }
  if (!reader.ok()) {
    *error = reader.error();
    return false;
  }
  *vertices = out;
  return true;
}

bool WriteVertexList(const std::string& path, const std::vector<int>& vertices,
                     const std::string& comment, std::string* error) {
  std::string text;
  if (!comment.empty()) text += "# " + comment + "\n";
  for (int v : vertices) text += std::to_string(v) + "\n";
  return WriteFileAtomically(path, text, error);
}

}  // namespace aqs
