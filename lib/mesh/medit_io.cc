// MEDIT ASCII .mesh reading and writing.

#include <limits>
#include <string>
#include <vector>

#include "mesh/mesh_io.h"
#include "mesh/text_io_util.h"
#include "util/atomic_file.h"
#include "util/file_extension.h"
#include "util/line_reader.h"
#include "util/number_format.h"
#include "util/finite_values.h"

namespace aqs {
namespace {

// Sections that are read past: each record has `doubles` floating-point numbers
// followed by `ints` integers.
struct SkippedSection {
  const char* name;
  int doubles;
  int ints;
};

constexpr SkippedSection kSkippedSections[] = {
    {"Triangles", 0, 4},
    {"Edges", 0, 3},
    {"Quadrilaterals", 0, 5},
    {"Hexahedra", 0, 9},
    {"Prisms", 0, 7},
    {"Pyramids", 0, 6},
    {"Corners", 0, 1},
    {"Ridges", 0, 1},
    {"RequiredVertices", 0, 1},
    {"RequiredEdges", 0, 1},
    {"RequiredTriangles", 0, 1},
    {"RequiredQuadrilaterals", 0, 1},
    {"RequiredTetrahedra", 0, 1},
    {"RequiredHexahedra", 0, 1},
    {"Normals", 3, 0},
    {"NormalAtVertices", 0, 2},
    {"Tangents", 3, 0},
    {"TangentAtVertices", 0, 2},
};

class MeditReader {
 public:
  MeditReader(const std::string& path, LineReader* reader)
      : path_(path),
        reader_(reader),
        tokens_(reader, '#'),
        file_size_(mesh_internal::FileSizeBytes(path)) {}

  bool Read(TetMesh* mesh, std::string* error);

 private:
  bool Fail(const std::string& message) {
    *error_ = tokens_.Where(message);
    return false;
  }
  // The next token, which must exist. `what()` says what was expected; it is only
  // called to build an error message, so reading stays free of string building.
  template <typename What>
  const std::string* Expect(const What& what) {
    const std::string* token = tokens_.Next();
    if (token == nullptr) {
      *error_ = mesh_internal::EndOfFileError(*reader_, "expected " + what() +
                                                            ", found the end of the file");
    }
    return token;
  }
  template <typename What>
  bool ExpectInt(const What& what, long long* value) {
    const std::string* token = Expect(what);
    if (token == nullptr) return false;
    if (!ParseInt64(*token, value)) {
      return Fail("expected " + what() + " (an integer), got " + Quoted(*token));
    }
    return true;
  }
  template <typename What>
  bool ExpectDouble(const What& what, double* value) {
    const std::string* token = Expect(what);
    if (token == nullptr) return false;
    if (!ParseDouble(*token, value)) {
      return Fail("expected " + what() + " (a finite number), got " + Quoted(*token));
    }
    return true;
  }
  bool ExpectCount(const std::string& keyword, int tokens_per_record, int* count) {
    long long value = 0;
    if (!ExpectInt([&] { return "the number of records after '" + keyword + "'"; }, &value)) {
      return false;
    }
    if (!mesh_internal::CheckRecordCount(*reader_, value, tokens_per_record, file_size_,
                                         "records in '" + keyword + "'", error_)) {
      return false;
    }
    *count = static_cast<int>(value);
    return true;
  }
  bool ReadVertices();
  bool ReadTetrahedra();
  bool Skip(const SkippedSection& section);

