// TetGen .node/.ele reading.

#include <limits>
#include <string>
#include <vector>

#include "mesh/mesh_io.h"
#include "mesh/text_io_util.h"
#include "util/file_extension.h"
#include "util/line_reader.h"

namespace aqs {
namespace {

bool OpenText(const std::string& path, LineReader* reader, std::string* error) {
  if (!reader->ok()) {
    *error = reader->error();
    return false;
  }
  if (mesh_internal::FileLooksBinary(path)) {
    *error = path + ": the file is binary (NUL bytes); TetGen files are text";
    return false;
  }
  return true;
}

// Parses tokens[i] as an integer of the named field; on failure sets *error.
bool TokenInt(const LineReader& reader, const std::vector<std::string>& tokens, size_t i,
              const char* field, long long* value, std::string* error) {
  if (!ParseInt64(tokens[i], value)) {
    *error = reader.Where(std::string("expected ") + field + " (an integer) as entry " +
                          std::to_string(i + 1) + ", got " + Quoted(tokens[i]));
    return false;
  }
  return true;
}

// After the header's records nothing but comments and blank lines may follow: more
// records than the header counts means the count is wrong (or two files were joined),
// and the extra ones would be dropped without a word.
bool ExpectEndOfFile(LineReader* reader, long long count, const char* what,
                     std::vector<std::string>* tokens, std::string* error) {
  if (reader->NextTokens(tokens, '#')) {
    *error = reader->Where("content after the " + std::to_string(count) + " " + what +
                           " the header declares: the header's count is smaller than the data");
    return false;
  }
  if (!reader->ok()) {
    *error = reader->error();
    return false;
  }
  return true;
}

bool TokenDouble(const LineReader& reader, const std::vector<std::string>& tokens, size_t i,
                 const char* field, double* value, std::string* error) {
  if (!ParseDouble(tokens[i], value)) {
    *error = reader.Where(std::string("expected ") + field + " (a finite number) as entry " +
                          std::to_string(i + 1) + ", got " + Quoted(tokens[i]));
    return false;
  }
  return true;
}

bool ReadNodeFile(const std::string& path, Eigen::Matrix3Xd* vertices, int* base,
                  std::string* error) {
  LineReader reader(path);
  if (!OpenText(path, &reader, error)) return false;
  std::vector<std::string> tokens;
  if (!reader.NextTokens(&tokens, '#')) {
    *error = mesh_internal::EndOfFileError(
        reader,
        "expected the .node header '<#points> <dimension 3> <#attributes> "
        "<#boundary markers 0|1>', found the end of the file");
    return false;
  }
  if (tokens.size() != 4) {
    *error = reader.Where(
        "expected the .node header '<#points> <dimension 3> <#attributes> "
        "<#boundary markers 0|1>' (4 numbers), got " +
        std::to_string(tokens.size()) + " tokens");
    return false;
  }
  long long count = 0, dimension = 0, attributes = 0, markers = 0;
  if (!TokenInt(reader, tokens, 0, "the number of points", &count, error) ||
      !TokenInt(reader, tokens, 1, "the dimension", &dimension, error) ||
      !TokenInt(reader, tokens, 2, "the number of attributes", &attributes, error) ||
      !TokenInt(reader, tokens, 3, "the number of boundary markers", &markers, error)) {
    return false;
  }
  if (dimension != 3) {
    *error = reader.Where("dimension " + std::to_string(dimension) +
                          " is not supported: tetrahedral meshes need dimension 3");
    return false;
  }
  if (markers != 0 && markers != 1) {
    *error = reader.Where("the number of boundary markers must be 0 or 1, got " +
                          std::to_string(markers));
    return false;
  }
  const long long file_size = mesh_internal::FileSizeBytes(path);
  if (!mesh_internal::CheckRecordCount(reader, count, 4, file_size, "points", error)) {
    return false;
  }
  if (attributes < 0 || (file_size >= 0 && attributes > file_size)) {
    *error = reader.Where("invalid number of attributes " + std::to_string(attributes));
    return false;
  }
  const size_t max_tokens = 4 + static_cast<size_t>(attributes + markers);
  vertices->resize(3, static_cast<Eigen::Index>(count));
  for (long long v = 0; v < count; ++v) {
    if (!reader.NextTokens(&tokens, '#')) {
      *error = mesh_internal::EndOfFileError(
          reader, "expected point " + std::to_string(v + 1) + " of " + std::to_string(count) +
                      " ('index x y z ...'), found the end of the file");
      return false;
    }
    if (tokens.size() < 4 || tokens.size() > max_tokens) {
      *error = reader.Where("expected 'index x y z' followed by " + std::to_string(attributes) +
                            " attributes and " + std::to_string(markers) + " boundary markers (" +
                            std::to_string(max_tokens) + " entries), got " +
                            std::to_string(tokens.size()));
      return false;
    }
    long long index = 0;
    if (!TokenInt(reader, tokens, 0, "the point index", &index, error)) return false;
    if (v == 0) {
      if (index != 0 && index != 1) {
        *error = reader.Where(
            "the first point index must be 0 or 1 (it sets the index base), "
            "got " +
            std::to_string(index));
        return false;
      }
      *base = static_cast<int>(index);
    } else if (index != *base + v) {
      *error = reader.Where("expected point index " + std::to_string(*base + v) +
                            " (points are numbered consecutively), got " + std::to_string(index));
      return false;
    }
    static const char* const kAxes[3] = {"the x coordinate", "the y coordinate",
                                         "the z coordinate"};
    for (int i = 0; i < 3; ++i) {
      double value = 0;
      if (!TokenDouble(reader, tokens, i + 1, kAxes[i], &value, error)) return false;
      (*vertices)(i, v) = value;
    }
    for (size_t i = 4; i < tokens.size(); ++i) {
      double value = 0;
      if (!TokenDouble(reader, tokens, i, "an attribute or boundary marker", &value, error)) {
        return false;
      }
    }
  }
  return ExpectEndOfFile(&reader, count, "points", &tokens, error);
}

bool ReadEleFile(const std::string& path, int base, int num_vertices, Eigen::Matrix4Xi* tets,
                 std::string* error) {
  LineReader reader(path);
  if (!OpenText(path, &reader, error)) return false;
  std::vector<std::string> tokens;
  static const char kHeader[] =
      "the .ele header '<#tetrahedra> <nodes per tetrahedron 4|10> "
      "<#attributes>'";
  if (!reader.NextTokens(&tokens, '#')) {
    *error = mesh_internal::EndOfFileError(
        reader, std::string("expected ") + kHeader + ", found the end of the file");
    return false;
  }
  if (tokens.size() != 3) {
    *error = reader.Where(std::string("expected ") + kHeader + " (3 numbers), got " +
                          std::to_string(tokens.size()) + " tokens");
    return false;
  }
  long long count = 0, nodes = 0, attributes = 0;
  if (!TokenInt(reader, tokens, 0, "the number of tetrahedra", &count, error) ||
      !TokenInt(reader, tokens, 1, "the number of nodes per tetrahedron", &nodes, error) ||
      !TokenInt(reader, tokens, 2, "the number of attributes", &attributes, error)) {
    return false;
  }
  if (nodes != 4 && nodes != 10) {
    *error = reader.Where("the number of nodes per tetrahedron must be 4 or 10, got " +
                          std::to_string(nodes));
    return false;
  }
  const long long file_size = mesh_internal::FileSizeBytes(path);
  if (!mesh_internal::CheckRecordCount(reader, count, 1 + static_cast<int>(nodes), file_size,
                                       "tetrahedra", error)) {
    return false;
  }
  if (attributes < 0 || (file_size >= 0 && attributes > file_size)) {
    *error = reader.Where("invalid number of attributes " + std::to_string(attributes));
    return false;
  }
  const size_t min_tokens = 1 + static_cast<size_t>(nodes);
  const size_t max_tokens = min_tokens + static_cast<size_t>(attributes);
  tets->resize(4, static_cast<Eigen::Index>(count));
  for (long long t = 0; t < count; ++t) {
    if (!reader.NextTokens(&tokens, '#')) {
      *error = mesh_internal::EndOfFileError(
          reader, "expected tetrahedron " + std::to_string(t + 1) + " of " +
                      std::to_string(count) + " ('index' and " + std::to_string(nodes) +
                      " node indices), found the end of the file");
      return false;
    }
    if (tokens.size() < min_tokens || tokens.size() > max_tokens) {
      *error = reader.Where("expected 'index' and " + std::to_string(nodes) +
                            " node indices followed by " + std::to_string(attributes) +
                            " attributes, got " + std::to_string(tokens.size()) + " entries");
      return false;
    }
    long long index = 0;
    if (!TokenInt(reader, tokens, 0, "the tetrahedron index", &index, error)) return false;
    if (index != base + t) {
      *error = reader.Where("expected tetrahedron index " + std::to_string(base + t) +
                            " (tetrahedra are numbered consecutively from the .node file's "
                            "base " + std::to_string(base) + "), got " + std::to_string(index));
      return false;
    }
    for (size_t i = 1; i < min_tokens; ++i) {
      long long node = 0;
      if (!TokenInt(reader, tokens, i, "a node index", &node, error)) return false;
      if (node < base || node >= base + static_cast<long long>(num_vertices)) {
        *error =
            reader.Where("tetrahedron " + std::to_string(index) + " has node index " +
                         std::to_string(node) + " out of range: the .node file has " +
                         std::to_string(num_vertices) + " points numbered from " +
                         std::to_string(base) + " to " + std::to_string(base + num_vertices - 1LL));
        return false;
      }
      if (i <= 4) (*tets)(static_cast<int>(i) - 1, t) = static_cast<int>(node - base);
    }
    for (size_t i = min_tokens; i < tokens.size(); ++i) {
      double value = 0;
      if (!TokenDouble(reader, tokens, i, "an attribute", &value, error)) return false;
    }
  }
  return ExpectEndOfFile(&reader, count, "tetrahedra", &tokens, error);
}

}  // namespace

bool ReadTetgenMesh(const std::string& path, TetMesh* mesh, std::string* error) {
  const std::string extension = LowercaseExtension(path);
  std::string stem = path;
  // The pair's extensions in the case of the one given (T.NODE goes with T.ELE).
  std::string node = ".node", ele = ".ele";
  if (extension == ".node" || extension == ".ele") {
    stem.resize(path.size() - extension.size());
    if (path.substr(stem.size()) != extension) {
      node = ".NODE";
      ele = ".ELE";
    }
  }
  Eigen::Matrix3Xd vertices;
  Eigen::Matrix4Xi tets;
  int base = 0;
  if (!ReadNodeFile(stem + node, &vertices, &base, error)) return false;
  if (!ReadEleFile(stem + ele, base, static_cast<int>(vertices.cols()), &tets, error)) {
    return false;
  }
  mesh->vertices = std::move(vertices);
  mesh->tets = std::move(tets);
  return true;
}

}  // namespace aqs
