// Wavefront OBJ surface reading and writing.

#include <glog/logging.h>

#include <limits>
#include <string>
#include <vector>

#include "mesh/mesh_io.h"
#include "mesh/text_io_util.h"
#include "util/atomic_file.h"
#include "util/line_reader.h"
#include "util/number_format.h"
#include "util/finite_values.h"

namespace aqs {
namespace {

// A positive face index larger than the vertices defined so far; OBJ readers commonly
// accept vertices defined after the face, so it is checked at the end of the file.
struct PendingIndex {
  int line;
  long long index;
};

}  // namespace

bool ReadObj(const std::string& path, SurfaceMesh* surface, std::string* error) {
  LineReader reader(path);
  if (!reader.ok()) {
    *error = reader.error();
    return false;
  }
  if (mesh_internal::FileLooksBinary(path)) {
    *error = path + ": the file is binary (NUL bytes); OBJ files are text";
    return false;
  }
  std::vector<double> coordinates;
  std::vector<int> face_offsets = {0};
  std::vector<int> face_vertices;
  std::vector<PendingIndex> pending;
  std::vector<std::string> tokens;
  std::string corner;
  while (reader.NextTokens(&tokens, '#')) {
    const std::string& record = tokens[0];
    if (record == "v") {
      // x y z, x y z w or x y z r g b: 3, 4 or 6 numbers.
      if (tokens.size() != 4 && tokens.size() != 5 && tokens.size() != 7) {
        *error = reader.Where(
            "expected 'v x y z [w]' (3 numbers, optionally followed by w or an r g b "
            "colour), got " +
            std::to_string(tokens.size() - 1) + " numbers");
        return false;
      }
      for (size_t i = 1; i < tokens.size(); ++i) {
        double value = 0;
        if (!ParseDouble(tokens[i], &value)) {
          *error = reader.Where("expected a finite number as entry " + std::to_string(i) +
                                " of the vertex record, got " + Quoted(tokens[i]));
          return false;
        }
        if (i <= 3) coordinates.push_back(value);
      }
    } else if (record == "f") {
      if (tokens.size() < 4) {
        *error = reader.Where("a face needs at least 3 corners, got " +
                              std::to_string(tokens.size() - 1));
        return false;
      }
      const long long num_vertices = static_cast<long long>(coordinates.size() / 3);
      for (size_t i = 1; i < tokens.size(); ++i) {
        // 'v', 'v/t', 'v//n' or 'v/t/n': the vertex index is before the first slash.
        const std::string& token = tokens[i];
        const size_t slash = token.find('/');
        corner.assign(token, 0, slash);
        long long index = 0;
        if (!ParseInt64(corner, &index)) {
          *error = reader.Where(
              "expected a face corner 'v', 'v/t', 'v//n' or 'v/t/n' with an "
              "integer vertex index, got " +
              Quoted(token));
          return false;
        }
        if (slash != std::string::npos) {
          // The texture and normal indices must be integers (or empty) too.
          size_t start = slash + 1;
          int parts = 1;
          while (true) {
            const size_t next = token.find('/', start);
            const std::string part =
                token.substr(start, next == std::string::npos ? std::string::npos : next - start);
            long long ignored = 0;
            ++parts;
            if (parts > 3 || (!part.empty() && !ParseInt64(part, &ignored))) {
              *error = reader.Where("malformed face corner " + Quoted(token) +
                                    " (expected 'v', 'v/t', 'v//n' or 'v/t/n')");
              return false;
            }
            if (next == std::string::npos) break;
            start = next + 1;
          }
        }
        long long resolved = 0;
        if (index == 0) {
          *error = reader.Where("face corner " + Quoted(token) +
                                ": vertex index 0 is invalid (OBJ indices start at 1; "
                                "negative ones count back from the last vertex)");
          return false;
        } else if (index < 0) {
          resolved = num_vertices + index;
          if (resolved < 0) {
            *error = reader.Where("face corner " + Quoted(token) + ": relative vertex index " +
                                  std::to_string(index) + " is out of range: only " +
                                  std::to_string(num_vertices) +
                                  " vertices are defined before this line");
            return false;
          }
        } else {
          resolved = index - 1;
          if (resolved >= num_vertices) pending.push_back({reader.line_number(), index});
        }
        if (resolved > std::numeric_limits<int>::max()) {
          *error = reader.Where("vertex index " + std::to_string(index) + " is too large");
          return false;
        }
        face_vertices.push_back(static_cast<int>(resolved));
      }
      face_offsets.push_back(static_cast<int>(face_vertices.size()));
    }
    // Everything else (vt, vn, g, o, s, usemtl, mtllib, l, ...) is ignored.
  }
  if (!reader.ok()) {
    *error = reader.error();
    return false;
  }
  const long long num_vertices = static_cast<long long>(coordinates.size() / 3);
  for (const PendingIndex& p : pending) {
    if (p.index > num_vertices) {
      *error = path + ":" + std::to_string(p.line) + ": face vertex index " +
               std::to_string(p.index) + " is out of range: the file has " +
               std::to_string(num_vertices) + " vertices";
      return false;
    }
  }

  SurfaceMesh result;
  result.vertices = Eigen::Map<const Eigen::Matrix3Xd>(coordinates.data(), 3, num_vertices);
  const int num_polygons = static_cast<int>(face_offsets.size()) - 1;
  size_t num_triangles = 0;
  for (int p = 0; p < num_polygons; ++p) num_triangles += face_offsets[p + 1] - face_offsets[p] - 2;
  result.triangles.resize(3, static_cast<Eigen::Index>(num_triangles));
  result.triangle_face.reserve(num_triangles);
  int k = 0;
  for (int p = 0; p < num_polygons; ++p) {
    const int first = face_offsets[p];
    for (int i = first + 1; i + 1 < face_offsets[p + 1]; ++i) {
      result.triangles.col(k++) << face_vertices[first], face_vertices[i], face_vertices[i + 1];
      result.triangle_face.push_back(p);
    }
  }
  if (num_polygons > 0) {
    result.face_offsets = std::move(face_offsets);
    result.face_vertices = std::move(face_vertices);
  }
  *surface = std::move(result);
  return true;
}

bool WriteObj(const std::string& path, const SurfaceMesh& surface, std::string* error) {
  const int num_vertices = surface.num_vertices();
  if (!AllFiniteForWriting(path, surface.vertices, "vertex", error)) return false;
  auto check_index = [num_vertices](int v) {
    CHECK(v >= 0 && v < num_vertices)
        << "surface index " << v << " out of range [0, " << num_vertices << ")";
  };
  AtomicFileWriter writer(path);
  {
    mesh_internal::ChunkedWriter out(&writer.stream());
    std::string* buffer = out.buffer();
    *buffer += "# written by ActiveQS\n";
    for (int v = 0; v < num_vertices; ++v) {
      *buffer += "v";
      for (int i = 0; i < 3; ++i) {
        buffer->push_back(' ');
        AppendDouble(surface.vertices(i, v), buffer);
      }
      buffer->push_back('\n');
      out.MaybeFlush();
    }
    if (!surface.face_offsets.empty()) {
      CHECK_EQ(surface.face_offsets.front(), 0);
      CHECK_EQ(static_cast<size_t>(surface.face_offsets.back()), surface.face_vertices.size());
      for (int p = 0; p < surface.num_polygons(); ++p) {
        CHECK_GE(surface.face_offsets[p + 1] - surface.face_offsets[p], 3)
            << "polygon " << p << " has fewer than 3 vertices";
        *buffer += "f";
        for (int i = surface.face_offsets[p]; i < surface.face_offsets[p + 1]; ++i) {
          check_index(surface.face_vertices[i]);
          buffer->push_back(' ');
          mesh_internal::AppendInt(surface.face_vertices[i] + 1LL, buffer);
        }
        buffer->push_back('\n');
        out.MaybeFlush();
      }
    } else {
      for (int t = 0; t < surface.num_triangles(); ++t) {
        *buffer += "f";
        for (int i = 0; i < 3; ++i) {
          check_index(surface.triangles(i, t));
          buffer->push_back(' ');
          mesh_internal::AppendInt(surface.triangles(i, t) + 1LL, buffer);
        }
        buffer->push_back('\n');
        out.MaybeFlush();
      }
    }
  }
  return writer.Commit(error);
}

}  // namespace aqs
