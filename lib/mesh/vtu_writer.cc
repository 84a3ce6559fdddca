// VTK XML unstructured grid (.vtu) writing, ASCII.

#include <glog/logging.h>

#include <algorithm>
#include <string>
#include <vector>

#include "mesh/mesh_io.h"
#include "mesh/text_io_util.h"
#include "util/atomic_file.h"
#include "util/finite_values.h"
#include "util/number_format.h"

namespace aqs {
namespace {

constexpr int kVtkTetra = 10;
constexpr int kValuesPerLine = 6;

// `text` with the characters that are special in XML attribute values escaped.
std::string XmlEscape(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&apos;";
        break;
      default:
        out.push_back(c);
    }
  }
  return out;
}

void WriteFields(const std::vector<VtuField>& fields, size_t entries, const char* kind,
                 mesh_internal::ChunkedWriter* out) {
  std::string* buffer = out->buffer();
  for (const VtuField& field : fields) {
    CHECK_GE(field.components, 1) << kind << " field '" << field.name << "'";
    CHECK_EQ(field.values.size(), entries * field.components)
        << kind << " field '" << field.name << "' has " << field.values.size()
        << " values; expected " << entries << " entries x " << field.components << " components";
    *buffer += "        <DataArray type=\"Float64\" Name=\"" + XmlEscape(field.name) +
               "\" NumberOfComponents=\"" + std::to_string(field.components) +
               "\" format=\"ascii\">\n";
    const size_t per_line =
        static_cast<size_t>(field.components) * std::max(1, kValuesPerLine / field.components);
    for (size_t i = 0; i < field.values.size(); ++i) {
      buffer->push_back(i % per_line == 0 ? '\n' : ' ');
      AppendDouble(field.values[i], buffer);
      if (i % per_line == per_line - 1) out->MaybeFlush();
    }
    *buffer += "\n        </DataArray>\n";
  }
}

// False with *error naming the field and entry if a value of `fields` is not finite
// (ParaView's ASCII reader stops at "nan" and "inf", and the points of a failed solve
// would be drawn as a valid mesh).
bool FieldsFinite(const std::string& path, const std::vector<VtuField>& fields, const char* kind,
                  std::string* error) {
  for (const VtuField& field : fields) {
    if (field.components < 1) continue;  // CHECKed when written
    const Eigen::Map<const Eigen::MatrixXd> values(
        field.values.data(), field.components,
        static_cast<Eigen::Index>(field.values.size()) / field.components);
    if (!AllFiniteForWriting(path, values,
                             std::string(kind) + " field '" + field.name + "': entry", error)) {
      return false;
    }
  }
  return true;
}

}  // namespace

bool WriteVtu(const std::string& path, const TetMesh& mesh,
              const std::vector<VtuField>& point_fields, const std::vector<VtuField>& cell_fields,
              std::string* error) {
  const int num_points = mesh.num_vertices();
  const int num_cells = mesh.num_tets();
  if (!AllFiniteForWriting(path, mesh.vertices, "vertex", error) ||
      !FieldsFinite(path, point_fields, "point", error) ||
      !FieldsFinite(path, cell_fields, "cell", error)) {
    return false;
  }
  AtomicFileWriter writer(path);
  {
    mesh_internal::ChunkedWriter out(&writer.stream());
    std::string* buffer = out.buffer();
    *buffer +=
        "<?xml version=\"1.0\"?>\n"
        "<VTKFile type=\"UnstructuredGrid\" version=\"0.1\" byte_order=\"LittleEndian\">\n"
        "  <UnstructuredGrid>\n"
        "    <Piece NumberOfPoints=\"" +
        std::to_string(num_points) + "\" NumberOfCells=\"" + std::to_string(num_cells) + "\">\n";

    *buffer += "      <PointData>\n";
    WriteFields(point_fields, num_points, "point", &out);
    *buffer += "      </PointData>\n      <CellData>\n";
    WriteFields(cell_fields, num_cells, "cell", &out);
    *buffer += "      </CellData>\n";

    *buffer +=
        "      <Points>\n"
        "        <DataArray type=\"Float64\" Name=\"Points\" NumberOfComponents=\"3\" "
        "format=\"ascii\">\n";
    for (int v = 0; v < num_points; ++v) {
      for (int i = 0; i < 3; ++i) {
        AppendDouble(mesh.vertices(i, v), buffer);
        buffer->push_back(i == 2 ? '\n' : ' ');
      }
      out.MaybeFlush();
    }
    *buffer +=
        "        </DataArray>\n"
        "      </Points>\n"
        "      <Cells>\n"
        "        <DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n";
    for (int t = 0; t < num_cells; ++t) {
      for (int i = 0; i < 4; ++i) {
        mesh_internal::AppendInt(mesh.tets(i, t), buffer);
        buffer->push_back(i == 3 ? '\n' : ' ');
      }
      out.MaybeFlush();
    }
    *buffer +=
        "        </DataArray>\n"
        "        <DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">\n";
    for (int t = 0; t < num_cells; ++t) {
      mesh_internal::AppendInt(4LL * (t + 1), buffer);
      buffer->push_back(t % 16 == 15 || t + 1 == num_cells ? '\n' : ' ');
      out.MaybeFlush();
    }
    *buffer +=
        "        </DataArray>\n"
        "        <DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">\n";
    for (int t = 0; t < num_cells; ++t) {
      mesh_internal::AppendInt(kVtkTetra, buffer);
      buffer->push_back(t % 32 == 31 || t + 1 == num_cells ? '\n' : ' ');
      out.MaybeFlush();
    }
    *buffer +=
        "        </DataArray>\n"
        "      </Cells>\n"
        "    </Piece>\n"
        "  </UnstructuredGrid>\n"
        "</VTKFile>\n";
  }
  return writer.Commit(error);
}

}  // namespace aqs