  std::string path_;
  LineReader* reader_;
  mesh_internal::TokenStream tokens_;
  long long file_size_;
  std::string* error_ = nullptr;
  bool have_vertices_ = false;
  bool have_tets_ = false;
  Eigen::Matrix3Xd vertices_;
  Eigen::Matrix4Xi tets_;
  // Line of each element, kept only while the vertex count is unknown (Tetrahedra
  // before Vertices), to name the line of an out-of-range index afterwards.
  std::vector<int> tet_lines_;
};

bool MeditReader::ReadVertices() {
  if (have_vertices_) return Fail("a second 'Vertices' section (only one is allowed)");
  int count = 0;
  if (!ExpectCount("Vertices", 4, &count)) return false;
  vertices_.resize(3, count);
  for (int v = 0; v < count; ++v) {
    static const char* const kAxes[3] = {"x", "y", "z"};
    for (int i = 0; i < 3; ++i) {
      double value = 0;
      auto what = [&] {
        return std::string("the ") + kAxes[i] + " coordinate of vertex " + std::to_string(v + 1) +
               " of " + std::to_string(count) + " in 'Vertices' (records: x y z reference)";
      };
      if (!ExpectDouble(what, &value)) {
        return false;
      }
      vertices_(i, v) = value;
    }
    long long reference = 0;
    auto what = [&] {
      return "the reference of vertex " + std::to_string(v + 1) + " of " + std::to_string(count) +
             " in 'Vertices' (records: x y z reference)";
    };
    if (!ExpectInt(what, &reference)) {
      return false;
    }
  }
  have_vertices_ = true;
  return true;
}

bool MeditReader::ReadTetrahedra() {
  if (have_tets_) return Fail("a second 'Tetrahedra' section (only one is allowed)");
  int count = 0;
  if (!ExpectCount("Tetrahedra", 5, &count)) return false;
  tets_.resize(4, count);
  const long long num_vertices = vertices_.cols();
  if (!have_vertices_) tet_lines_.resize(count);
  for (int t = 0; t < count; ++t) {
    for (int i = 0; i < 4; ++i) {
      long long index = 0;
      auto what = [&] {
        return "vertex index " + std::to_string(i + 1) + " of tetrahedron " +
               std::to_string(t + 1) + " of " + std::to_string(count) +
               " in 'Tetrahedra' (records: 4 vertex indices and a reference)";
      };
      if (!ExpectInt(what, &index)) {
        return false;
      }
      if (index < 1 || (have_vertices_ && index > num_vertices)) {
        return Fail("tetrahedron " + std::to_string(t + 1) + " has vertex index " +
                    std::to_string(index) + " out of range: indices are 1-based and the file has " +
                    (have_vertices_ ? std::to_string(num_vertices) + " vertices"
                                    : std::string("no vertices before it")));
      }
      if (index > std::numeric_limits<int>::max()) {
        return Fail("vertex index " + std::to_string(index) + " is too large");
      }
      tets_(i, t) = static_cast<int>(index - 1);
    }
    if (!have_vertices_) tet_lines_[t] = reader_->line_number();
    long long reference = 0;
    auto what = [&] {
      return "the reference of tetrahedron " + std::to_string(t + 1) + " of " +
             std::to_string(count) + " in 'Tetrahedra' (records: 4 vertex indices and a reference)";
    };
    if (!ExpectInt(what, &reference)) {
      return false;
    }
  }
  have_tets_ = true;
  return true;
}

bool MeditReader::Skip(const SkippedSection& section) {
  int count = 0;
  if (!ExpectCount(section.name, section.doubles + section.ints, &count)) return false;
  for (int r = 0; r < count; ++r) {
    for (int i = 0; i < section.doubles + section.ints; ++i) {
      auto what = [&] {
        return "entry " + std::to_string(i + 1) + " of record " + std::to_string(r + 1) + " of " +
               std::to_string(count) + " in '" + section.name + "'";
      };
      double d = 0;
      long long n = 0;
      if (i < section.doubles ? !ExpectDouble(what, &d) : !ExpectInt(what, &n)) return false;
    }
  }
  return true;
}

bool MeditReader::Read(TetMesh* mesh, std::string* error) {
  error_ = error;
  bool saw_end = false;
  while (!saw_end) {
    const std::string* token = tokens_.Next();
    if (token == nullptr) {
      if (!reader_->ok()) {
        *error = reader_->error();
        return false;
      }
      break;  // A missing End is tolerated.
    }
    const std::string& keyword = *token;
    if (keyword == "MeshVersionFormatted") {
      long long version = 0;
      if (!ExpectInt([] { return std::string("the version after 'MeshVersionFormatted'"); },
                     &version)) {
        return false;
      }
      if (version < 1 || version > 4) {
        return Fail("unsupported MeshVersionFormatted " + std::to_string(version) +
                    " (expected 1 to 4)");
      }
    } else if (keyword == "Dimension") {
      long long dimension = 0;
      if (!ExpectInt([] { return std::string("the dimension after 'Dimension'"); }, &dimension)) {
        return false;
      }
      if (dimension != 3) {
        return Fail("Dimension " + std::to_string(dimension) +
                    " is not supported: tetrahedral meshes need Dimension 3");
      }
    } else if (keyword == "Vertices") {
      if (!ReadVertices()) return false;
    } else if (keyword == "Tetrahedra") {
      if (!ReadTetrahedra()) return false;
    } else if (keyword == "End") {
      saw_end = true;
    } else {
      const SkippedSection* skipped = nullptr;
      for (const SkippedSection& section : kSkippedSections) {
        if (keyword == section.name) skipped = &section;
      }
      if (skipped == nullptr) {
        std::string known = "MeshVersionFormatted, Dimension, Vertices, Tetrahedra, End";
        for (const SkippedSection& section : kSkippedSections) {
          known += std::string(", ") + section.name;
        }
        return Fail("unknown keyword " + Quoted(keyword) + " (expected one of " + known + ")");
      }
      if (!Skip(*skipped)) return false;
    }
  }
  if (!have_vertices_) {
    *error = path_ + ": no 'Vertices' section (a tetrahedral mesh needs its vertices)";
    return false;
  }
  if (!have_tets_) {
    *error = path_ + ": no 'Tetrahedra' section (the file has no volume elements)";
    return false;
  }
  if (!tet_lines_.empty()) {  // Tetrahedra came before Vertices: check the range now.
    const int num_vertices = static_cast<int>(vertices_.cols());
    for (int t = 0; t < tets_.cols(); ++t) {
      for (int i = 0; i < 4; ++i) {
        if (tets_(i, t) >= num_vertices) {
          *error = path_ + ":" + std::to_string(tet_lines_[t]) + ": tetrahedron " +
                   std::to_string(t + 1) + " has vertex index " + std::to_string(tets_(i, t) + 1) +
                   " out of range: indices are 1-based and the file has " +
                   std::to_string(num_vertices) + " vertices";
          return false;
        }
      }
    }
  }
  mesh->vertices = std::move(vertices_);
  mesh->tets = std::move(tets_);
  return true;
}

}  // namespace

bool ReadMeditMesh(const std::string& path, TetMesh* mesh, std::string* error) {
  if (LowercaseExtension(path) == ".meshb") {
    *error = path + ": binary MEDIT files (.meshb) are not supported; convert to ASCII .mesh";
    return false;
  }
  LineReader reader(path);
  if (!reader.ok()) {
    *error = reader.error();
    return false;
  }
  if (mesh_internal::FileLooksBinary(path)) {
    *error = path +
             ": the file is binary (NUL bytes); binary MEDIT (.meshb) is not "
             "supported, convert to ASCII .mesh";
    return false;
  }
  MeditReader medit(path, &reader);
  return medit.Read(mesh, error);
}

bool WriteMeditMesh(const std::string& path, const TetMesh& mesh, std::string* error) {
  if (!AllFiniteForWriting(path, mesh.vertices, "vertex", error)) return false;
  AtomicFileWriter writer(path);
  {
    mesh_internal::ChunkedWriter out(&writer.stream());
    std::string* buffer = out.buffer();
    *buffer += "MeshVersionFormatted 2\n\nDimension 3\n\nVertices\n";
    mesh_internal::AppendInt(mesh.num_vertices(), buffer);
    buffer->push_back('\n');
    for (int v = 0; v < mesh.num_vertices(); ++v) {
      for (int i = 0; i < 3; ++i) {
        AppendDouble(mesh.vertices(i, v), buffer);
        buffer->push_back(' ');
      }
      *buffer += "0\n";
      out.MaybeFlush();
    }
    *buffer += "\nTetrahedra\n";
    mesh_internal::AppendInt(mesh.num_tets(), buffer);
    buffer->push_back('\n');
    for (int t = 0; t < mesh.num_tets(); ++t) {
      for (int i = 0; i < 4; ++i) {
        mesh_internal::AppendInt(mesh.tets(i, t) + 1LL, buffer);
        buffer->push_back(' ');
      }
      *buffer += "0\n";
      out.MaybeFlush();
    }
    *buffer += "\nEnd\n";
  }
  return writer.Commit(error);
}

}  // namespace aqs
